"""The time-optimal lower bound, the minimum time found by direct optimisation, the family.

What a user needs to be true: the lower bound is never above a feasible move (the moves the
direct method returns, re-integrated, and moves these tests build by their own shooting,
including the three that beat the paper's family minimum); the paper's family minimum is never
below the bound; every move the direct method returns is feasible when re-integrated.
"""

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from shooting import reintegrate_polar, shoot_move
from walker_planner.core.bounds import (
    family_minimum_time,
    minimum_time_found,
    move_problem,
    step_move_problem,
)
from walker_planner.core.direct_method import FEASIBILITY_TOLERANCE, reintegrate
from walker_planner.core.errors import NoSolutionError
from walker_planner.core.minimum_time import MoveProblem, lower_bound
from walker_planner.core.node_to_node import PlanarModel, solve_node_to_node

#: The independent check's cases (torque limits alone): sweep [deg], r_min [m], the paper's
#: family minimum beaten or not by a feasible move of eqs (19)-(20).
SHOOTING_CASES = [(90, 0.5, True), (180, 0.5, False), (180, 0.05, True)]


@pytest.fixture(scope='module', params=SHOOTING_CASES, ids=lambda c: f'{c[0]}deg-r{c[1]}')
def shot(request, robot):
    sweep, min_radius, beats_family = request.param
    problem = move_problem(robot, math.radians(sweep), 0.9, min_radius, rate_limits=False)
    limits = problem.limits
    duration, torques = shoot_move(0.9, problem.sweep, min_radius, limits.tip_mass,
                                   limits.link_length,
                                   (limits.circular_torque, limits.radial_torque))
    found = minimum_time_found(robot, problem.sweep, 0.9, min_radius, rate_limits=False)
    return problem, duration, torques, found, beats_family


@pytest.fixture(scope='module', params=[90, 180], ids=lambda s: f'{s}deg-rates')
def rate_limited(request, robot):
    return minimum_time_found(robot, math.radians(request.param), 0.9, 0.5)


def assert_feasible(move):
    problem = move.problem
    limits = problem.limits
    assert np.all(np.abs(move.torques[:, 0]) <= limits.circular_torque * (1 + 1e-9))
    assert np.all(np.abs(move.torques[:, 1]) <= limits.radial_torque * (1 + 1e-9))
    check, states = reintegrate(problem, move.duration, move.torques, samples_per_interval=40)
    assert check.feasible(), check
    np.testing.assert_allclose(states, move.states, atol=1e-9)
    assert states[-1, 2] == pytest.approx(problem.sweep, abs=FEASIBILITY_TOLERANCE)


def test_the_shooting_moves_are_feasible_on_eqs_19_20_as_printed(shot):
    problem, duration, torques, _, _ = shot
    end, path = reintegrate_polar(0.9, duration, torques, problem.limits.tip_mass,
                                  problem.limits.link_length)
    np.testing.assert_allclose(end, [0.9, 0.0, problem.sweep, 0.0], atol=1e-5)
    assert problem.min_radius <= path[:, 0].min() and path[:, 0].max() <= 0.9 * (1 + 1e-9)


def test_the_bound_is_below_every_constructed_move_and_the_direct_method_matches_them(shot):
    problem, duration, _, found, _ = shot
    assert lower_bound(problem) <= found.duration <= duration * (1 + 1e-3)
    assert lower_bound(problem) <= duration
    assert_feasible(found)


def test_feasible_moves_beat_the_family_minimum_where_the_centrifugal_term_allows(shot, robot):
    problem, duration, _, found, beats_family = shot
    family = family_minimum_time(robot, problem.sweep, 0.75, rho_min=problem.min_radius / 1.2)
    assert family >= lower_bound(problem)
    assert (duration < family) == beats_family
    assert (found.duration < family) == beats_family


def test_every_starting_guess_agrees_on_the_minimum_found(shot, rate_limited):
    for move in (shot[3], rate_limited):
        starts = np.array(move.starts)
        assert np.all(np.isfinite(starts))
        assert np.ptp(starts) <= 1e-6 * move.duration


def test_at_the_rate_limits_the_move_found_is_within_a_fraction_of_a_percent_of_the_bound(
        rate_limited):
    assert_feasible(rate_limited)
    assert 0.0 <= rate_limited.optimality_gap < 0.002
    yaw = rate_limited.problem.limits.yaw_rate
    assert np.max(np.abs(rate_limited.states[:, 3])) == pytest.approx(yaw, rel=1e-3)


def test_with_the_radius_held_both_meet_the_exact_rest_to_rest_optimum(robot):
    # r_min = r_max = r0: the tip can only turn, at constant inertia m r0^2 (eq (20)); the
    # fastest move is then bang-bang, or bang-coast-bang at the rate limit
    limits = PlanarModel.from_parameters(robot, 1.0, 1.0)
    problem = MoveProblem(limits, 0.9, math.pi / 2, 0.9)
    acceleration = limits.circular_torque / (limits.tip_mass * 0.9 ** 2)
    rate = limits.yaw_rate
    exact = problem.sweep / rate + rate / acceleration
    assert exact * (1 - 1e-3) <= lower_bound(problem) <= exact
    free = dataclasses.replace(problem, limits=dataclasses.replace(limits, yaw_rate=math.inf))
    assert lower_bound(free) == pytest.approx(2 * math.sqrt(problem.sweep / acceleration),
                                              rel=1e-3)
    assert lower_bound(free) <= 2 * math.sqrt(problem.sweep / acceleration)


def test_letting_the_tip_out_beyond_its_start_does_not_shorten_the_move(robot):
    problem = move_problem(robot, math.pi / 2, 0.9, 0.5, rate_limits=False)
    wide = dataclasses.replace(problem, max_radius=0.98 * 1.2)
    from walker_planner.core.direct_method import solve_minimum_time

    assert solve_minimum_time(wide).duration == pytest.approx(
        solve_minimum_time(problem).duration, rel=1e-5)
    assert lower_bound(wide) <= lower_bound(problem)


@settings(max_examples=40, deadline=None)
@given(st.sampled_from([45.0, 90.0, 135.0, 180.0]), st.floats(0.4, 1.1), st.floats(0.1, 1.0),
       st.floats(0.2, 5.0) | st.just(math.inf), st.floats(0.3, 1.5))
def test_the_family_minimum_is_never_below_the_bound(robot, sweep, radius, depth, rate,
                                                     torque_scale):
    base = PlanarModel.from_parameters(robot, 1.0)
    limits = PlanarModel(base.link_length, base.tip_mass, base.circular_torque * torque_scale,
                         base.radial_torque, rate, rate, rate)
    min_radius = radius * depth
    problem = MoveProblem(limits, radius, math.radians(sweep), min_radius)
    family = solve_node_to_node(limits, radius / 1.2, 0.5 * problem.sweep, min_radius / 1.2)
    assert family.duration >= lower_bound(problem)


def test_the_bound_grows_with_the_sweep_and_shrinks_with_more_torque(robot):
    bounds = [lower_bound(move_problem(robot, math.radians(s), 0.9, 0.5)) for s in (45, 90, 180)]
    assert bounds == sorted(bounds)
    problem = move_problem(robot, math.pi, 0.9, 0.5, rate_limits=False)
    stronger = dataclasses.replace(problem, limits=dataclasses.replace(
        problem.limits, circular_torque=2 * problem.limits.circular_torque))
    assert lower_bound(stronger) < lower_bound(problem)


@pytest.mark.parametrize('change, words', [
    ({'min_radius': 1.0}, 'min_radius'),
    ({'sweep': 4.0}, 'not a node-to-node move'),
    ({'max_radius': 1.2}, 'stretched V'),
    ({'start_radius': math.nan}, 'finite'),
])
def test_a_problem_out_of_range_is_refused_by_name(robot, change, words):
    problem = move_problem(robot, math.pi, 0.9, 0.5)
    fields = {'limits': problem.limits, 'start_radius': 0.9, 'sweep': math.pi,
              'min_radius': 0.5}
    fields.update(change)
    with pytest.raises(NoSolutionError, match=words):
        MoveProblem(**fields)


def test_a_step_problem_is_the_sweep_about_the_base_node(robot):
    problem = step_move_problem(robot, 'n1_1', 'n2_1', 'n0_1', min_radius=0.5)
    assert problem.sweep == pytest.approx(math.pi)
    assert problem.start_radius == pytest.approx(robot.truss.spacing)
    assert problem.limits.yaw_rate == robot.robot.drive.yaw.velocity_limit
