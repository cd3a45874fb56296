"""The bang-bang node-to-node profile of section 5: eqs (17)-(27), corrected, checked."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from walker_planner.core.bang_bang import (
    PlanarProfile, integrate_dimensionless, summarize_profile, torque_ratio_by_root_finding)
from walker_planner.core.errors import NoSolutionError

starts = st.floats(0.3, 0.9)
fractions = st.floats(0.2, 0.98)
half_sweeps = st.sampled_from([math.pi / 4, math.pi / 2]) | st.floats(0.05, math.pi / 2)


def profile_of(rho_start, fraction, half_sweep):
    return PlanarProfile.solve(rho_start, rho_start * fraction, half_sweep)


@settings(max_examples=40, deadline=None)
@given(starts, fractions, half_sweeps)
def test_the_midpoint_has_half_the_sweep_zero_radial_speed_and_the_smallest_radius(
        rho_start, fraction, half_sweep):
    profile = profile_of(rho_start, fraction, half_sweep)
    middle = profile.sample(profile.phi2)
    assert middle.theta[0] == pytest.approx(half_sweep, rel=1e-10)
    assert abs(middle.rho_d[0]) < 1e-12
    assert middle.rho[0] == pytest.approx(profile.rho_mid, abs=1e-12)
    phi = np.linspace(0.0, profile.phi_end, 801)
    assert np.min(profile.sample(phi).rho) >= profile.rho_mid - 1e-12
    assert 0.0 < profile.phi1 < profile.phi2


@settings(max_examples=40, deadline=None)
@given(starts, fractions, half_sweeps)
def test_the_trajectory_starts_and_ends_at_rest_on_the_nodes(rho_start, fraction, half_sweep):
    profile = profile_of(rho_start, fraction, half_sweep)
    ends = profile.sample([0.0, profile.phi_end])
    np.testing.assert_allclose(ends.rho, rho_start, atol=1e-12)
    np.testing.assert_allclose(ends.theta, [0.0, 2 * half_sweep], atol=1e-10)
    np.testing.assert_allclose(ends.rho_d, 0.0, atol=1e-12)
    np.testing.assert_allclose(ends.theta_d, 0.0, atol=1e-12)


@settings(max_examples=25, deadline=None)
@given(starts, fractions, half_sweeps)
def test_the_second_half_mirrors_the_first(rho_start, fraction, half_sweep):
    profile = profile_of(rho_start, fraction, half_sweep)
    phi = np.linspace(0.0, profile.phi2, 97)
    first, second = profile.sample(phi), profile.sample(profile.phi_end - phi)
    np.testing.assert_allclose(second.rho, first.rho, atol=1e-12)
    np.testing.assert_allclose(second.rho_d, -first.rho_d, atol=1e-12)
    np.testing.assert_allclose(second.theta, 2 * half_sweep - first.theta, atol=1e-10)
    np.testing.assert_allclose(second.theta_d, first.theta_d, atol=1e-10)
    np.testing.assert_allclose(profile.radial_sign(profile.phi_end - phi[1:-1]),
                               profile.radial_sign(phi[1:-1]))


@settings(max_examples=20, deadline=None)
@given(starts, fractions, half_sweeps)
def test_the_exact_solution_matches_a_numerical_integration_of_eqs_26_27(
        rho_start, fraction, half_sweep):
    profile = profile_of(rho_start, fraction, half_sweep)
    phi = np.linspace(0.0, profile.phi2, 13)
    numerical = integrate_dimensionless(rho_start, profile.phi1, profile.phi2, profile.tau, phi)
    exact = profile.sample(phi)
    np.testing.assert_allclose(numerical[:, 0], exact.rho, atol=1e-8)
    np.testing.assert_allclose(numerical[:, 1], exact.rho_d, atol=1e-8)
    np.testing.assert_allclose(numerical[:, 2], exact.theta, atol=1e-8)
    np.testing.assert_allclose(numerical[:, 3], exact.theta_d, atol=1e-8)


@pytest.mark.parametrize('rho_start, rho_mid, half_sweep', [
    (0.75, 0.5, math.pi / 2), (0.75, 0.6, math.pi / 4), (0.6, 0.3, math.pi / 2)])
def test_root_finding_on_the_integrator_finds_the_same_torque_ratio(rho_start, rho_mid,
                                                                   half_sweep):
    closed_form = PlanarProfile.solve(rho_start, rho_mid, half_sweep).tau
    assert torque_ratio_by_root_finding(rho_start, rho_mid, half_sweep) == pytest.approx(
        closed_form, rel=1e-8)


def test_accelerations_are_the_derivatives_of_the_rates():
    profile = PlanarProfile.solve(0.75, 0.45, math.pi / 2)
    step = 1e-6
    for phi in np.linspace(0.05, profile.phi_end - 0.05, 17):
        if min(abs(phi - mark) for mark in (profile.phi1, profile.phi2,
                                             profile.phi_end - profile.phi1)) < 1e-3:
            continue
        here, ahead, behind = (profile.sample(x) for x in (phi, phi + step, phi - step))
        assert here.rho_d[0] == pytest.approx((ahead.rho - behind.rho)[0] / (2 * step), abs=1e-7)
        assert here.rho_dd[0] == pytest.approx((ahead.rho_d - behind.rho_d)[0] / (2 * step),
                                               abs=1e-6)
        assert here.theta_d[0] == pytest.approx((ahead.theta - behind.theta)[0] / (2 * step),
                                                abs=1e-6)
        assert here.theta_dd[0] == pytest.approx(
            (ahead.theta_d - behind.theta_d)[0] / (2 * step), abs=1e-5)


def dimensional_run(profile, link, m, tau3, printed_eq22):
    """Integrate eqs (21)-(22) in seconds with the torques of the profile."""
    tau1 = profile.tau * tau3
    omega = math.sqrt(tau3 / (m * link ** 2))  # eq (23)

    def rates(t, y):
        r, r_d, theta, theta_d = y
        s3 = -1.0 if t * omega < profile.phi1 else 1.0
        sin2 = r / (2 * link)
        cos2 = math.sqrt(1 - sin2 ** 2)
        r_dd = s3 * tau3 / (m * link * cos2)  # eq (21)
        if printed_eq22:
            theta_dd = tau1 / (2 * m * r * sin2) - 2 * r_d * theta_d / r
        else:
            theta_dd = tau1 / (2 * m * link * r * sin2) - 2 * r_d * theta_d / r
        return [r_d, r_dd, theta_d, theta_dd]

    end = profile.phi2 / omega
    switch = profile.phi1 / omega
    state = [2 * link * profile.rho_start, 0.0, 0.0, 0.0]
    for lower, upper in ((0.0, switch), (switch, end)):
        state = solve_ivp(rates, (lower, upper), state, rtol=1e-11, atol=1e-13).y[:, -1]
    return state


def test_corrected_eq22_agrees_with_the_dimensionless_solution_and_the_printed_one_does_not():
    profile = PlanarProfile.solve(0.75, 0.5, math.pi / 2)
    link, m, tau3 = 0.6, 3.25, 4.0  # l != 1 m, or the printed eq (22) would pass by accident
    r, r_d, theta, theta_d = dimensional_run(profile, link, m, tau3, printed_eq22=False)
    assert r == pytest.approx(2 * link * profile.rho_mid, abs=1e-8)
    assert r_d == pytest.approx(0.0, abs=1e-8)
    assert theta == pytest.approx(math.pi / 2, abs=1e-8)
    _, _, theta_printed, _ = dimensional_run(profile, link, m, tau3, printed_eq22=True)
    assert abs(theta_printed - math.pi / 2) > 0.1


def test_a_pure_rotation_keeps_the_radius_and_reaches_the_sweep():
    profile = PlanarProfile.solve(0.75, 0.75, math.pi / 4)
    assert profile.pure_rotation
    samples = profile.sample(np.linspace(0.0, profile.phi_end, 51))
    np.testing.assert_allclose(samples.rho, 0.75)
    assert samples.theta[-1] == pytest.approx(math.pi / 2)
    np.testing.assert_allclose(profile.radial_sign(np.linspace(0, profile.phi_end, 5)), 0.0)


@pytest.mark.parametrize('rho_start, rho_mid, half_sweep, words', [
    (0.75, 0.8, math.pi / 2, 'rho_min above the start radius has no solution'),
    (1.2, 0.5, math.pi / 2, 'outside \\(0, 1\\)'),
    (0.75, 0.0, math.pi / 2, 'must be in \\(0'),
    (0.75, 0.5, math.pi, 'not reachable'),
    (0.75, 0.5, 0.0, 'not reachable'),
    (0.75, math.nan, math.pi / 2, 'finite'),
])
def test_problems_without_a_solution_are_refused_by_name(rho_start, rho_mid, half_sweep, words):
    with pytest.raises(NoSolutionError, match=words):
        summarize_profile(rho_start, rho_mid, half_sweep)
    with pytest.raises(NoSolutionError, match=words):
        PlanarProfile.solve(rho_start, rho_mid, half_sweep)
