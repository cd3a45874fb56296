"""The planner node sending whole trajectories (``planner.send_whole_trajectories``).

The node runs as a separate process with ``use_sim_time``; the test owns ``/clock`` and the
joint states, as the plant does, and listens on ``controllers/joint_trajectory`` as the
controllers do. A followed trajectory must go out once, whole, stamped with the clock time of
its start, with no setpoint stream; its goal must succeed when the clock reaches the
trajectory's end, with no joint state heard meanwhile (the controllers follow it without the
planner); a cancel must go out as a one-point trajectory at rest holding where the trajectory
is on the clock then.
"""

import numpy as np
import pytest

from ros_test_support import NodeProcess, isolated_domain, ros_environment
from test_planner_node import NODE, WAIT, Probe, _stamp, settle

pytestmark = pytest.mark.integration

#: [s] wall time the node is given to do what it must not do (end a goal early, send again)
QUIET = 0.5


@pytest.fixture(scope='module')
def graph(planner_parameters):
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from trajectory_msgs.msg import JointTrajectory

    with isolated_domain() as domain:
        env = ros_environment(domain)
        args = [str(NODE), '--ros-args', '-r', '__ns:=/walker', '-p', 'use_sim_time:=true',
                '-p', 'planner.send_whole_trajectories:=true']
        with NodeProcess(args, env, 'planner') as planner:
            probe = Probe(domain)
            probe.trajectories = []
            probe.node.create_subscription(
                JointTrajectory, '/walker/controllers/joint_trajectory',
                probe.trajectories.append,
                QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE))
            try:
                assert planner.wait_for_output('planner ready', WAIT), planner.output
                assert probe.planner.wait_for_service(timeout_sec=WAIT), planner.output
                assert probe.follow.wait_for_server(timeout_sec=WAIT), planner.output
                probe.publish_clock()
                yield probe, planner
            finally:
                probe.close()
            assert planner.stop() == 0, planner.output


@pytest.fixture(scope='module')
def stance(context):
    return context.kinematics.inverse([0.0, 0.9, 0.03, 0.0, 0.0])


@pytest.fixture(scope='module')
def period(context):
    return int(round(1e9 / context.robot.timing.control_rate))


def _plan(probe, stance, duration):
    planned = probe.call(trajectory_type='joint_min_jerk', base_gripper='a',
                         start=stance.tolist(), goal=(stance + 0.04).tolist(),
                         duration=duration)
    assert planned.success, planned.message
    return planned.trajectory


def _follow(probe, trajectory):
    """Send a goal; return its handle once accepted and its trajectory message once sent."""
    probe.trajectories.clear()
    sent = probe.follow.send_goal_async(probe.Goal(trajectory=trajectory))
    assert probe.spin_until(sent.done)
    handle = sent.result()
    assert handle.accepted
    assert probe.spin_until(lambda: probe.trajectories), 'no trajectory was sent'
    return handle, probe.trajectories[0]


def _tick_clock(probe, period, count):
    """Advance the clock ``count`` periods, publishing no joint state (the plant runs on)."""
    for _ in range(count):
        probe.now += period
        probe.publish_clock()
        probe.spin_until(lambda: False, timeout=0.002)


def test_a_followed_trajectory_is_sent_once_whole_and_ends_on_the_clock(graph, stance,
                                                                         period):
    from action_msgs.msg import GoalStatus
    from walker_planner.conversions import sampled_trajectory

    probe, _ = graph
    settle(probe, stance)
    trajectory = _plan(probe, stance, 0.6)
    probe.clear()
    started = probe.now  # the clock and the newest state: the trajectory's time 0 a period on
    handle, sent = _follow(probe, trajectory)
    assert _stamp(sent) == started + period
    assert list(sent.joint_names) == list(probe.names)
    theirs, mine = sampled_trajectory(trajectory), sampled_trajectory(sent)
    np.testing.assert_allclose(mine.times, theirs.times, rtol=0, atol=1e-9)
    for ours, planned in ((mine.positions, theirs.positions),
                          (mine.velocities, theirs.velocities),
                          (mine.accelerations, theirs.accelerations)):
        np.testing.assert_allclose(ours, planned, rtol=0, atol=1e-12)
    # the end on the clock: the first period at or after the trajectory's duration
    end = started + period + int(np.ceil(round(mine.duration * 1e9) / period)) * period
    result = handle.get_result_async()
    _tick_clock(probe, period, (end - period - probe.now) // period - 1)
    probe.spin_until(lambda: False, timeout=QUIET)
    assert not result.done(), 'the goal ended before the clock reached the trajectory end'
    _tick_clock(probe, period, 1)  # one period before the end: the state the end comes with
    assert probe.spin_until(result.done), 'the goal did not end at the trajectory end'
    assert result.result().status == GoalStatus.STATUS_SUCCEEDED
    assert result.result().result.success
    assert result.result().result.duration == pytest.approx(mine.duration, abs=period * 1e-9)
    _tick_clock(probe, period, 20)  # and nothing afterwards: the controllers hold its end
    probe.spin_until(lambda: False, timeout=QUIET)
    assert len(probe.trajectories) == 1 and probe.count() == 0, \
        (len(probe.trajectories), probe.count())


def test_cancel_holds_where_the_trajectory_is_on_the_clock(graph, stance, period):
    from action_msgs.msg import GoalStatus
    from walker_planner.conversions import sampled_trajectory

    probe, _ = graph
    settle(probe, stance)
    trajectory = _plan(probe, stance, 1.0)
    probe.clear()
    handle, sent = _follow(probe, trajectory)
    origin = _stamp(sent)
    _tick_clock(probe, period, 150)  # the plant runs on; the planner hears no state
    probe.spin_until(lambda: False, timeout=QUIET)  # the node's clock has caught up
    cancelled_at = probe.now
    cancelling = handle.cancel_goal_async()
    assert probe.spin_until(cancelling.done)
    result = handle.get_result_async()
    assert probe.spin_until(result.done)
    assert result.result().status == GoalStatus.STATUS_CANCELED
    assert not result.result().result.success
    assert probe.spin_until(lambda: len(probe.trajectories) == 2), 'no hold was sent'
    hold = probe.trajectories[1]
    assert _stamp(hold) == cancelled_at + period and len(hold.points) == 1
    point = hold.points[0]
    assert point.time_from_start.sec == 0 and point.time_from_start.nanosec == 0
    where = sampled_trajectory(sent).sample((cancelled_at - origin) * 1e-9).position
    assert 0.0 < np.max(np.abs(where - stance)) < 0.04  # under way: neither start nor end
    np.testing.assert_allclose(point.positions, where, rtol=0, atol=1e-12)
    assert list(point.velocities) == [0.0] * 5 and list(point.accelerations) == [0.0] * 5
    assert probe.count() == 0  # no setpoint: the hold is the trajectory
    # the planner is free again: a new goal is taken (from where the joints are)
    settle(probe, where)
    again = _plan(probe, where, 0.6)
    handle, _ = _follow(probe, again)
    cancelling = handle.cancel_goal_async()
    assert probe.spin_until(cancelling.done)
