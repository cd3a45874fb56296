"""The planner node as a separate process: service, setpoint stream, action, cancel, refusals.

The node runs with ``use_sim_time``; the test owns ``/clock`` and advances it one control
period at a time, waiting for the five setpoints of each tick, as the plant does in sim-time
mode. That makes the stream deterministic: every setpoint is checked against the core's plan,
and its stamp against the clock, with no timing in the assertions. The node streams setpoints
here (``planner.send_whole_trajectories`` false); whole trajectories:
``test_planner_node_whole_trajectories.py``.
"""

import contextlib
import copy
import math
import time

import numpy as np
import pytest

from ros_test_support import REPO_ROOT, NodeProcess, isolated_domain, ros_environment

pytestmark = pytest.mark.integration

NODE = REPO_ROOT / 'ros2_ws' / 'install' / 'walker_planner' / 'lib' / 'walker_planner' / \
    'planner_node'
START_NS = 100 * 1_000_000_000
WAIT = 20.0  # [s] of wall time for anything to arrive before a test fails


class Probe:
    """The test's side of the graph: clock, joint states, clients, setpoint subscribers."""

    def __init__(self, domain: int) -> None:
        import rclpy
        from rclpy.action import ActionClient
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from rosgraph_msgs.msg import Clock
        from sensor_msgs.msg import JointState
        from trajectory_msgs.msg import JointTrajectory
        from walker_msgs.action import FollowTrajectory
        from walker_msgs.msg import ControlMode, JointCommand
        from walker_msgs.srv import PlanTrajectory

        from walker_core.joint_roles import PHYSICAL_JOINT_NAMES

        self.names = PHYSICAL_JOINT_NAMES
        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain)
        self.node = Node('planner_probe', context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.clock_publisher = self.node.create_publisher(
            Clock, '/clock', QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE))
        self.state_publisher = self.node.create_publisher(
            JointState, '/walker/joint_states',
            QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT))
        self.planner = self.node.create_client(PlanTrajectory, '/walker/plan_trajectory')
        self.mode_publisher = self.node.create_publisher(
            ControlMode, '/walker/control_mode',
            QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.TRANSIENT_LOCAL))
        self.follow = ActionClient(self.node, FollowTrajectory, '/walker/follow_trajectory')
        self.setpoints = {name: [] for name in self.names}
        for name in self.names:
            self.node.create_subscription(
                JointCommand, f'/walker/controllers/{name}/setpoint',
                self.setpoints[name].append,
                QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE))
        self.plans = []
        self.latched_qos = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                                      durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.node.create_subscription(JointTrajectory, '/walker/planned_trajectory',
                                      self.plans.append, self.latched_qos)
        self.now = START_NS
        self.Clock, self.JointState = Clock, JointState
        self.Request, self.Goal = PlanTrajectory.Request, FollowTrajectory.Goal

    def close(self) -> None:
        import rclpy
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)

    def spin_until(self, done, timeout: float = WAIT) -> bool:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if done():
                return True
            self.executor.spin_once(timeout_sec=0.02)
        return done()

    def publish_clock(self) -> None:
        message = self.Clock()
        message.clock.sec, message.clock.nanosec = divmod(self.now, 1_000_000_000)
        self.clock_publisher.publish(message)

    def publish_state(self, positions) -> None:
        message = self.JointState(name=list(self.names), position=[float(x) for x in positions])
        message.header.stamp.sec, message.header.stamp.nanosec = divmod(self.now,
                                                                        1_000_000_000)
        self.state_publisher.publish(message)

    def command_mode(self, mode: str) -> None:
        from walker_msgs.msg import ControlMode

        value = {'hold': ControlMode.HOLD, 'fine': ControlMode.FINE}[mode]
        self.mode_publisher.publish(ControlMode(mode=value, base_gripper='a',
                                                commander='/walker/supervisor'))

    def call(self, **fields):
        future = self.planner.call_async(self.Request(**fields))
        assert self.spin_until(future.done), 'plan_trajectory did not answer'
        return future.result()

    def count(self) -> int:
        return min(len(messages) for messages in self.setpoints.values())

    def clear(self) -> None:
        for messages in self.setpoints.values():
            messages.clear()

    def step(self, positions, period_ns: int) -> None:
        """Advance the clock one period (with a joint state) and wait for that tick's setpoints."""
        expected = self.count() + 1
        self.now += period_ns
        self.publish_clock()
        self.publish_state(positions)
        assert self.spin_until(lambda: self.count() >= expected), \
            f'no setpoints for the tick at {self.now} ns'


@pytest.fixture(scope='module')
def graph(planner_parameters):
    with isolated_domain() as domain:
        env = ros_environment(domain)
        args = [str(NODE), '--ros-args', '-r', '__ns:=/walker', '-p', 'use_sim_time:=true',
                '-p', 'planner.send_whole_trajectories:=false']
        with NodeProcess(args, env, 'planner') as planner:
            probe = Probe(domain)
            probe.lookahead = planner_parameters.stream.lookahead
            try:
                assert planner.wait_for_output('planner ready', WAIT), planner.output
                assert probe.planner.wait_for_service(timeout_sec=WAIT), planner.output
                assert probe.follow.wait_for_server(timeout_sec=WAIT), planner.output
                probe.publish_clock()
                yield probe, planner
            finally:
                probe.close()
            assert planner.stop() == 0, planner.output  # SIGINT ends it cleanly


@pytest.fixture(scope='module')
def stance(context):
    return context.kinematics.inverse([0.0, 0.9, 0.03, 0.0, 0.0])


def settle(probe, positions):
    """Publish the clock and the robot's state until the node has surely seen both."""
    for _ in range(10):
        probe.publish_clock()
        probe.publish_state(positions)
        probe.spin_until(lambda: False, timeout=0.05)


def test_plan_trajectory_returns_the_core_plan_with_rates_and_the_bound(graph, context):
    from walker_planner.core.planning import PlanRequest, plan

    probe, _ = graph
    response = probe.call(trajectory_type='bang_bang_node', base_gripper='a',
                          start=[0.0, 0.9, 0.03], goal=[0.0, -0.9, 0.03])
    assert response.success, response.message
    expected = plan(PlanRequest('bang_bang_node', 'a', (0.0, 0.9, 0.03), (0.0, -0.9, 0.03)),
                    context)
    assert response.duration == pytest.approx(expected.duration)
    assert response.time_optimal_bound == pytest.approx(expected.time_optimal_bound)
    assert 0.0 < response.time_optimal_bound < response.duration
    points = response.trajectory.points
    assert list(response.trajectory.joint_names) == list(probe.names)
    assert len(points) == len(expected.times)
    for k in (0, len(points) // 3, len(points) - 1):
        np.testing.assert_allclose(points[k].positions, expected.samples.position[k])
        np.testing.assert_allclose(points[k].velocities, expected.samples.velocity[k])
        np.testing.assert_allclose(points[k].accelerations, expected.samples.acceleration[k])
    # the plan is latched: a subscriber that joins now still receives it
    from trajectory_msgs.msg import JointTrajectory
    late = []
    probe.node.create_subscription(JointTrajectory, '/walker/planned_trajectory', late.append,
                                   probe.latched_qos)
    assert probe.spin_until(lambda: late)
    assert len(late[-1].points) == len(points)


@pytest.mark.parametrize('fields, words', [
    ({'trajectory_type': 'warp'}, 'unknown trajectory type'),
    ({'goal': [0.0, math.nan, 0.03]}, 'must be finite'),
    ({'goal': [0.0, 0.9]}, 'must have 3 values'),
    ({'goal': [0.0, 1.5, 0.03]}, 'out of reach'),
    ({'max_velocity': -1.0}, 'must not be negative'),
    ({'base_gripper': 'z'}, 'unknown base gripper'),
])
def test_invalid_requests_are_refused_with_a_message(graph, fields, words):
    probe, _ = graph
    request = {'trajectory_type': 'cartesian_line', 'base_gripper': 'a',
               'start': [0.0, 0.88, 0.03], 'goal': [0.0, 0.9, 0.03]}
    request.update(fields)
    response = probe.call(**request)
    assert not response.success
    assert words in response.message
    assert len(response.trajectory.points) == 0


def test_execute_streams_the_plan_on_five_topics_each_setpoint_sent_ahead_of_its_state(
        graph, context, stance):
    """Each setpoint once, stamped with the time it applies, before the state it applies to.

    The stream keeps ``planner.stream.lookahead`` periods ahead of the newest joint state.
    """
    from walker_planner.core.planning import PlanRequest, plan

    probe, _ = graph
    lookahead = probe.lookahead
    goal = stance + np.array([0.02, 0.0, 0.0, 0.0, 0.02])
    settle(probe, stance)
    probe.clear()
    response = probe.call(trajectory_type='joint_min_jerk', base_gripper='a',
                          start=stance.tolist(), goal=goal.tolist(), duration=0.4,
                          execute=True)
    assert response.success, response.message
    expected = plan(PlanRequest('joint_min_jerk', 'a', tuple(stance), tuple(goal),
                                duration=0.4), context)
    period = int(round(1e9 / context.robot.timing.control_rate))
    origin = probe.now + period  # the clock when the stream began, plus one period
    assert probe.spin_until(lambda: probe.count() >= lookahead)
    while probe.count() < len(expected.times):
        assert _newest_stamp(probe) == probe.now + lookahead * period
        probe.step(stance, period)
    for j, name in enumerate(probe.names):
        messages = probe.setpoints[name]
        stamps = [m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec
                  for m in messages]
        assert stamps == [origin + k * period for k in range(len(expected.times))]
        assert all(m.joint_name == name for m in messages)
        np.testing.assert_allclose([m.position for m in messages],
                                   expected.samples.position[:, j], atol=1e-12)
        np.testing.assert_allclose([m.velocity for m in messages],
                                   expected.samples.velocity[:, j], atol=1e-12)
        np.testing.assert_allclose([m.acceleration for m in messages],
                                   expected.samples.acceleration[:, j], atol=1e-9)
    # the final setpoint is out: the stream ends at the state one period before it applies;
    # until then, and after (the controllers holding on their own), a tick brings nothing
    count = probe.count()
    for _ in range(lookahead):
        probe.now += period
        probe.publish_clock()
        probe.publish_state(stance)
        probe.spin_until(lambda: probe.count() > count, timeout=0.5)
        assert probe.count() == count
    # while they track (COARSE or FINE) they need a setpoint every period, one period ahead of
    # each state, at rest: back to tracking after a hold, where the joints are (the probe's
    # joints never followed the plan), not where the stream left its setpoints
    _assert_held_while_tracking(probe, stance, period)


def _assert_held_while_tracking(probe, positions, period):
    """Switch to FINE: each state is answered with ``positions`` at rest; then HOLD again."""
    probe.command_mode('fine')
    settle(probe, positions)
    _assert_holding(probe, positions, period)
    probe.command_mode('hold')
    settle(probe, positions)
    probe.clear()


def _assert_holding(probe, positions, period):
    """Two ticks, each answered by the five setpoints ``positions`` [rad] at rest.

    Every period up to ``planner.stream.lookahead`` after the tick has its hold, the one after
    the tick included.
    """
    for _ in range(2):
        probe.step(positions, period)
        ahead = probe.now + probe.lookahead * period  # a tick may bring several at once
        probe.spin_until(lambda ahead=ahead: min(_stamp(probe.setpoints[name][-1])
                                                 for name in probe.names) >= ahead)
        assert _newest_stamp(probe) == ahead
        for j, name in enumerate(probe.names):
            # the newest message for each time (a later one for the same time replaces it)
            held = {_stamp(m): m for m in probe.setpoints[name] if _stamp(m) > probe.now}
            assert sorted(held) == list(range(probe.now + period, ahead + 1, period))
            for stamp, hold in held.items():
                assert hold.position == pytest.approx(positions[j], abs=1e-12), \
                    (name, (stamp - probe.now) // period, hold.position - positions[j],
                     [((_stamp(m) - probe.now) // period, m.position - positions[j])
                      for m in probe.setpoints[name][-12:]])
                assert hold.velocity == 0.0 and hold.acceleration == 0.0


def _advance(probe, positions, period):
    """Advance the clock one period with a joint state; take what comes for a moment."""
    count = probe.count()
    probe.now += period
    probe.publish_clock()
    probe.publish_state(positions)
    probe.spin_until(lambda: probe.count() > count, timeout=0.2)


def _stamp(message) -> int:
    return message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec


def _newest_stamp(probe) -> int:
    """Stamp [ns] of the newest setpoint received, the same for the five joints."""
    newest = {_stamp(probe.setpoints[name][-1]) for name in probe.names}
    assert len(newest) == 1, newest
    return newest.pop()


def test_a_stream_ending_while_tracking_holds_its_last_setpoint_until_a_hold(graph, context,
                                                                            stance):
    """The controllers still tracking: the stream's end is held; after a hold, the joints.

    A stream cut short while the controllers hold (a fault) leaves its last setpoint where the
    arm never got to: going back to tracking must not pull the joints there.
    """
    probe, _ = graph
    period = int(round(1e9 / context.robot.timing.control_rate))
    goal = stance + np.array([0.03, 0.0, 0.0, 0.0, 0.03])
    settle(probe, stance)
    probe.command_mode('fine')
    settle(probe, stance)
    started = probe.now  # the newest state's stamp: the stream's start
    response = probe.call(trajectory_type='joint_min_jerk', base_gripper='a',
                          start=stance.tolist(), goal=goal.tolist(), duration=0.5,
                          execute=True)
    assert response.success, response.message
    end = response.trajectory.points[-1].time_from_start
    final = started + period + end.sec * 1_000_000_000 + end.nanosec  # the final setpoint's
    while not all(_stamp(probe.setpoints[name][-1]) >= final for name in probe.names):
        _advance(probe, stance, period)
    for _ in range(probe.lookahead - 1):  # the stream ends at the state before the final's
        _advance(probe, stance, period)
    _assert_holding(probe, goal, period)  # tracking throughout: the end of the stream
    probe.command_mode('hold')
    moved = stance + np.array([-0.01, 0.0, 0.0, 0.0, 0.02])  # the arm drifted meanwhile
    settle(probe, moved)
    probe.command_mode('fine')
    settle(probe, moved)
    _assert_holding(probe, moved, period)
    probe.command_mode('hold')
    settle(probe, stance)
    probe.clear()


def test_follow_trajectory_streams_with_feedback_and_cancel_holds(graph, context, stance):
    probe, _ = graph
    period = int(round(1e9 / context.robot.timing.control_rate))
    settle(probe, stance)
    planned = probe.call(trajectory_type='joint_parabolic_time', base_gripper='a',
                         start=stance.tolist(), goal=(stance + 0.05).tolist(), duration=1.0)
    assert planned.success, planned.message
    probe.clear()
    feedback = []
    sent = probe.follow.send_goal_async(probe.Goal(trajectory=planned.trajectory),
                                        feedback_callback=feedback.append)
    assert probe.spin_until(sent.done)
    handle = sent.result()
    assert handle.accepted
    assert probe.spin_until(lambda: probe.count() >= probe.lookahead)  # sent at once
    # a second goal while this one streams is refused, and so is executing a plan
    second = probe.follow.send_goal_async(probe.Goal(trajectory=planned.trajectory))
    assert probe.spin_until(second.done)
    assert not second.result().accepted
    busy = probe.call(trajectory_type='joint_parabolic_time', base_gripper='a',
                      start=stance.tolist(), goal=(stance + 0.05).tolist(), duration=1.0,
                      execute=True)
    assert not busy.success and 'already running' in busy.message
    for _ in range(60):
        probe.step(stance, period)
    assert probe.spin_until(lambda: len(feedback) >= 2)
    latest = feedback[-1].feedback
    assert 0.0 < latest.fraction < 1.0
    assert latest.time_from_start == pytest.approx(latest.fraction * 1.0)
    assert latest.max_position_error >= 0.0  # the robot (here: the probe) stays at the start
    count = probe.count()
    cancelling = handle.cancel_goal_async()
    assert probe.spin_until(cancelling.done)
    # the stream ends with the cancel, no joint state needed (a frozen plant sends none): the
    # hold setpoint goes out, the goal ends cancelled, and a new goal may start
    result = handle.get_result_async()
    assert probe.spin_until(result.done)
    from action_msgs.msg import GoalStatus
    assert result.result().status == GoalStatus.STATUS_CANCELED
    assert not result.result().result.success
    assert probe.spin_until(lambda: probe.count() >= count + 1)
    holds = [probe.setpoints[name][-1] for name in probe.names]
    assert all(h.velocity == 0.0 and h.acceleration == 0.0 for h in holds)
    assert probe.count() == count + 1
    probe.clear()


def _cpu_seconds(pid: int) -> float:
    """CPU time [s] a process has used so far, all its threads (/proc)."""
    import os

    with open(f'/proc/{pid}/stat') as stat:
        fields = stat.read().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')


def test_the_planner_idles_between_setpoints_while_a_goal_streams(graph, context, stance):
    """A goal under way must not keep the planner busy while no state comes to stream on.

    Its execution awaits the stream's end; under the events executor an awaited future made
    the node's spin loop return at once, over and over, and the planner burnt a core for the
    whole of every stream (at the decision priority, in real time).
    """
    probe, planner = graph
    settle(probe, stance)
    planned = probe.call(trajectory_type='joint_parabolic_time', base_gripper='a',
                         start=stance.tolist(), goal=(stance + 0.05).tolist(), duration=1.0)
    assert planned.success, planned.message
    probe.clear()
    sent = probe.follow.send_goal_async(probe.Goal(trajectory=planned.trajectory))
    assert probe.spin_until(sent.done)
    handle = sent.result()
    assert handle.accepted
    assert probe.spin_until(lambda: probe.count() >= 1)  # streaming, waiting for states
    before = _cpu_seconds(planner.process.pid)
    probe.spin_until(lambda: False, timeout=2.0)
    used = _cpu_seconds(planner.process.pid) - before
    assert used < 0.5, f'the planner used {used:.2f} s of CPU in 2 s while it waited'
    cancelling = handle.cancel_goal_async()
    assert probe.spin_until(cancelling.done)
    result = handle.get_result_async()
    assert probe.spin_until(result.done)
    probe.clear()


def test_stop_trajectory_ends_a_stream_started_by_the_service(graph, context, stance):
    from std_srvs.srv import Trigger

    probe, _ = graph
    period = int(round(1e9 / context.robot.timing.control_rate))
    stop = probe.node.create_client(Trigger, '/walker/stop_trajectory')
    assert stop.wait_for_service(timeout_sec=WAIT)
    settle(probe, stance)
    probe.clear()
    started = probe.call(trajectory_type='joint_parabolic_time', base_gripper='a',
                         start=stance.tolist(), goal=(stance + 0.05).tolist(), duration=1.0,
                         execute=True)
    assert started.success, started.message
    assert probe.spin_until(lambda: probe.count() >= probe.lookahead)  # sent at once
    for _ in range(3):
        probe.step(stance, period)
    count = probe.count()
    answer = stop.call_async(Trigger.Request())
    assert probe.spin_until(answer.done) and answer.result().success
    assert probe.spin_until(lambda: probe.count() >= count + 1)  # the hold, sent at once
    holds = [probe.setpoints[name][-1] for name in probe.names]
    assert all(h.velocity == 0.0 and h.acceleration == 0.0 for h in holds)
    # the plan no longer advances: with the controllers holding, nothing more comes
    count = probe.count()
    probe.now += period
    probe.publish_state(stance)
    probe.spin_until(lambda: probe.count() > count, timeout=0.5)
    assert probe.count() == count
    answer = stop.call_async(Trigger.Request())
    assert probe.spin_until(answer.done) and not answer.result().success
    probe.clear()


def test_goals_that_cannot_be_streamed_are_aborted_with_the_reason(graph, stance):
    probe, _ = graph
    settle(probe, stance)
    planned = probe.call(trajectory_type='joint_parabolic_time', base_gripper='a',
                         start=(stance + 0.3).tolist(), goal=(stance + 0.35).tolist(),
                         duration=1.0)
    assert planned.success, planned.message
    broken = planned.trajectory
    cases = [(planned.trajectory, 'away from the measured')]
    from trajectory_msgs.msg import JointTrajectory
    nan = JointTrajectory(joint_names=broken.joint_names,
                          points=copy.deepcopy(list(broken.points[:3])))
    nan.points[1].positions = [math.nan] * 5
    cases.append((nan, 'finite'))
    cases.append((JointTrajectory(joint_names=broken.joint_names[:4],
                                  points=list(broken.points[:2])), 'five joints'))
    for trajectory, words in cases:
        sent = probe.follow.send_goal_async(probe.Goal(trajectory=trajectory))
        assert probe.spin_until(sent.done) and sent.result().accepted
        result = sent.result().get_result_async()
        assert probe.spin_until(result.done)
        from action_msgs.msg import GoalStatus
        assert result.result().status == GoalStatus.STATUS_ABORTED
        assert words in result.result().result.message


def test_joint_states_silent_while_the_clock_runs_are_subscribed_anew_and_followed(
        graph, context, stance):
    """A subscription that stopped receiving while the plant runs on heals itself.

    Seen in sim-time walks with the loop in one process: the stream heard no joint state again
    while the plant's clock ran on, and the motion it streamed stood still for good.
    """
    probe, planner = graph
    period = int(round(1e9 / context.robot.timing.control_rate))
    settle(probe, stance)
    before = planner.output.count('subscription made anew')
    deadline = time.monotonic() + WAIT
    while planner.output.count('subscription made anew') == before \
            and time.monotonic() < deadline:  # the clock runs on, no joint state comes
        probe.now += period
        probe.publish_clock()
        probe.spin_until(lambda: False, timeout=0.02)
    assert planner.output.count('subscription made anew') == before + 1, planner.output
    assert 'joint_states: silent for' in planner.output
    assert probe.spin_until(lambda: [
        info.node_name for info in probe.node.get_subscriptions_info_by_topic(
            '/walker/joint_states')] == ['_planner_stream'])
    # the new subscription is heard: tracking with no stream, each state is answered
    _assert_held_while_tracking(probe, stance, period)
    assert planner.output.count('subscription made anew') == before + 1, planner.output


def test_invalid_parameter_updates_are_refused(graph):
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import SetParameters

    probe, _ = graph
    client = probe.node.create_client(SetParameters, '/walker/planner/set_parameters')
    assert client.wait_for_service(timeout_sec=WAIT)

    def set_value(name, value):
        request = SetParameters.Request(parameters=[Parameter(
            name=name, value=ParameterValue(type=ParameterType.PARAMETER_DOUBLE,
                                            double_value=value))])
        future = client.call_async(request)
        assert probe.spin_until(future.done)
        return future.result().results[0]

    refused = set_value('planner.joint.max_acceleration', 4.0)  # above acceleration_limit
    assert not refused.successful and 'acceleration_limit' in refused.reason
    assert not set_value('robot.geometry.l2', 0.7).successful  # read-only geometry
    assert set_value('planner.cartesian.fine_speed', 0.02).successful
    with contextlib.suppress(Exception):
        probe.node.destroy_client(client)


def test_the_node_refuses_to_start_with_invalid_parameters():
    with isolated_domain() as domain:
        args = [str(NODE), '--ros-args', '-r', '__ns:=/walker', '-p',
                'planner.joint.max_acceleration:=9.0']
        with NodeProcess(args, ros_environment(domain), 'planner') as planner:
            assert planner.process.wait(timeout=WAIT) == 2  # node_main.EXIT_REFUSED
            assert 'must not exceed planner.joint.acceleration_limit' in planner.output
            assert 'refusing to start' in planner.output and 'Traceback' not in planner.output
