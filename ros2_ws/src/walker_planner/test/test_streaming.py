"""Streaming: interpolation of a JointTrajectory, its validation, and the setpoints' timing."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_planner.core.errors import InvalidRequestError, LimitError
from walker_planner.core.planning import PlanRequest, plan
from walker_planner.core.streaming import (
    SampledTrajectory, SetpointStream, check_start, stamps_due)

NAMES = list(PHYSICAL_JOINT_NAMES)
MS = 1_000_000


def quintic(t, coefficients):
    """Evaluate a degree-5 polynomial per joint and its first two derivatives."""
    c = np.asarray(coefficients)
    powers = np.arange(6)
    p = np.sum(c * t ** powers, axis=-1)
    v = np.sum(c[..., 1:] * powers[1:] * t ** (powers[1:] - 1), axis=-1)
    a = np.sum(c[..., 2:] * powers[2:] * (powers[2:] - 1) * t ** (powers[2:] - 2), axis=-1)
    return p, v, a


@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(-0.3, 0.3), min_size=30, max_size=30),
       st.lists(st.floats(0.05, 0.5), min_size=2, max_size=6))
def test_quintic_hermite_interpolation_is_exact_for_quintics(values, gaps):
    coefficients = np.array(values).reshape(5, 6)
    times = np.concatenate([[0.0], np.cumsum(gaps)])
    knots = np.array([quintic(t, coefficients) for t in times])  # (N, 3, 5)
    trajectory = SampledTrajectory.from_points(NAMES, times, knots[:, 0], knots[:, 1],
                                               knots[:, 2])
    t = np.linspace(times[0] + 1e-3, times[-1] - 1e-3, 57)
    sampled = trajectory.sample(t)
    exact = np.array([quintic(x, coefficients) for x in t])
    np.testing.assert_allclose(sampled.position, exact[:, 0], atol=1e-9)
    np.testing.assert_allclose(sampled.velocity, exact[:, 1], atol=1e-8)
    np.testing.assert_allclose(sampled.acceleration, exact[:, 2], atol=1e-6)


@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(-0.3, 0.3), min_size=30, max_size=30),
       st.lists(st.floats(0.05, 0.5), min_size=2, max_size=6),
       st.sampled_from(['quintic', 'cubic', 'linear']),
       st.lists(st.floats(-0.2, 2.0), min_size=1, max_size=12))
def test_one_sample_time_gives_what_an_array_of_times_gives(values, gaps, kind, where):
    """The stream's scalar path and the array path agree, inside, at and beyond the points."""
    coefficients = np.array(values).reshape(5, 6)
    times = np.concatenate([[0.0], np.cumsum(gaps)])
    knots = np.array([quintic(t, coefficients) for t in times])
    derivatives = {'quintic': (knots[:, 1], knots[:, 2]), 'cubic': (knots[:, 1],),
                   'linear': ()}[kind]
    trajectory = SampledTrajectory.from_points(NAMES, times, knots[:, 0], *derivatives)
    at = np.concatenate([np.array(where) * times[-1], times])
    together = trajectory.sample(at)
    for k, t in enumerate(at):
        alone = trajectory.sample(float(t))
        for one, many in zip(alone, together, strict=True):
            np.testing.assert_allclose(one, many[k], rtol=1e-9, atol=1e-9)


def test_cubic_and_linear_interpolation_when_the_points_carry_less():
    times = [0.0, 1.0, 2.0]
    positions = [[0.0] * 5, [1.0] * 5, [0.0] * 5]
    linear = SampledTrajectory.from_points(NAMES, times, positions)
    np.testing.assert_allclose(linear.sample(0.5).position, 0.5)
    cubic = SampledTrajectory.from_points(NAMES, times, positions,
                                          [[0.0] * 5, [0.0] * 5, [0.0] * 5])
    np.testing.assert_allclose(cubic.sample(0.5).position, 0.5)
    np.testing.assert_allclose(cubic.sample(1.0).velocity, 0.0)
    assert cubic.sample(0.25).position[0] < 0.25  # eases out of rest


def test_points_are_reordered_to_the_physical_joints():
    names = NAMES[::-1]
    trajectory = SampledTrajectory.from_points(names, [0.0, 1.0], [[1, 2, 3, 4, 5]] * 2)
    np.testing.assert_allclose(trajectory.sample(0.5).position, [5, 4, 3, 2, 1])


def test_before_and_after_the_points_the_trajectory_rests():
    trajectory = SampledTrajectory.from_points(NAMES, [0.5, 1.0], [[0.0] * 5, [1.0] * 5],
                                               [[0.2] * 5, [0.2] * 5])
    for t, expected in ((0.0, 0.0), (2.0, 1.0)):
        sample = trajectory.sample(t)
        np.testing.assert_allclose(sample.position, expected)
        np.testing.assert_allclose(sample.velocity, 0.0)


@pytest.mark.parametrize('names, times, positions, velocities, error, words', [
    (NAMES[:4], [0.0], [[0.0] * 4], [], InvalidRequestError, 'must be the five joints'),
    (NAMES[:4] + ['elbow'], [0.0], [[0.0] * 5], [], InvalidRequestError, 'five joints'),
    (NAMES, [], [], [], InvalidRequestError, 'no points'),
    (NAMES, [0.0, 0.0], [[0.0] * 5] * 2, [], InvalidRequestError, 'strictly increasing'),
    (NAMES, [-1.0], [[0.0] * 5], [], InvalidRequestError, 'non-negative'),
    (NAMES, [0.0], [[0.0] * 4], [], InvalidRequestError, 'needs 5 positions'),
    (NAMES, [0.0, 1.0], [[0.0] * 5] * 2, [[0.0] * 5, []], InvalidRequestError,
     '5 velocities .* or none'),
    (NAMES, [0.0], [[0.0, math.nan, 0.0, 0.0, 0.0]], [], InvalidRequestError, 'finite'),
    (NAMES, [0.0], [[0.0, 2.5, 0.0, 0.0, 0.0]], [], LimitError,
     'a_pitch_joint goes to .* outside its limits'),
    (NAMES, [0.0, 1.0], [[0.0] * 5] * 2, [[0.0] * 5, [0, 0, 0, 0, 3.0]], LimitError,
     'b_yaw_joint moves at 3 rad/s, above its velocity limit'),
])
def test_malformed_trajectories_are_refused(robot, names, times, positions, velocities, error,
                                            words):
    with pytest.raises(error, match=words):
        SampledTrajectory.from_points(names, times, positions, velocities or
                                      [[] for _ in times], [[] for _ in times], robot)


def test_each_setpoint_applies_one_period_ahead_and_carries_the_planned_sample(context):
    stance = context.kinematics.inverse([0.0, 0.9, 0.03, 0.0, 0.0])
    goal = stance + np.array([0.3, 0, 0, 0, 0.3])
    planned = plan(PlanRequest('joint_min_jerk', 'a', tuple(stance), tuple(goal)), context)
    trajectory = SampledTrajectory(planned.times, *planned.samples)
    period = 2 * MS
    stream = SetpointStream(trajectory, start=10_000 * MS, period=period)
    for k in range(0, len(planned.times) - 1, 37):
        now = 10_000 * MS + k * period
        setpoint = stream.setpoint(now)
        assert setpoint.stamp == now + period
        assert setpoint.time_from_start == pytest.approx(k * period / 1e9, abs=1e-12)
        np.testing.assert_allclose(setpoint.position, planned.samples.position[k], atol=1e-12)
        np.testing.assert_allclose(setpoint.velocity, planned.samples.velocity[k], atol=1e-12)
        assert not setpoint.final
    last = stream.setpoint(10_000 * MS + int(planned.duration * 1e9) + period)
    assert last.final
    np.testing.assert_allclose(last.position, goal, atol=1e-12)
    np.testing.assert_allclose(last.velocity, 0.0)
    hold = stream.hold(10_000 * MS, stream.setpoint(10_000 * MS + 300 * period))
    np.testing.assert_allclose(hold.velocity, 0.0)
    assert hold.final


def test_a_stream_starts_only_where_the_robot_is():
    trajectory = SampledTrajectory.from_points(NAMES, [0.0, 1.0], [[0.0] * 5, [1.0] * 5])
    check_start(trajectory, np.full(5, 0.01), tolerance=0.05)
    with pytest.raises(LimitError, match='0.1000 rad away from the measured vertex_joint'):
        check_start(trajectory, np.array([0, 0, 0.1, 0, 0]), tolerance=0.05)
    with pytest.raises(LimitError, match='no joint_states received'):
        check_start(trajectory, None, tolerance=0.05)


def test_the_tracking_error_compares_a_state_with_the_setpoint_for_its_stamp():
    trajectory = SampledTrajectory.from_points(NAMES, [0.0, 1.0], [[0.0] * 5, [1.0] * 5])
    stream = SetpointStream(trajectory, start=0, period=2 * MS)
    # trajectory time 0.5 s applies at 0.5 s + one period
    assert stream.tracking_error(502 * MS, np.full(5, 0.45)) == pytest.approx(0.05)


def test_the_setpoints_due_reach_the_lookahead_once_each_and_end_with_the_final():
    trajectory = SampledTrajectory.from_points(NAMES, [0.0, 0.02], [[0.0] * 5, [1.0] * 5])
    period = 2 * MS
    stream = SetpointStream(trajectory, start=0, period=period)
    first = stream.due(0, None, lookahead=4)  # the stream's start: four at once
    assert [s.stamp for s in first] == [period, 2 * period, 3 * period, 4 * period]
    for setpoint in first:  # each the same as sent just in time, one period ahead
        just_in_time = stream.setpoint(setpoint.stamp - period)
        assert setpoint.time_from_start == just_in_time.time_from_start
        np.testing.assert_array_equal(setpoint.position, just_in_time.position)
    sent = first[-1]
    assert [s.stamp for s in stream.due(period, sent, 4)] == [5 * period]
    assert stream.due(period, stream.due(period, sent, 4)[-1], 4) == []  # nothing twice
    # a planner that missed states sends what is still ahead of the newest, not the past
    late = stream.due(8 * period, stream.setpoint_at(5 * period), 4)
    assert [s.stamp for s in late] == [9 * period, 10 * period, 11 * period]
    assert late[-1].final and not late[-2].final  # the end (0.02 s after origin) stops it
    assert stream.due(9 * period, late[-1], 4) == []
    with pytest.raises(ValueError, match='lookahead'):
        stream.due(0, None, 0)


def test_a_hold_after_setpoints_sent_ahead_stops_where_they_end():
    trajectory = SampledTrajectory.from_points(NAMES, [0.0, 1.0], [[0.0] * 5, [1.0] * 5],
                                               [[0.0] * 5, [0.0] * 5])
    period = 2 * MS
    stream = SetpointStream(trajectory, start=0, period=period)
    sent = stream.due(100 * period, stream.setpoint_at(100 * period), 4)[-1]
    hold = stream.hold(100 * period, sent)
    assert hold.stamp == sent.stamp + period  # after the last sent: no jump back
    np.testing.assert_array_equal(hold.position, sent.position)
    np.testing.assert_array_equal(hold.velocity, 0.0)
    assert hold.final
    # sent just in time (a lookahead of one), the hold applies at the next state
    assert stream.hold(100 * period, stream.setpoint(99 * period)).stamp == 101 * period


def test_the_stamps_due_start_after_the_last_sent_and_one_period_after_the_state():
    period = 2 * MS
    assert list(stamps_due(10 * period, None, period, 3)) == [11 * period, 12 * period,
                                                             13 * period]
    assert list(stamps_due(11 * period, 13 * period, period, 3)) == [14 * period]
    assert list(stamps_due(11 * period, 14 * period, period, 3)) == []  # nothing twice
    assert list(stamps_due(20 * period, 14 * period, period, 1)) == [21 * period]  # missed
    for bad in (0, 1.5, True):
        with pytest.raises(ValueError, match='lookahead'):
            stamps_due(0, None, period, bad)
