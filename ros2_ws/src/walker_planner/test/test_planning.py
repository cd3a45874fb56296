"""Planning requests of every type: boundary conditions, continuity, limits, clear refusals."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from walker_core.joint_roles import physical_to_roles
from walker_planner.core.errors import (
    InvalidRequestError, LimitError, NoSolutionError, PlanningError, WorkspaceError)
from walker_planner.core.planning import PlanRequest, plan
from walker_planner.core.registry import TRAJECTORY_TYPES
from walker_planner.core.trajectory import CARTESIAN

H = 0.03  # approach height [m]
ABOVE = (0.0, 0.9, H)
STEPS_AT_THE_ENDS = {'cartesian_line'}  # the paper's constant-velocity fine motion
VERTICAL_LINES = {'insertion_line', 'extraction_line'}


@pytest.fixture(scope='module')
def stance(context):
    q = context.kinematics.inverse([*ABOVE, 0.0, 0.0])
    return tuple(q)


def turned(stance, angle):
    return (stance[0] + angle, *stance[1:4], stance[4] + angle)


def requests(stance):
    """One typical request of each type, with gripper a as base."""
    return {
        'joint_parabolic_time': {'start': stance, 'goal': turned(stance, 0.4), 'duration': 2.0},
        'joint_parabolic_accel': {'start': stance, 'goal': turned(stance, 0.4)},
        'joint_min_jerk': {'start': stance, 'goal': turned(stance, 0.4)},
        'cartesian_parabolic_time': {'start': ABOVE, 'goal': (0.1, 0.85, 0.1), 'duration': 3.0},
        'cartesian_parabolic_accel': {'start': ABOVE, 'goal': (0.1, 0.85, 0.1)},
        'cartesian_line': {'start': (0.01, 0.89, H), 'goal': ABOVE},
        'insertion_line': {'start': ABOVE, 'goal': (0.0, 0.9, 0.0)},
        'extraction_line': {'start': (0.0, 0.9, 0.0), 'goal': ABOVE},
        'bang_bang_node': {'start': ABOVE, 'goal': (-0.9, 0.0, H)},
    }


@pytest.fixture(scope='module', params=list(TRAJECTORY_TYPES))
def planned(request, stance, context):
    name = request.param
    return name, plan(PlanRequest(name, 'a', **requests(stance)[name]), context)


def tip_positions(context, plan_result):
    roles = physical_to_roles(plan_result.samples.position, plan_result.base_gripper)
    return np.array([context.kinematics.forward(q) for q in roles])


def test_every_type_starts_and_ends_where_asked_at_rest(planned, context, stance):
    name, result = planned
    asked = requests(stance)[name]
    kind = TRAJECTORY_TYPES[name]
    if kind.space == CARTESIAN:
        tips = tip_positions(context, result)
        np.testing.assert_allclose(tips[0, :3], asked['start'], atol=1e-9)
        np.testing.assert_allclose(tips[-1, :3], asked['goal'], atol=1e-9)
        np.testing.assert_allclose(tips[[0, -1], 3], 0.0, atol=1e-9)  # gripper vertical
    else:
        np.testing.assert_allclose(result.samples.position[0], asked['start'], atol=1e-12)
        np.testing.assert_allclose(result.samples.position[-1], asked['goal'], atol=1e-12)
    np.testing.assert_allclose(result.samples.velocity[[0, -1]], 0.0, atol=1e-12)
    assert result.times[0] == 0.0 and result.times[-1] == pytest.approx(result.duration)
    period = 1.0 / context.robot.timing.control_rate
    assert np.all(np.diff(result.times) <= period * (1 + 1e-9))


def test_position_and_velocity_are_continuous(planned, context):
    name, result = planned
    dt = np.diff(result.times)[:, None]
    samples = result.samples
    speed = np.max(np.abs(samples.velocity))
    acceleration = max(np.max(np.abs(samples.acceleration)), 1e-9)
    # a jump is a change larger than the trajectory's own rates can make in one period
    steps = np.abs(np.diff(samples.position, axis=0))
    assert np.all(steps <= (speed + acceleration * dt) * dt + 1e-12)
    changes = np.abs(np.diff(samples.velocity, axis=0))
    if name in STEPS_AT_THE_ENDS:  # the constant-velocity lines step their rate at the ends
        changes = changes[1:-1]
        dt = dt[1:-1]
    assert np.all(changes <= 2.0 * acceleration * dt + 1e-9)


def test_velocities_are_the_derivative_of_the_positions(planned):
    name, result = planned
    trajectory = result.trajectory
    t = np.linspace(0.0, result.duration, 37)[1:-1]
    step = 1e-6
    ahead, behind = trajectory.sample(t + step), trajectory.sample(t - step)
    np.testing.assert_allclose(trajectory.sample(t).velocity,
                               (ahead.position - behind.position) / (2 * step), atol=1e-6)


def test_joint_limits_are_respected(planned, context):
    _, result = planned
    drive = context.robot.robot.drive
    roles = physical_to_roles(result.samples.position, result.base_gripper)
    assert np.all(roles >= drive.role_array('position_min'))
    assert np.all(roles <= drive.role_array('position_max'))
    speeds = physical_to_roles(np.abs(result.samples.velocity), result.base_gripper)
    assert np.all(speeds <= drive.role_array('velocity_limit') * (1 + 1e-9))


def test_cartesian_lines_are_straight(planned, context, stance):
    name, result = planned
    if name not in STEPS_AT_THE_ENDS | VERTICAL_LINES | {'cartesian_parabolic_time',
                                                         'cartesian_parabolic_accel'}:
        return
    asked = requests(stance)[name]
    start, goal = np.array(asked['start']), np.array(asked['goal'])
    direction = (goal - start) / np.linalg.norm(goal - start)
    offsets = tip_positions(context, result)[:, :3] - start
    across = offsets - np.outer(offsets @ direction, direction)
    assert np.max(np.linalg.norm(across, axis=1)) < 1e-9
    along = offsets @ direction
    assert np.all(np.diff(along) >= -1e-12)  # never backwards


@pytest.mark.parametrize('name', sorted(VERTICAL_LINES))
def test_vertical_lines_start_and_stop_smoothly_at_their_peak_speed(name, context, stance):
    """The lift and the descent are minimum-jerk: no step of velocity or acceleration.

    A joint held by its stiction lags a velocity step and overshoots where the line stops;
    the quintic starts and stops at rest with zero acceleration, reaches the default speed at
    its middle, and keeps within the Cartesian acceleration limit.
    """
    result = plan(PlanRequest(name, 'a', **requests(stance)[name]), context)
    tips = tip_positions(context, result)[:, :3]
    dt = np.diff(result.times)
    speed = np.linalg.norm(np.diff(tips, axis=0), axis=1) / dt
    cartesian = context.planner.cartesian
    assert speed[0] < 0.02 * speed.max() and speed[-1] < 0.02 * speed.max()
    np.testing.assert_allclose(result.samples.acceleration[[0, -1]], 0.0, atol=1e-9)
    acceleration = np.abs(np.diff(speed)) / dt[1:]
    assert acceleration.max() <= cartesian.acceleration_limit * 1.01
    assert speed.max() <= cartesian.insertion_speed * 1.001
    length = np.linalg.norm(np.subtract(requests(stance)[name]['goal'],
                                        requests(stance)[name]['start']))
    fastest = max(1.875 * length / cartesian.insertion_speed,
                  math.sqrt(10.0 / math.sqrt(3.0) * length / cartesian.acceleration_limit))
    assert result.duration == pytest.approx(fastest)
    slower = plan(PlanRequest(name, 'a', **requests(stance)[name], max_velocity=0.05), context)
    assert slower.duration == pytest.approx(1.875 * length / 0.05)


def test_the_time_optimal_bound_is_reported_for_sweeps_and_lines(planned, context, stance):
    name, result = planned
    if name in ('bang_bang_node', 'joint_parabolic_time', 'joint_parabolic_accel',
                'joint_min_jerk'):  # the joint moves turn J1 about the base at one radius
        assert 0.0 < result.time_optimal_bound <= result.duration
    elif name in ('cartesian_line', 'insertion_line', 'extraction_line'):
        length = np.linalg.norm(np.subtract(requests(stance)[name]['goal'],
                                            requests(stance)[name]['start']))
        acceleration = context.planner.cartesian.acceleration_limit
        assert result.time_optimal_bound == pytest.approx(2 * math.sqrt(length / acceleration))
        assert result.time_optimal_bound <= result.duration
    else:
        assert result.time_optimal_bound is None


def test_a_sweep_reports_the_time_optimal_lower_bound_at_the_planner_min_radius(context):
    from walker_planner.core.bounds import time_optimal_bound

    min_radius = context.planner.bang_bang.min_radius
    for goal, sweep in (((-0.9, 0.0, H), math.pi / 2), ((0.0, -0.9, H), math.pi)):
        result = plan(PlanRequest('bang_bang_node', 'a', ABOVE, goal), context)
        assert result.time_optimal_bound == pytest.approx(
            time_optimal_bound(context.robot, sweep, 0.9, min_radius))
        yaw = context.robot.robot.drive.yaw
        # no faster than the yaw's speed limit, and it must also speed up and slow down
        assert result.time_optimal_bound > sweep / yaw.velocity_limit + 0.1


def test_the_bang_bang_plan_ends_on_the_node_and_reports_its_solution(context, stance):
    for goal, sweep in (((-0.9, 0.0, H), 90.0), ((0.0, -0.9, H), 180.0)):
        result = plan(PlanRequest('bang_bang_node', 'a', ABOVE, goal), context)
        tips = tip_positions(context, result)
        np.testing.assert_allclose(tips[-1, :3], goal, atol=1e-9)
        assert result.solution.profile.half_sweep == pytest.approx(math.radians(sweep / 2))
        assert abs(result.samples.position[-1, 0] - stance[0]) == pytest.approx(
            math.radians(sweep))
        np.testing.assert_allclose(tips[:, 2], H, atol=1e-9)


@pytest.mark.parametrize('direction', [1, -1])
def test_a_half_turn_goes_the_way_asked(context, stance, direction):
    result = plan(PlanRequest('bang_bang_node', 'a', ABOVE, (0.0, -0.9, H),
                              sweep_direction=direction), context)
    turn = result.samples.position[-1, 0] - result.samples.position[0, 0]
    assert turn == pytest.approx(direction * math.pi)
    assert np.all(np.diff(result.samples.position[:, 0]) * direction >= -1e-12)


@pytest.mark.parametrize('name', ['joint_parabolic_accel', 'bang_bang_node', 'insertion_line'])
def test_gripper_b_as_base_mirrors_the_joint_order(name, context, stance):
    asked = requests(stance)[name]
    if TRAJECTORY_TYPES[name].space != CARTESIAN:
        asked = dict(asked, start=stance[::-1], goal=turned(stance, 0.4)[::-1])
    a = plan(PlanRequest(name, 'a', **requests(stance)[name]), context)
    b = plan(PlanRequest(name, 'b', **asked), context)
    np.testing.assert_allclose(b.samples.position, a.samples.position[:, ::-1], atol=1e-12)


@settings(max_examples=15, deadline=None)
@given(st.lists(st.floats(-0.5, 0.5), min_size=5, max_size=5),
       st.sampled_from(['joint_parabolic_accel', 'joint_min_jerk']))
def test_joint_moves_anywhere_within_the_limits_reach_their_goal(context, stance, offsets,
                                                                 name):
    goal = np.array(stance) + np.array(offsets)
    if np.max(np.abs(offsets)) < 1e-6:
        return
    result = plan(PlanRequest(name, 'a', stance, tuple(goal)), context)
    np.testing.assert_allclose(result.samples.position[-1], goal, atol=1e-12)
    limits = context.robot.robot.drive.role_array('velocity_limit')
    assert np.all(np.abs(result.samples.velocity) <= limits * (1 + 1e-9))
    peak = np.max(np.abs(result.samples.acceleration))
    assert peak <= context.planner.joint.max_acceleration * (1 + 1e-9)


def refused(stance):
    q = stance
    return [
        ({'trajectory_type': 'teleport'}, InvalidRequestError, 'unknown trajectory type'),
        ({'base_gripper': 'c'}, InvalidRequestError, 'unknown base gripper'),
        ({'start': q[:4]}, InvalidRequestError, 'start .* must have 5 values'),
        ({'goal': (math.nan, *q[1:])}, InvalidRequestError, 'goal .* must be finite'),
        ({'duration': math.inf}, InvalidRequestError, 'duration must be a finite number'),
        ({'max_velocity': -1.0}, LimitError, 'max_velocity must not be negative'),
        ({'max_velocity': 2.0}, LimitError, 'max_velocity .* exceeds the limit 1.5'),
        ({'max_acceleration': 10.0}, LimitError, 'max_acceleration .* exceeds the limit 2.5'),
        ({'min_radius': 0.5}, InvalidRequestError, 'does not take min_radius'),
        ({'start_joints': q}, InvalidRequestError, 'does not take start_joints'),
        ({'goal': q}, InvalidRequestError, 'goal equals start'),
        ({'goal': (q[0], 2.5, *q[2:])}, WorkspaceError, 'goal: J2 = 2.5000 rad is outside'),
        ({'trajectory_type': 'joint_parabolic_time'}, InvalidRequestError,
         'settling time: give duration'),
        ({'trajectory_type': 'joint_parabolic_time', 'duration': 0.1}, LimitError,
         'too short for the limits'),
        ({'trajectory_type': 'cartesian_line', 'start': ABOVE, 'goal': (0.0, 1.5, H)},
         WorkspaceError, 'out of reach'),
        ({'trajectory_type': 'cartesian_line', 'start': ABOVE, 'goal': (0.0, 0.8, H),
          'duration': 2.0}, InvalidRequestError, 'does not take duration'),
        ({'trajectory_type': 'cartesian_line', 'start': ABOVE, 'goal': (0.0, 0.5, H),
          'max_velocity': 3.0}, LimitError,
         'J3 \\(vertex_joint\\) to turn at .* velocity limit'),
        ({'trajectory_type': 'cartesian_line', 'start': ABOVE, 'goal': (0.0, 0.8, H),
          'start_joints': q[:3]}, InvalidRequestError, 'start_joints .* must have 5 values'),
        ({'trajectory_type': 'cartesian_line', 'start': (0.0, 0.8, H), 'goal': ABOVE,
          'start_joints': q}, InvalidRequestError, 'start_joints put the tip at'),
        ({'trajectory_type': 'cartesian_line', 'start': (0.0, 1.4, H), 'goal': ABOVE},
         WorkspaceError, 'start .* out of reach'),
        ({'trajectory_type': 'insertion_line', 'start': ABOVE, 'goal': (0.01, 0.9, 0.0)},
         InvalidRequestError, 'vertically aligned, but they are 10.00 mm apart'),
        ({'trajectory_type': 'insertion_line', 'start': (0.0, 0.9, 0.0), 'goal': ABOVE},
         InvalidRequestError, 'goal must be below'),
        ({'trajectory_type': 'extraction_line', 'start': ABOVE, 'goal': (0.0, 0.9, 0.0)},
         InvalidRequestError, 'goal must be above'),
        ({'trajectory_type': 'bang_bang_node', 'start': ABOVE, 'goal': (-0.8, 0.0, H)},
         NoSolutionError, 'same distance from the base yaw axis'),
        ({'trajectory_type': 'bang_bang_node', 'start': ABOVE, 'goal': (-0.9, 0.0, 0.1)},
         NoSolutionError, 'heights differ'),
        ({'trajectory_type': 'bang_bang_node', 'start': ABOVE, 'goal': (-0.9, 0.0, H),
          'min_radius': 1.0}, NoSolutionError, 'rho_min above the start radius'),
        ({'trajectory_type': 'bang_bang_node', 'start': ABOVE, 'goal': (-0.9, 0.0, H),
          'duration': 0.2}, LimitError, 'shorter than the fastest'),
        ({'trajectory_type': 'bang_bang_node', 'start': ABOVE, 'goal': (-0.9, 0.0, H),
          'max_velocity': 1.0}, InvalidRequestError, 'does not take max_velocity'),
        ({'trajectory_type': 'bang_bang_node',
          'start': (-0.9 * math.sin(3.0), 0.9 * math.cos(3.0), H),
          'goal': (-0.9 * math.sin(3.0 + math.pi / 2), 0.9 * math.cos(3.0 + math.pi / 2), H)},
         WorkspaceError, 'J1 = .* outside its limits .* J1 = a_yaw_joint'),
        ({'sweep_direction': 1}, InvalidRequestError, 'does not take sweep_direction'),
        ({'trajectory_type': 'bang_bang_node', 'start': ABOVE, 'goal': (0.0, -0.9, H),
          'sweep_direction': 2}, InvalidRequestError, 'sweep_direction must be -1, 0 or \\+1'),
        ({'trajectory_type': 'bang_bang_node', 'start': ABOVE, 'goal': (-0.9, 0.0, H),
          'sweep_direction': -1}, NoSolutionError, 'goes one way only'),
        ({'trajectory_type': 'bang_bang_node',
          'start': (-0.9 * math.sin(2.0), 0.9 * math.cos(2.0), H),
          'goal': (-0.9 * math.sin(2.0 + math.pi), 0.9 * math.cos(2.0 + math.pi), H),
          'start_joints': (2.0, *stance[1:4], 2.0), 'sweep_direction': 1}, NoSolutionError,
         'half turn counterclockwise takes J1'),
    ]


@pytest.mark.parametrize('case', range(33))
def test_invalid_requests_are_refused_naming_what_is_wrong(case, context, stance):
    changes, error, words = refused(stance)[case]
    fields = {'trajectory_type': 'joint_parabolic_accel', 'base_gripper': 'a', 'start': stance,
              'goal': turned(stance, 0.4)}
    fields.update(changes)
    with pytest.raises(error, match=words):
        plan(PlanRequest(**fields), context)


def test_the_refusal_table_covers_every_case(stance):
    assert len(refused(stance)) == 33
    assert all(issubclass(error, PlanningError) for _, error, _ in refused(stance))
