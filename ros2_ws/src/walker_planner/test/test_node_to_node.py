"""The bang-bang node-to-node motion in physical units: limits, time-optimal choice, bound."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from walker_core.truss import UnknownNodeError
from walker_planner.core.bang_bang import summarize_profile
from walker_planner.core.bounds import (
    coarse_move_bound,
    family_minimum_solution,
    family_minimum_time,
    step_time_optimal_bound,
    time_optimal_bound,
)
from walker_planner.core.errors import LimitError, NoSolutionError
from walker_planner.core.node_to_node import NodeToNodeTrajectory, PlanarModel, solve_node_to_node

torque_fractions = st.floats(0.1, 1.0)
rate_caps = st.floats(0.3, 10.0) | st.just(math.inf)


def model_of(robot, fraction=1.0, rate=math.inf):
    base = PlanarModel.from_parameters(robot, fraction)
    return PlanarModel(base.link_length, base.tip_mass, base.circular_torque,
                       base.radial_torque, rate, rate, rate)


def peak_rates(solution):
    phi = np.linspace(0.0, solution.profile.phi_end, 4001)
    p = solution.profile.sample(phi)
    pitch = p.rho_d / np.sqrt(1 - p.rho ** 2)  # th2' with rho = sin th2
    return (solution.omega * np.max(np.abs(p.theta_d)),
            solution.omega * np.max(np.abs(pitch)))


def test_the_model_takes_the_tip_mass_and_the_available_torque_from_the_parameter_file(robot):
    model = PlanarModel.from_parameters(robot, torque_fraction=0.5)
    _, m4, m5 = robot.robot.mass.lumped
    assert model.tip_mass == m4 + m5
    assert model.link_length == robot.robot.geometry.l2
    yaw, vertex = robot.robot.drive.yaw, robot.robot.drive.vertex
    assert model.circular_torque == pytest.approx(0.5 * (yaw.torque_limit - yaw.friction_torque))
    assert model.radial_torque == pytest.approx(
        0.5 * (vertex.torque_limit - vertex.friction_torque))


@settings(max_examples=30, deadline=None)
@given(torque_fractions, rate_caps, st.sampled_from([math.pi / 4, math.pi / 2]),
       st.floats(0.2, 0.74))
def test_torques_and_rates_stay_within_the_limits_and_one_limit_binds(robot, fraction, rate,
                                                                      half_sweep, rho_min):
    model = model_of(robot, fraction, rate)
    solution = solve_node_to_node(model, 0.75, half_sweep, rho_min)
    assert solution.profile.rho_mid >= rho_min - 1e-12
    assert solution.circular_torque <= model.circular_torque * (1 + 1e-9)
    assert solution.radial_torque <= model.radial_torque * (1 + 1e-9)
    yaw_rate, pitch_rate = peak_rates(solution)
    assert yaw_rate <= rate * (1 + 1e-6)
    assert 2 * pitch_rate <= rate * (1 + 1e-6)  # J3 turns at twice th2's rate
    usage = max(solution.circular_torque / model.circular_torque,
                solution.radial_torque / model.radial_torque, yaw_rate / rate,
                2 * pitch_rate / rate)
    assert usage == pytest.approx(1.0, rel=1e-4)


@settings(max_examples=15, deadline=None)
@given(torque_fractions, rate_caps, st.sampled_from([math.pi / 4, math.pi / 2]))
def test_the_chosen_midpoint_is_the_fastest_of_the_family(robot, fraction, rate, half_sweep):
    model = model_of(robot, fraction, rate)
    rho_min = 0.3
    solution = solve_node_to_node(model, 0.75, half_sweep, rho_min)
    for rho_mid in np.linspace(rho_min, 0.75, 40):
        summary = summarize_profile(0.75, rho_mid, half_sweep)
        omega, _ = model.time_scale(summary)
        assert solution.duration <= 2 * summary.phi2 / omega * (1 + 1e-6)


def test_a_longer_duration_stretches_the_motion_and_a_shorter_one_is_refused(robot):
    model = model_of(robot, 0.5)
    fastest = solve_node_to_node(model, 0.75, math.pi / 2, 0.4)
    slower = solve_node_to_node(model, 0.75, math.pi / 2, 0.4, duration=2 * fastest.duration)
    assert slower.duration == pytest.approx(2 * fastest.duration)
    assert slower.circular_torque == pytest.approx(fastest.circular_torque / 4)
    with pytest.raises(LimitError, match='shorter than the fastest'):
        solve_node_to_node(model, 0.75, math.pi / 2, 0.4, duration=0.5 * fastest.duration)


def trajectory_of(robot, sweep, direction=1, theta_start=0.3, height=0.03):
    solution = solve_node_to_node(model_of(robot, 0.5, 1.2), 0.75, 0.5 * sweep, 0.4)
    return NodeToNodeTrajectory(solution, theta_start, direction, height)


@pytest.mark.parametrize('sweep', [math.pi / 2, math.pi])
@pytest.mark.parametrize('direction', [1, -1])
def test_the_tip_goes_from_node_to_node_at_rest_in_its_plane(robot, sweep, direction):
    trajectory = trajectory_of(robot, sweep, direction)
    radius = 2 * robot.robot.geometry.l2 * 0.75
    start, end = trajectory.sample(0.0), trajectory.sample(trajectory.duration)
    for sample, angle in ((start, 0.3), (end, 0.3 + direction * sweep)):
        np.testing.assert_allclose(sample.position,
                                   [-radius * math.sin(angle), radius * math.cos(angle), 0.03],
                                   atol=1e-9)
        np.testing.assert_allclose(sample.velocity, 0.0, atol=1e-12)
    t = np.linspace(0.0, trajectory.duration, 501)
    np.testing.assert_allclose(trajectory.sample(t).position[:, 2], 0.03)


def test_cartesian_velocity_and_acceleration_are_the_derivatives_of_the_position(robot):
    trajectory = trajectory_of(robot, math.pi)
    step = 1e-6
    for t in np.linspace(0.01, trajectory.duration - 0.01, 23):
        if np.min(np.abs(np.array(trajectory.solution.switch_times) - t)) < 1e-3:
            continue  # the accelerations switch there
        here = trajectory.sample(t)
        ahead, behind = trajectory.sample(t + step), trajectory.sample(t - step)
        np.testing.assert_allclose(here.velocity, (ahead.position - behind.position) / (2 * step),
                                   atol=1e-6)
        np.testing.assert_allclose(here.acceleration,
                                   (ahead.velocity - behind.velocity) / (2 * step), atol=1e-4)


def test_the_step_bound_on_the_default_truss_for_90_and_180_degree_steps(robot):
    ninety = step_time_optimal_bound(robot, 'n1_1', 'n2_1', 'n1_2', min_radius=0.5)
    half_turn = step_time_optimal_bound(robot, 'n1_1', 'n2_1', 'n0_1', min_radius=0.5)
    assert 0.0 < ninety < half_turn
    assert ninety == pytest.approx(time_optimal_bound(robot, math.pi / 2, 0.9, 0.5))
    # J1 cannot turn faster than its velocity limit: the bound is at least the sweep at it
    yaw = robot.robot.drive.yaw
    assert half_turn > math.pi / yaw.velocity_limit
    # the fastest of the family at the full torques and rates is no faster than the bound
    nominal = solve_node_to_node(PlanarModel.from_parameters(robot, 1.0, 1.0), 0.75,
                                 math.pi / 4, 0.5 / 1.2)
    assert nominal.duration >= ninety


def test_the_family_minimum_is_at_the_full_available_torque(robot):
    solution = family_minimum_solution(robot, math.pi, 0.75)
    yaw, vertex = robot.robot.drive.yaw, robot.robot.drive.vertex
    assert max(solution.circular_torque / (yaw.torque_limit - yaw.friction_torque),
               solution.radial_torque / (vertex.torque_limit - vertex.friction_torque)) \
        == pytest.approx(1.0)


@pytest.mark.parametrize('base, start, goal, error, words', [
    ('n1_1', 'n2_1', 'n2_2', NoSolutionError, 'keeps the radius'),
    ('n1_1', 'n2_1', 'n2_1', NoSolutionError, 'no sweep'),
    ('n1_1', 'n2_1', 'n9_9', UnknownNodeError, 'not on the truss'),
])
def test_steps_that_are_not_sweeps_are_refused(robot, base, start, goal, error, words):
    with pytest.raises(error, match=words):
        step_time_optimal_bound(robot, base, start, goal, min_radius=0.5)


def test_moves_that_are_not_sweeps_have_no_bound(robot):
    assert coarse_move_bound(robot, [0, 0.9, 0.03], [0, 0.8, 0.03], 0.5) is None
    assert coarse_move_bound(robot, [0, 0.9, 0.03], [0.9, 0, 0.0], 0.5) is None
    assert coarse_move_bound(robot, [0, 1.5, 0.0], [1.5, 0, 0.0], 0.5) is None  # out of reach
    with pytest.raises(NoSolutionError, match='equal start and end radii'):
        family_minimum_time(robot, math.pi, 0.75, rho_end=0.6)
