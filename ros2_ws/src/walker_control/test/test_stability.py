"""Eq (14), the Routh-Hurwitz conditions (15)/(16) and the poles of the sampled loop."""

import itertools

import numpy as np
import pytest
from numpy.polynomial import polynomial as npp

from walker_control.core.stability import (
    LoopDesign, UnstableLoopError, check_loop, discrete_closed_loop_poles, eq14_poles,
    eq14_transfer_function, eq15_margin, eq16_margin, inertia_ratio_grid, pole_damping,
    routh_array, routh_hurwitz_stable)

KA = [0.0, 0.25, 0.5, 1.0, 2.0, 4.0]
RATIO = [0.1, 0.2, 0.3, 0.45, 0.55, 0.7, 0.9, 1.2, 1.6, 2.5]  # wc / wf
ZETA = [0.3, 0.7, 1.0, 1.5]


def loop_from_the_block_diagram(wc, zc, wf, Ka):
    """Eq (14) derived again: s^2 theta = F(s) [u - Ka s^2 theta], F = wf^2/(s + wf)^2.

    With u = (s^2 + 2 zc wc s + wc^2) theta_r - (2 zc wc s + wc^2) theta, multiply by
    (s + wf)^2: theta [s^2 (s + wf)^2 + wf^2 (Ka s^2 + 2 zc wc s + wc^2)]
    = wf^2 (s^2 + 2 zc wc s + wc^2) theta_r. Polynomials here are lowest power first.
    """
    s2 = [0.0, 0.0, 1.0]
    filter_denominator = npp.polypow([wf, 1.0], 2)
    feedback = [wc ** 2, 2 * zc * wc, Ka]
    denominator = npp.polyadd(npp.polymul(s2, filter_denominator),
                              npp.polymul([wf ** 2], feedback))
    numerator = npp.polymul([wf ** 2], [wc ** 2, 2 * zc * wc, 1.0])
    return numerator[::-1], denominator[::-1]


@pytest.mark.parametrize('Ka, ratio, zc', itertools.product(KA, RATIO[::3], ZETA))
def test_eq14_as_printed_is_the_block_diagram(Ka, ratio, zc):
    wf = 10.0
    numerator, denominator = eq14_transfer_function(ratio * wf, zc, wf, Ka)
    expected_numerator, expected_denominator = loop_from_the_block_diagram(ratio * wf, zc, wf,
                                                                           Ka)
    np.testing.assert_allclose(numerator, expected_numerator, rtol=1e-12)
    np.testing.assert_allclose(denominator, expected_denominator, rtol=1e-12)


def test_eq14_has_unit_dc_gain():
    numerator, denominator = eq14_transfer_function(2.0, 1.0, 10.0, 0.5)
    assert numerator[-1] == pytest.approx(denominator[-1])


def _away_from_the_boundary(Ka, ratio, zc):
    return abs(eq15_margin(ratio, zc, 1.0, Ka)) > 1e-3


GRID = [case for case in itertools.product(KA, RATIO, ZETA) if _away_from_the_boundary(*case)]


@pytest.mark.parametrize('Ka, ratio, zc', GRID)
def test_eq15_agrees_with_routh_hurwitz_and_with_the_poles(Ka, ratio, zc):
    wf = 7.0
    wc = ratio * wf
    denominator = eq14_transfer_function(wc, zc, wf, Ka)[1]
    by_poles = bool(np.all(eq14_poles(wc, zc, wf, Ka).real < 0.0))
    assert routh_hurwitz_stable(denominator) == by_poles
    assert (eq15_margin(wc, zc, wf, Ka) > 0.0) == by_poles


def test_the_grid_contains_both_verdicts():
    verdicts = {eq15_margin(r, z, 1.0, k) > 0 for k, r, z in GRID}
    assert verdicts == {True, False}


@pytest.mark.parametrize('Ka, ratio', itertools.product(KA, RATIO))
def test_eq16_is_eq15_at_unit_damping(Ka, ratio):
    assert eq16_margin(ratio, 1.0, Ka) == pytest.approx(2.0 * eq15_margin(ratio, 1.0, 1.0, Ka))


def test_routh_array_of_a_known_polynomial():
    # (s + 1)(s + 2)(s + 3) = s^3 + 6 s^2 + 11 s + 6: first column 1, 6, 10, 6.
    np.testing.assert_allclose(routh_array([1, 6, 11, 6])[:, 0], [1, 6, 10, 6])
    assert routh_hurwitz_stable([1, 6, 11, 6])
    assert not routh_hurwitz_stable([1, -1, 2])
    assert not routh_hurwitz_stable([1, 0, 1])  # roots on the imaginary axis


@pytest.mark.parametrize('Ka, ratio', [(0.0, 0.2), (0.0, 0.4), (0.5, 0.6), (1.0, 0.5),
                                       (2.0, 0.9), (0.0, 0.6), (0.5, 0.9)])
def test_the_sampled_loop_tends_to_eq14_as_the_period_shrinks(Ka, ratio):
    """The discrete model with the paper's filter, T -> 0, has the poles of eq (14)."""
    wf = 10.0
    design = LoopDesign(ratio * wf, 1.0, 0.0, Ka, 2, wf, 'critical')
    T = 1e-4
    z = discrete_closed_loop_poles(design, T, delay_periods=0)
    s = np.log(z[np.abs(z) > 0.5]) / T  # the fast pole of the acceleration measurement aside
    assert len(s) == 4
    # Compare characteristic polynomials (repeated roots make the roots themselves sensitive).
    expected = eq14_transfer_function(ratio * wf, 1.0, wf, Ka)[1]
    np.testing.assert_allclose(np.poly(s).real, expected, rtol=0.01)
    assert (np.max(np.abs(z)) < 1.0) == (eq16_margin(ratio * wf, wf, Ka) > 0.0)


def test_pole_damping():
    T = 0.01
    s = np.array([-1.0 + 1.0j, -2.0, 0.5 + 3.0j])
    np.testing.assert_allclose(pole_damping(np.exp(s * T), T), [np.sqrt(0.5), 1.0,
                                                                -0.5 / abs(s[2])], rtol=1e-9)
    assert pole_damping([0.0], T)[0] == 1.0


def test_check_loop_refuses_a_violation_of_eq15_by_name():
    design = LoopDesign(6.0, 1.0, 0.0, 0.0, 2, 10.0, 'critical')  # 1 > 2 * 0.6 is false
    with pytest.raises(UnstableLoopError, match=r'J9 coarse.*eq \(15\).*0\.5.*0\.6'):
        check_loop(design, 0.002, label='J9 coarse')


def test_check_loop_refuses_what_eq15_cannot_see():
    """Refuse Ka > 1 on an unfiltered joint, which eq (15) does not cover.

    The measured acceleration of the last period feeds back with gain -Ka: a sampled-loop
    pole near z = -Ka.
    """
    design = LoopDesign(4.0, 1.0, 0.0, 1.5, 0, 0.0)
    with pytest.raises(UnstableLoopError, match=r'unstable.*\|z\| = 1\.[45]'):
        check_loop(design, 0.002, label='J4 coarse')
    check_loop(LoopDesign(4.0, 1.0, 0.0, 0.5, 0, 0.0), 0.002, label='J4 coarse')


def test_check_loop_refuses_poor_damping_and_reports_the_worst_case():
    design = LoopDesign(0.6, 1.0, 0.0, 0.5, 4, 8.0, 'critical')
    report = check_loop(design, 0.002, label='J1', inertia_ratios=inertia_ratio_grid(0.5, 2.0))
    assert 0.0 < report.smallest_damping < 1.0 and report.largest_pole_magnitude < 1.0
    with pytest.raises(UnstableLoopError, match='poorly damped'):
        check_loop(design, 0.002, label='J1', minimum_damping=report.smallest_damping + 0.01,
                   inertia_ratios=inertia_ratio_grid(0.5, 2.0))


def test_a_larger_inertia_mismatch_can_destabilise_a_loop():
    design = LoopDesign(1.5, 1.0, 0.0, 0.0, 4, 8.0, 'critical')
    check_loop(design, 0.002, label='J1', inertia_ratios=[1.0])
    with pytest.raises(UnstableLoopError, match='inertia ratio'):
        check_loop(design, 0.002, label='J1', inertia_ratios=inertia_ratio_grid(0.5, 4.0))


def test_inertia_ratio_grid_includes_its_ends_and_one():
    grid = inertia_ratio_grid(0.5, 2.0, 4)
    assert grid[0] == pytest.approx(0.5) and grid[-1] == pytest.approx(2.0) and 1.0 in grid


def continuous_poles_behind(filter_order, corner, kind, wc, zc=1.0, ka=0.0):
    """Poles of the continuous loop of eq (14) with another filter: s^2 D + N (Ka s^2 + ...)."""
    from scipy import signal

    if kind == 'bessel':
        numerator, denominator = signal.bessel(filter_order, corner, analog=True, norm='mag')
    else:
        numerator, denominator = [corner ** filter_order], np.poly([-corner] * filter_order)
    characteristic = np.polyadd(np.polymul([1.0, 0.0, 0.0], denominator),
                                np.polymul(numerator, [ka, 2.0 * zc * wc, wc ** 2]))
    return np.roots(characteristic)


def test_eq15_is_not_the_stability_condition_behind_a_4th_order_bessel_filter():
    # joint 1's filter: eq (15) allows wc up to 2.5 rad/s at Ka = 0, the loop fails from 1.69
    assert eq15_margin(2.0, 1.0, 5.0, 0.0) > 0.0
    assert np.max(continuous_poles_behind(4, 5.0, 'bessel', 1.65).real) < 0.0
    assert np.max(continuous_poles_behind(4, 5.0, 'bessel', 1.75).real) > 0.0
    # with the paper's own filter eq (15) is exact
    assert np.max(continuous_poles_behind(2, 5.0, 'critical', 2.45).real) < 0.0
    assert np.max(continuous_poles_behind(2, 5.0, 'critical', 2.55).real) > 0.0


def test_check_loop_applies_eq15_only_to_the_filter_it_was_derived_for():
    bessel = LoopDesign(1.5, 1.0, 0.0, 0.0, 4, 5.0, 'bessel')
    report = check_loop(bessel, 0.002, label='J1 coarse')
    assert report.eq15_margin is None
    assert 'does not apply' in report.stability_condition
    assert 'bessel filter of order 4' in report.stability_condition
    critical = check_loop(LoopDesign(1.5, 1.0, 0.0, 0.0, 2, 5.0, 'critical'), 0.002,
                          label='J2 coarse')
    assert critical.eq15_margin == pytest.approx(0.5 - 0.3)
    assert critical.stability_condition == 'sampled poles and eq (15)'


def test_a_bessel_loop_is_judged_by_its_poles_not_by_eq15():
    # eq (15) allows wc = 2 behind joint 1's filter; its poles refuse it, without naming eq (15)
    with pytest.raises(UnstableLoopError, match='unstable') as refused:
        check_loop(LoopDesign(2.0, 1.0, 0.0, 0.0, 4, 5.0, 'bessel'), 0.002, label='J1 coarse')
    assert 'eq (15)' not in str(refused.value)
    # eq (15) would refuse wc / wf = 0.55 behind a 2nd-order Bessel filter; the loop is stable
    design = LoopDesign(2.75, 1.0, 0.0, 0.0, 2, 5.0, 'bessel')
    assert eq15_margin(2.75, 1.0, 5.0, 0.0) < 0.0
    assert np.max(continuous_poles_behind(2, 5.0, 'bessel', 2.75).real) < 0.0
    assert check_loop(design, 0.002, label='J2 coarse').largest_pole_magnitude < 1.0
