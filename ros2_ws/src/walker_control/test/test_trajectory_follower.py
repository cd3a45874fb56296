"""The trajectory a controller holds: joint_trajectory_controller's semantics, without ROS."""

import math

import numpy as np
import pytest

from walker_control.core.trajectory_follower import (
    JointTrajectory, TrajectoryError, TrajectoryFollower)

JOINTS = ('a_yaw_joint', 'a_pitch_joint')
PERIOD = 0.002  # [s] the control period the follower is sampled at


def ramp(start=0.0, times=(0.0, 1.0), positions=((0.0, 0.0), (1.0, -1.0)), **kwargs):
    """Return a trajectory for JOINTS: positions only unless velocities are given."""
    return JointTrajectory.from_points(JOINTS, JOINTS, times, positions, start=start, **kwargs)


def follower_with(trajectory, now=10.0, measured=None):
    follower = TrajectoryFollower(JOINTS)
    follower.set_trajectory(trajectory, now, measured)
    return follower


# ----------------------------------------------------------------------- sampling at the points
def test_before_any_trajectory_there_is_no_reference():
    assert TrajectoryFollower(JOINTS).sample(1.0) is None


def test_the_points_themselves_are_sampled_exactly():
    trajectory = ramp(start=10.0, times=(0.0, 0.5, 1.0),
                      positions=((0.0, 0.0), (0.3, 0.1), (1.0, -1.0)),
                      velocities=((0.0, 0.0), (1.2, -0.4), (0.0, 0.0)),
                      accelerations=((0.0, 0.0), (0.5, 0.5), (0.0, 0.0)))
    follower = follower_with(trajectory, now=9.0)
    middle = follower.sample(10.5)
    assert np.allclose(middle.positions, [0.3, 0.1])
    assert np.allclose(middle.velocities, [1.2, -0.4])
    assert np.allclose(middle.accelerations, [0.5, 0.5])


@pytest.mark.parametrize('derivatives', [
    {}, {'velocities': ((0.0, 0.0), (0.0, 0.0))},
    {'velocities': ((0.0, 0.0), (0.0, 0.0)), 'accelerations': ((0.0, 0.0), (0.0, 0.0))}])
def test_interpolation_is_continuous_and_its_velocity_is_the_rate_of_its_position(derivatives):
    follower = follower_with(ramp(start=10.0, **derivatives), now=10.0)
    times = np.arange(10.0, 11.0, PERIOD)
    samples = [follower.sample(t) for t in times]
    positions = np.array([s.positions for s in samples])
    velocities = np.array([s.velocities for s in samples])
    assert np.max(np.abs(np.diff(positions, axis=0))) < 0.01
    # central differences against the sampled velocity (linear, cubic and quintic alike)
    rates = (positions[2:] - positions[:-2]) / (2 * PERIOD)
    assert np.allclose(rates, velocities[1:-1], atol=2e-2)


def test_a_linear_segment_moves_at_its_slope_without_acceleration():
    sample = follower_with(ramp(start=10.0), now=10.0).sample(10.25)
    assert np.allclose(sample.positions, [0.25, -0.25])
    assert np.allclose(sample.velocities, [1.0, -1.0])
    assert np.allclose(sample.accelerations, 0.0)


def test_after_the_end_the_last_point_is_held_at_rest():
    follower = follower_with(ramp(start=10.0, velocities=((0.0, 0.0), (0.5, 0.5))), now=10.0)
    for t in (11.0, 11.002, 20.0):
        sample = follower.sample(t)
        assert sample.ended
        assert np.allclose(sample.positions, [1.0, -1.0])
        assert np.allclose(sample.velocities, 0.0) and np.allclose(sample.accelerations, 0.0)
    assert not follower.sample(10.998).ended


def test_a_zero_start_time_starts_when_received():
    follower = follower_with(ramp(start=0.0), now=10.0)
    assert follower.sample(9.999) is None
    assert np.allclose(follower.sample(10.5).positions, [0.5, -0.5])


def test_a_future_trajectory_applies_only_from_its_start():
    follower = follower_with(ramp(start=12.0), now=10.0)
    assert follower.sample(11.0) is None
    assert np.allclose(follower.sample(12.5).positions, [0.5, -0.5])


def test_a_first_point_after_time_zero_is_reached_from_the_measured_position():
    trajectory = ramp(start=10.0, times=(1.0, 2.0), positions=((1.0, 1.0), (2.0, 2.0)))
    follower = follower_with(trajectory, now=10.0, measured=(0.0, 0.5))
    assert np.allclose(follower.sample(10.0).positions, [0.0, 0.5])
    halfway = follower.sample(10.5).positions
    assert 0.0 < halfway[0] < 1.0 and 0.5 < halfway[1] < 1.0
    assert np.allclose(follower.sample(11.0).positions, [1.0, 1.0])


# ------------------------------------------------------------------------------ replacement
def test_a_new_trajectory_replaces_the_old_one_from_its_start_time():
    follower = follower_with(ramp(start=10.0, times=(0.0, 2.0),
                                  positions=((0.0, 0.0), (2.0, 2.0))), now=10.0)
    follower.sample(10.4)
    # received at 10.5, to start at 11.0 from a first point one second later
    follower.set_trajectory(ramp(start=11.0, times=(1.0,), positions=((-1.0, -1.0),)),
                            now=10.5)
    # until 11.0 the old one is followed still
    assert np.allclose(follower.sample(10.8).positions, [0.8, 0.8])
    # from 11.0 the reference starts where the old one was then, and goes to the new point
    assert np.allclose(follower.sample(11.0).positions, [1.0, 1.0])
    assert np.allclose(follower.sample(12.0).positions, [-1.0, -1.0])
    assert np.allclose(follower.sample(13.0).positions, [-1.0, -1.0])


def test_a_replacement_with_a_point_at_time_zero_takes_over_at_once():
    follower = follower_with(ramp(start=10.0), now=10.0)
    follower.set_trajectory(ramp(start=0.0, times=(0.0, 1.0),
                                 positions=((0.2, 0.2), (0.2, 0.2))), now=10.5)
    assert np.allclose(follower.sample(10.5).positions, [0.2, 0.2])


def test_a_replacement_continues_the_reference_without_a_jump():
    old = ramp(start=10.0, times=(0.0, 2.0), positions=((0.0, 0.0), (2.0, 2.0)),
               velocities=((0.0, 0.0), (0.0, 0.0)), accelerations=((0.0, 0.0), (0.0, 0.0)))
    follower = follower_with(old, now=10.0)
    before = follower.sample(10.996)
    follower.set_trajectory(ramp(start=0.0, times=(0.5,), positions=((0.0, 0.0),),
                                 velocities=((0.0, 0.0),), accelerations=((0.0, 0.0),)),
                            now=11.0)
    after = follower.sample(11.0)
    # from the reference in force then, position, velocity and acceleration alike (a new
    # trajectory of positions only is reached linearly, as joint_trajectory_controller does)
    assert np.allclose(after.positions, before.positions, atol=0.01)
    assert np.allclose(after.velocities, before.velocities, atol=0.05)
    assert np.allclose(after.accelerations, before.accelerations, atol=0.05)


def test_a_queued_trajectory_is_dropped_by_one_that_starts_earlier():
    follower = follower_with(ramp(start=10.0), now=10.0)
    follower.set_trajectory(ramp(start=13.0, times=(0.0,), positions=((5.0, 5.0),)), now=10.1)
    follower.set_trajectory(ramp(start=12.0, times=(0.0,), positions=((3.0, 3.0),)), now=10.2)
    assert np.allclose(follower.sample(14.0).positions, [3.0, 3.0])


def test_a_later_queued_trajectory_keeps_the_one_before_it():
    follower = follower_with(ramp(start=10.0), now=10.0)
    follower.set_trajectory(ramp(start=12.0, times=(0.0,), positions=((3.0, 3.0),)), now=10.1)
    follower.set_trajectory(ramp(start=13.0, times=(0.0,), positions=((5.0, 5.0),)), now=10.2)
    assert np.allclose(follower.sample(12.5).positions, [3.0, 3.0])
    assert np.allclose(follower.sample(13.5).positions, [5.0, 5.0])


# ---------------------------------------------------------------------- the past and lateness
def test_a_late_trajectory_is_sampled_at_its_own_time():
    follower = follower_with(ramp(start=10.0), now=10.5)
    assert np.allclose(follower.sample(10.5).positions, [0.5, -0.5])


def test_a_trajectory_wholly_in_the_past_holds_its_last_point():
    follower = TrajectoryFollower(JOINTS)
    follower.set_trajectory(ramp(start=10.0), now=11.0)
    follower.set_trajectory(ramp(start=5.0), now=20.0)
    for t in (20.0, 25.0):
        sample = follower.sample(t)
        assert sample.ended and np.allclose(sample.positions, [1.0, -1.0])


def test_samples_do_not_depend_on_when_the_trajectory_arrived_before_it_applies():
    early = follower_with(ramp(start=10.0), now=9.0)
    late = follower_with(ramp(start=10.0), now=10.0)
    for t in np.arange(10.0, 11.2, 0.1):
        assert np.array_equal(early.sample(t).positions, late.sample(t).positions)


def test_a_hold_replaces_everything_from_now():
    follower = follower_with(ramp(start=10.0), now=10.0)
    follower.set_trajectory(ramp(start=12.0), now=10.1)
    follower.hold((0.4, 0.4), now=10.2)
    assert np.allclose(follower.sample(10.2).positions, [0.4, 0.4])
    assert np.allclose(follower.sample(12.5).positions, [0.4, 0.4])
    assert follower.end_time() == pytest.approx(10.2)


# ------------------------------------------------------------------------------- refusals
def test_an_empty_trajectory_is_refused():
    with pytest.raises(TrajectoryError, match='no points'):
        ramp(times=(), positions=())


@pytest.mark.parametrize('times, words', [
    ((0.0, math.nan), 'finite'), ((0.0, math.inf), 'finite'),
    ((0.5, 0.5), 'strictly increasing'), ((1.0, 0.5), 'strictly increasing'),
    ((-0.1, 0.5), '>= 0')])
def test_bad_times_are_refused(times, words):
    with pytest.raises(TrajectoryError, match=words):
        ramp(times=times)


@pytest.mark.parametrize('field', ['positions', 'velocities', 'accelerations'])
@pytest.mark.parametrize('value', [math.nan, math.inf, -math.inf])
def test_non_finite_values_are_refused_by_field(field, value):
    rows = {'positions': ((0.0, 0.0), (1.0, 1.0)), 'velocities': ((0.0, 0.0), (0.0, 0.0)),
            'accelerations': ((0.0, 0.0), (0.0, 0.0))}
    rows[field] = ((0.0, value), (1.0, 1.0))
    with pytest.raises(TrajectoryError, match=f'{field} must be finite'):
        ramp(**rows)


@pytest.mark.parametrize('kwargs, words', [
    ({'positions': ((0.0,), (1.0, 1.0))}, 'point 0 has 1 positions for 2'),
    ({'positions': ((0.0, 0.0),)}, '1 rows of positions for 2 points'),
    ({'velocities': ((0.0, 0.0), (0.0,))}, 'point 1 has 1 velocities'),
    ({'accelerations': ((0.0, 0.0), (0.0, 0.0))}, 'without velocities')])
def test_malformed_sizes_are_refused(kwargs, words):
    with pytest.raises(TrajectoryError, match=words):
        ramp(**kwargs)


def test_a_missing_or_doubled_joint_is_refused():
    with pytest.raises(TrajectoryError, match='does not name a_pitch_joint'):
        JointTrajectory.from_points(JOINTS, ('a_yaw_joint', 'vertex_joint'), (0.0,),
                                    ((0.0, 0.0),))
    with pytest.raises(TrajectoryError, match='named twice'):
        JointTrajectory.from_points(JOINTS, ('a_yaw_joint', 'a_yaw_joint'), (0.0,),
                                    ((0.0, 0.0),))


def test_a_trajectory_for_more_joints_gives_each_follower_its_own_columns():
    names = ('vertex_joint', 'a_pitch_joint', 'a_yaw_joint')
    trajectory = JointTrajectory.from_points(('a_yaw_joint',), names, (0.0,),
                                             ((3.0, 2.0, 1.0),), start=1.0)
    follower = TrajectoryFollower(('a_yaw_joint',))
    follower.set_trajectory(trajectory, now=1.0)
    assert np.allclose(follower.sample(1.0).positions, [1.0])


def test_a_refused_trajectory_changes_nothing():
    follower = follower_with(ramp(start=10.0), now=10.0)
    with pytest.raises(TrajectoryError):
        follower.set_trajectory(ramp(start=10.0), now=math.nan)
    with pytest.raises(TrajectoryError, match='joints'):
        follower.set_trajectory(JointTrajectory.from_points(
            ('a_yaw_joint',), JOINTS, (0.0,), ((0.0, 0.0),)), now=10.5)
    assert np.allclose(follower.sample(10.5).positions, [0.5, -0.5])
