"""The input shapers: what Singer and Seering's theory says of each, on the sample grid too."""

import math

import numpy as np
import pytest

from walker_control.core.input_shaping import (
    DiscreteShaper, Shaper, ShaperDesignError, ShaperKind, convolve, design_shaper, ei,
    residual_vibration, specified_insensitivity, zv, zvd)
from walker_control.core.inputs import Setpoint
from walker_control.core.reference_shaping import InputShapedSetpoint

SAMPLE_TIME = 0.002
MODES = [(18.0, 0.0), (18.0, 0.05), (9.0, 0.02), (80.0, 0.1)]


def _si(frequency, damping):
    return specified_insensitivity(0.85 * frequency, 1.15 * frequency, SAMPLE_TIME, 0.05,
                                   (0.0, damping))


def _damped_period(frequency, damping):
    return 2.0 * math.pi / (frequency * math.sqrt(1.0 - damping ** 2))


@pytest.mark.parametrize('frequency,damping', MODES)
@pytest.mark.parametrize('design', ['zv', 'zvd', 'ei', 'si'])
def test_impulses_are_positive_and_sum_to_one(design, frequency, damping):
    shaper = {'zv': zv, 'zvd': zvd, 'ei': ei, 'si': _si}[design](frequency, damping)
    assert sum(shaper.amplitudes) == pytest.approx(1.0, abs=1e-12)
    assert min(shaper.amplitudes) > 0.0
    assert shaper.times[0] == 0.0
    assert all(b > a for a, b in zip(shaper.times, shaper.times[1:], strict=False))


@pytest.mark.parametrize('frequency,damping', MODES)
@pytest.mark.parametrize('design', [zv, zvd, ei])
def test_residual_matches_the_closed_form_and_a_simulated_mode(design, frequency, damping):
    """V(w, z) of the library equals the mode's amplitude after the impulses, simulated."""
    shaper = design(frequency, damping)
    for w in np.linspace(0.7 * frequency, 1.3 * frequency, 13):
        wdw = w * math.sqrt(1.0 - damping ** 2)
        # amplitude of the free vibration after the impulses, against one unit impulse at the end
        x = v = 0.0
        for t, a in zip(shaper.times, shaper.amplitudes, strict=True):
            tau = shaper.duration - t
            decay = math.exp(-damping * w * tau)
            x += a * decay * math.sin(wdw * tau) / wdw
            v += a * decay * (math.cos(wdw * tau) - damping * w / wdw * math.sin(wdw * tau))
        simulated = math.hypot(x * wdw, v + damping * w * x)  # one unit impulse: 1
        assert residual_vibration(shaper, w, damping) == pytest.approx(simulated, abs=1e-9)


@pytest.mark.parametrize('frequency,damping', MODES)
def test_zero_vibration_shapers_cancel_the_design_mode(frequency, damping):
    assert zv(frequency, damping).residual(frequency, damping) == pytest.approx(0.0, abs=1e-12)
    shaper = zvd(frequency, damping)
    assert shaper.residual(frequency, damping) == pytest.approx(0.0, abs=1e-12)
    step = 1e-4 * frequency
    slope = (shaper.residual(frequency + step, damping)
             - shaper.residual(frequency - step, damping)) / (2 * step)
    assert abs(slope) * frequency < 1e-6  # zero derivative: flat at the design frequency


@pytest.mark.parametrize('frequency,damping', MODES)
def test_durations_are_what_theory_says(frequency, damping):
    period = _damped_period(frequency, damping)
    assert zv(frequency, damping).duration == pytest.approx(period / 2.0, rel=1e-12)
    assert zvd(frequency, damping).duration == pytest.approx(period, rel=1e-12)
    assert ei(frequency, damping).duration == pytest.approx(period, rel=1e-12)


def test_undamped_ei_is_the_closed_form():
    shaper = ei(18.0, 0.0, 0.05)
    assert shaper.amplitudes == pytest.approx((1.05 / 4, 0.95 / 2, 1.05 / 4))


@pytest.mark.parametrize('frequency,damping', MODES)
def test_ei_holds_its_tolerance_over_a_wider_range_than_zvd(frequency, damping):
    """EI: V = Vtol at the design frequency, its hump there, under Vtol wider than ZVD.

    Damped, the hump's top lies within a per cent of the frequency and 0.1 % of Vtol of the
    design point (the design fixes V there and the two zeros, not the top itself).
    """
    shaper = ei(frequency, damping, 0.05)
    assert shaper.residual(frequency, damping) == pytest.approx(0.05, abs=1e-9)
    grid = np.linspace(0.5, 1.5, 2001) * frequency

    def width(s):
        inside = grid[s.residual(grid, damping) <= 0.05 + 1e-9]
        return inside.max() - inside.min()

    assert width(shaper) > 1.3 * width(zvd(frequency, damping))
    hump = shaper.residual(np.linspace(0.9, 1.1, 201) * frequency, damping)
    assert hump.max() <= 0.05 * 1.001


@pytest.mark.parametrize('frequency,damping', MODES[:3])
def test_si_keeps_the_residual_under_its_tolerance_over_its_range(frequency, damping):
    shaper = _si(frequency, damping)
    dense = np.linspace(0.85, 1.15, 601) * frequency
    for z in (0.0, damping):
        assert np.all(shaper.residual(dense, z) <= 0.05 + 2e-3)
    # on the grid, and no longer than ZVD-over-the-range's cousins need: about one period
    assert shaper.times == pytest.approx(np.round(np.array(shaper.times) / SAMPLE_TIME)
                                         * SAMPLE_TIME)
    assert shaper.duration < 1.1 * _damped_period(frequency, damping)


def test_si_is_shorter_for_a_narrower_range():
    narrow = specified_insensitivity(17.0, 19.0, SAMPLE_TIME, 0.05)
    wide = specified_insensitivity(12.0, 24.0, SAMPLE_TIME, 0.05)
    assert narrow.duration < wide.duration


def test_multi_mode_convolution_multiplies_the_residuals():
    low, high = zvd(18.0, 0.05), zv(80.0, 0.05)
    both = convolve(low, high)
    assert sum(both.amplitudes) == pytest.approx(1.0)
    assert both.duration == pytest.approx(low.duration + high.duration)
    grid = np.linspace(5.0, 120.0, 50)
    assert both.residual(grid, 0.05) == pytest.approx(
        low.residual(grid, 0.05) * high.residual(grid, 0.05), abs=1e-9)


@pytest.mark.parametrize('kind', [ShaperKind.ZV, ShaperKind.ZVD, ShaperKind.EI, ShaperKind.SI])
@pytest.mark.parametrize('frequency', [18.0, 17.3, 11.1])
def test_a_step_through_the_discrete_shaper_reaches_the_step_exactly(kind, frequency):
    shaper = design_shaper(kind, frequency, 0.05, 0.05, 0.15, SAMPLE_TIME)
    discrete = DiscreteShaper(shaper, SAMPLE_TIME)
    discrete.reset_to(0.3)
    out = discrete.filter([1.3] * (len(discrete.taps) + 5))
    assert out[len(discrete.taps) - 1:] == pytest.approx(1.3, abs=1e-12)
    assert np.all(np.diff(out) >= -1e-15)  # positive impulses: no overshoot, no reversal
    assert discrete.duration <= shaper.duration + SAMPLE_TIME
    # split impulses keep each impulse's time centroid: the mean delay is the shaper's
    assert np.dot(discrete.taps, np.arange(len(discrete.taps))) * SAMPLE_TIME \
        == pytest.approx(shaper.delay, abs=1e-12)


def test_discrete_shaper_cancels_the_mode_on_the_grid():
    """Off-grid impulses split between samples still leave the mode nearly quiet."""
    shaper = zvd(17.3, 0.05)
    discrete = Shaper(tuple(DiscreteShaper(shaper, SAMPLE_TIME).taps),
                      tuple(np.arange(len(DiscreteShaper(shaper, SAMPLE_TIME).taps))
                            * SAMPLE_TIME))
    assert discrete.residual(17.3, 0.05) < 0.002


def test_held_samples_advance_the_shaper_in_time():
    shaper = zv(18.0, 0.0)
    one, many = DiscreteShaper(shaper, SAMPLE_TIME), DiscreteShaper(shaper, SAMPLE_TIME)
    for _ in range(10):
        one.update(1.0)
    many.update(1.0, samples=10)
    assert many.output == one.output


def test_the_shaped_setpoint_keeps_velocity_the_derivative_of_position():
    shaped = InputShapedSetpoint(zvd(18.0, 0.05), SAMPLE_TIME)
    shaped.reset_to(0.0, 0.0)
    t = np.arange(600) * SAMPLE_TIME
    positions, velocities = [], []
    for time in t:
        out = shaped.update(Setpoint(position=0.5 * time ** 2, velocity=time, acceleration=1.0,
                                     effort=2.0))
        positions.append(out.position)
        velocities.append(out.velocity)
    assert np.gradient(positions, SAMPLE_TIME)[300:-1] == pytest.approx(velocities[300:-1],
                                                                         abs=1e-3)
    assert out.acceleration == pytest.approx(1.0)
    assert out.effort == pytest.approx(2.0)


@pytest.mark.parametrize('call', [
    lambda: zv(0.0), lambda: zvd(-1.0), lambda: zv(18.0, 1.0), lambda: ei(18.0, 0.0, 0.0),
    lambda: specified_insensitivity(20.0, 10.0, SAMPLE_TIME),
    lambda: specified_insensitivity(10.0, 2000.0, SAMPLE_TIME),
    lambda: design_shaper(ShaperKind.ZV, 2000.0, 0.0, 0.05, 0.15, SAMPLE_TIME),
    lambda: design_shaper(ShaperKind.SI, 18.0, 0.0, 0.05, 0.0, SAMPLE_TIME)])
def test_bad_designs_are_refused_with_a_reason(call):
    with pytest.raises(ShaperDesignError):
        call()
