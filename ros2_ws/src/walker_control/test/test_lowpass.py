"""The digital low-pass filter: DC gain, designed corner, state initialisation, refusals."""

import math

import numpy as np
import pytest
from scipy import signal

from walker_control.core.config import load_controller_settings
from walker_control.core.lowpass import FilterDesignError, LowPassFilter, design_lowpass_sos

T = 0.002
DESIGNS = [(kind, order, corner) for kind in ('butterworth', 'critical', 'bessel')
           for order in (1, 2, 3, 4, 6) for corner in (3.0, 8.0, 30.0, 300.0)]


@pytest.mark.parametrize('kind, order, corner', DESIGNS)
def test_dc_gain_is_one(kind, order, corner):
    sos = design_lowpass_sos(order, corner, T, kind)
    _, response = signal.freqz_sos(sos, worN=[0.0])
    assert abs(response[0] - 1.0) < 1e-12


@pytest.mark.parametrize('kind, order, corner', DESIGNS)
def test_gain_at_the_designed_corner(kind, order, corner):
    sos = design_lowpass_sos(order, corner, T, kind)
    _, response = signal.freqz_sos(sos, worN=[corner * T])
    # Butterworth and Bessel: half power at the corner; critically damped: n poles at it.
    expected = 2.0 ** (-order / 2.0) if kind == 'critical' else math.sqrt(0.5)
    assert abs(abs(response[0]) - expected) < 1e-9


@pytest.mark.parametrize('kind, order, corner', DESIGNS)
def test_gain_falls_above_the_corner(kind, order, corner):
    sos = design_lowpass_sos(order, corner, T, kind)
    w = np.linspace(corner, 0.99 * math.pi / T, 400)
    _, response = signal.freqz_sos(sos, worN=w * T)
    assert np.all(np.diff(np.abs(response)) <= 1e-12)


def _settling_after(lowpass: LowPassFilter, tolerance: float) -> float:
    """Time [s] from the end of a 90 deg move until its filtered copy stays near the end.

    The move: 1.8 s rest to rest, a trapezoidal speed with 0.55 s ramps (a coarse sweep);
    near: within ``tolerance`` [rad].
    """
    t = np.arange(0.0, 5.0, T)
    speed = np.clip(np.minimum(t, 1.8 - t) / 0.55, 0.0, 1.0)
    position = np.cumsum(speed) * T
    position *= (math.pi / 2) / position[-1]
    filtered = np.array([lowpass.update(v) for v in position])
    outside = np.nonzero(np.abs(filtered - position[-1]) > tolerance)[0]
    return t[outside[-1]] - 1.8


def test_the_files_joint_1_filter_settles_sooner_for_the_same_attenuation_of_its_mode():
    """Why joint 1 uses a Bessel filter: the attenuation, about half the settling.

    As much attenuation at the held arm's 18 rad/s mode as the critically damped 4th-order
    filter at 8 rad/s of eq (14), and about half its settling after a sweep.
    """
    settings = load_controller_settings().control.filter
    bessel = LowPassFilter(settings.order[0], settings.corner[0], T, settings.kind)
    critical = LowPassFilter(4, 8.0, T, 'critical')
    assert settings.kind == 'bessel'
    gains = [20 * math.log10(abs(f.frequency_response(np.array([18.0]))[0]))
             for f in (bessel, critical)]
    assert gains[0] <= gains[1] + 0.5
    assert _settling_after(bessel, 1e-3) < 0.6 * _settling_after(critical, 1e-3)


def test_update_matches_scipy_sosfilt():
    lowpass = LowPassFilter(4, 8.0, T, 'critical')
    x = np.random.default_rng(1).normal(size=500)
    ours = np.array([lowpass.update(v) for v in x])
    np.testing.assert_allclose(ours, signal.sosfilt(lowpass.sos, x), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize('kind', ['butterworth', 'critical', 'bessel'])
def test_reset_to_passes_a_constant_without_transient(kind):
    lowpass = LowPassFilter(4, 8.0, T, kind)
    lowpass.reset_to(3.7)
    out = [lowpass.update(3.7) for _ in range(2000)]
    np.testing.assert_allclose(out, 3.7, rtol=1e-10)


def test_without_reset_a_constant_input_has_a_transient():
    lowpass = LowPassFilter(4, 8.0, T, 'critical')
    assert abs(lowpass.update(3.7) - 3.7) > 3.0


def test_order_zero_is_a_pass_through():
    lowpass = LowPassFilter(0, 0.0, T)
    assert lowpass.is_passthrough
    assert [lowpass.update(v) for v in (1.0, -2.0, 5.5)] == [1.0, -2.0, 5.5]
    np.testing.assert_array_equal(lowpass.frequency_response(np.array([1.0, 100.0])), 1.0)


@pytest.mark.parametrize('order, corner, sample_time, kind, words', [
    (9, 8.0, T, 'critical', 'order'),
    (-1, 8.0, T, 'critical', 'order'),
    (2.0, 8.0, T, 'critical', 'order'),
    (True, 8.0, T, 'critical', 'order'),
    (2, 0.0, T, 'critical', 'corner'),
    (2, math.nan, T, 'critical', 'corner'),
    (2, 2000.0, T, 'critical', 'Nyquist'),
    (2, 8.0, 0.0, 'critical', 'sample time'),
    (2, 8.0, math.inf, 'critical', 'sample time'),
    (2, 8.0, T, 'chebyshev', 'kind'),
])
def test_bad_designs_are_refused(order, corner, sample_time, kind, words):
    with pytest.raises(FilterDesignError, match=words):
        design_lowpass_sos(order, corner, sample_time, kind)


def test_the_parameter_file_filters_joint_1_harder_than_joints_2_and_3():
    """Paper section 3: J1 higher order and lower corner; J4, J5 unfiltered; modes attenuated."""
    settings = load_controller_settings()
    order, corner = settings.control.filter.order, settings.control.filter.corner
    assert order[0] > order[1] == order[2] > 0 and order[3] == order[4] == 0
    assert corner[0] < corner[1] == corner[2]
    modes = settings.robot.flexibility
    filters = [LowPassFilter(order[i], corner[i], settings.sample_time,
                             settings.control.filter.kind) for i in range(3)]
    j1_mode = abs(filters[0].frequency_response(np.array([modes.joint1_mode]))[0])
    j23_mode = [abs(f.frequency_response(np.array([modes.joints23_mode]))[0])
                for f in filters[1:]]
    assert 20 * math.log10(j1_mode) < -20.0
    assert all(20 * math.log10(g) < -12.0 for g in j23_mode)
