"""The simplifications of section 5 checked against fuller dynamics along the planned motion."""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from walker_planner.core.bounds import family_minimum_solution
from walker_planner.core.node_to_node import PlanarModel, solve_node_to_node
from walker_planner.core.simplification import (
    PlanarDynamics,
    feasible_duration,
    required_torques,
    simplification_errors,
)


@pytest.fixture(scope='module', params=['bound_180', 'bound_90', 'nominal_180'])
def solution(request, robot):
    if request.param == 'bound_180':
        return family_minimum_solution(robot, math.pi, 0.75, rho_min=0.4)
    if request.param == 'bound_90':
        return family_minimum_solution(robot, math.pi / 2, 0.75, rho_min=0.4)
    model = PlanarModel.from_parameters(robot, 0.5, 0.8)
    return solve_node_to_node(model, 0.75, math.pi / 2, 0.4)


def equations_19_20(solution, with_centrifugal=True):
    """Integrate eqs (17)-(20) in (r, Theta) with the planned torques, written out anew."""
    link, m = solution.model.link_length, solution.model.tip_mass
    switches = sorted({0.0, *solution.switch_times, solution.duration})
    state = [2 * link * solution.profile.rho_start, 0.0, 0.0, 0.0]

    def rates(t, y, tau1, tau3):
        r, r_d, theta, theta_d = y
        sin2 = r / (2 * link)
        f_r = tau3 / (link * math.sqrt(max(1 - sin2 ** 2, 1e-12)))  # eq (17)
        f_theta = tau1 / (2 * link * sin2)  # eq (18)
        centrifugal = r * theta_d ** 2 if with_centrifugal else 0.0
        return [r_d, f_r / m + centrifugal, theta_d,
                (f_theta / m - 2 * r_d * theta_d) / r]  # eqs (19), (20)

    def stretched(t, y, *args):
        return 2 * link * math.sin(0.5 * math.pi - 1e-3) - y[0]

    stretched.terminal = True
    for lower, upper in zip(switches[:-1], switches[1:], strict=True):
        tau1, tau3 = (float(x[0]) for x in solution.torques(np.array([0.5 * (lower + upper)])))
        result = solve_ivp(rates, (lower, upper), state, rtol=1e-11, atol=1e-13,
                           args=(tau1, tau3), events=stretched)
        state = result.y[:, -1]
        if result.status == 1:
            return result.t[-1], state
    return solution.duration, state


def planned_tip(solution, time):
    p = solution.profile.sample(time * solution.omega)
    radius = 2 * solution.model.link_length * p.rho[0]
    return radius * np.array([-math.sin(p.theta[0]), math.cos(p.theta[0])])


def tip(state):
    return state[0] * np.array([-math.sin(state[2]), math.cos(state[2])])


def test_the_simplified_model_reproduces_the_plan(solution):
    error = simplification_errors(solution, models=('simplified',))[0]
    assert not error.stopped
    assert error.position < 1e-8 and error.speed < 1e-8
    end_time, state = equations_19_20(solution, with_centrifugal=False)
    assert end_time == pytest.approx(solution.duration)
    np.testing.assert_allclose(tip(state), planned_tip(solution, end_time), atol=1e-8)


def test_the_reported_endpoint_error_is_what_eqs_19_20_give(solution, robot):
    reported = simplification_errors(solution, robot, models=('full',))[0]
    end_time, state = equations_19_20(solution)
    assert reported.end_time == pytest.approx(end_time, abs=1e-6)
    miss = np.linalg.norm(tip(state) - planned_tip(solution, end_time))
    assert reported.position == pytest.approx(miss, abs=1e-6)
    assert reported.position > 1e-3  # the centrifugal term is not negligible open loop


def test_the_lumped_model_with_no_extra_inertia_is_the_full_model(solution):
    full = PlanarDynamics.named('full', solution)
    same = PlanarDynamics(full.link_length, full.tip_mass, 0.0, 0.0, 0.0)
    t = np.linspace(0, solution.duration, 101)
    for a, b in zip(required_torques(solution, full, t), required_torques(solution, same, t),
                    strict=True):
        np.testing.assert_allclose(a, b)


def test_inverse_dynamics_of_the_simplified_model_gives_the_planned_torques(solution):
    dynamics = PlanarDynamics.named('simplified', solution)
    t = np.linspace(0.0, solution.duration, 401)
    switches = np.array(solution.switch_times)
    away = np.min(np.abs(t[:, None] - switches[None, :]), axis=1) > 1e-6
    circular, radial = required_torques(solution, dynamics, t[away])
    planned_circular, planned_radial = solution.torques(t[away])
    np.testing.assert_allclose(circular, planned_circular, atol=1e-8)
    np.testing.assert_allclose(radial, planned_radial, atol=1e-8)


def test_a_fuller_model_follows_the_path_within_the_torques_at_the_feasible_duration(
        solution, robot):
    for name in ('full', 'lumped'):
        dynamics = PlanarDynamics.named(name, solution, robot)
        stretched = feasible_duration(solution, dynamics, solution.model.circular_torque,
                                      solution.model.radial_torque)
        assert stretched >= solution.duration
        scale = solution.duration / stretched
        t = np.linspace(0.0, solution.duration, 2001)
        circular, radial = required_torques(solution, dynamics, t)
        worst = max(np.max(np.abs(circular)) / solution.model.circular_torque,
                    np.max(np.abs(radial)) / solution.model.radial_torque)
        if stretched > solution.duration:
            assert worst * scale ** 2 == pytest.approx(1.0)
        else:
            assert worst <= 1.0


def test_at_the_bound_the_centrifugal_force_needs_more_than_the_radial_torque(robot):
    solution = family_minimum_solution(robot, math.pi, 0.75, rho_min=0.4)
    full = PlanarDynamics.named('full', solution)
    assert feasible_duration(solution, full, solution.model.circular_torque,
                             solution.model.radial_torque) > 1.5 * solution.duration
