"""The planner's whole trajectories followed by a real controller, lock-stepped in sim time.

Two node processes in a ROS domain of their own: the planner with
``planner.send_whole_trajectories`` and the controller of ``b_pitch_joint`` (role J4 with
gripper a as base: no acceleration feedback to stand in for). The test is the plant and the
supervisor: it publishes ``/clock`` and the joint states, waits for the effort that answers
each state, commands FINE, and asks the planner to follow trajectories. The controller must use,
at every state, the planner's plan sampled at that state's own time (the trajectory sent once,
no setpoint on the wire), hold the plan's end after it, and after a cancel hold where the plan
was when it was cancelled. No timing is asserted: waits only bound a hang.
"""

import numpy as np
import pytest

from ros_test_support import REPO_ROOT, NodeProcess, isolated_domain, ros_environment

pytestmark = pytest.mark.integration

JOINT = 'b_pitch_joint'
PLANNER = REPO_ROOT / 'ros2_ws' / 'install' / 'walker_planner' / 'lib' / 'walker_planner' / \
    'planner_node'
CONTROLLER = REPO_ROOT / 'ros2_ws' / 'install' / 'walker_control' / 'lib' / 'walker_control' / \
    'joint_controller_node'
START_NS = 10 * 1_000_000_000
WAIT = 20.0  # [s] of wall time for anything to arrive before the test fails
RESEND = 0.5  # [s] of wall time after which a state not answered is sent again
DISCOVERY = 2.0  # [s] of wall time for the planner to match a reader the probe sees


class Loop:
    """The test's side: the plant's clock and states, the supervisor's mode and goals."""

    def __init__(self, domain: int, names, period: int) -> None:
        import rclpy
        from rclpy.action import ActionClient
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor
        from walker_runtime.spinning import helper_node
        from rosgraph_msgs.msg import Clock
        from sensor_msgs.msg import JointState
        from trajectory_msgs.msg import JointTrajectory
        from walker_msgs.action import FollowTrajectory
        from walker_msgs.msg import ControllerState, ControlMode, JointCommand
        from walker_msgs.srv import PlanTrajectory
        from walker_runtime.qos import CLOCK_QOS, COMMAND_QOS, MODE_QOS, SENSOR_QOS

        self.names, self.period = list(names), period
        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain)
        # a tool, not part of the graph: hidden and serving nothing, so a later test's node
        # list in a domain this one used shows no trace of it
        self.node = helper_node('loop_probe', '/walker', self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.clock = self.node.create_publisher(Clock, '/clock', CLOCK_QOS)
        self.states = self.node.create_publisher(JointState, 'joint_states', SENSOR_QOS)
        self.mode = self.node.create_publisher(ControlMode, 'control_mode', MODE_QOS)
        self.planner = self.node.create_client(PlanTrajectory, 'plan_trajectory')
        self.follow = ActionClient(self.node, FollowTrajectory, 'follow_trajectory')
        self.efforts, self.reports, self.trajectories, self.setpoints = {}, {}, [], []
        self.node.create_subscription(
            JointState, 'effort_commands',
            lambda m: self.efforts.__setitem__(_ns(m.header.stamp), m), COMMAND_QOS)
        self.node.create_subscription(
            ControllerState, f'controllers/{JOINT}/state',
            lambda m: self.reports.__setitem__(_ns(m.header.stamp), m), COMMAND_QOS)
        self.node.create_subscription(JointTrajectory, 'controllers/joint_trajectory',
                                      self.trajectories.append, COMMAND_QOS)
        self.node.create_subscription(JointCommand, f'controllers/{JOINT}/setpoint',
                                      self.setpoints.append, COMMAND_QOS)
        self.now = START_NS
        self.Clock, self.JointState, self.ControlMode = Clock, JointState, ControlMode
        self.Request, self.Goal = PlanTrajectory.Request, FollowTrajectory.Goal

    def close(self) -> None:
        import rclpy
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)

    def spin_until(self, done, timeout: float = WAIT) -> bool:
        import time
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if done():
                return True
            self.executor.spin_once(timeout_sec=0.01)
        return done()

    def step(self, positions) -> None:
        """Publish the clock and the state at ``now`` and wait for the effort that answers it."""
        message = self.Clock()
        message.clock.sec, message.clock.nanosec = divmod(self.now, 1_000_000_000)
        self.clock.publish(message)
        state = self.JointState(name=self.names, position=[float(x) for x in positions],
                                velocity=[0.0] * 5, effort=[0.0] * 5)
        state.header.stamp = message.clock
        stamp = self.now
        for _ in range(int(WAIT / RESEND)):  # best effort, as the plant's: sent again if lost
            self.states.publish(state)
            if self.spin_until(lambda: stamp in self.efforts and stamp in self.reports,
                               RESEND):
                break
        assert stamp in self.efforts and stamp in self.reports, \
            f'no effort for the state at {stamp} ns'
        self.now += self.period

    def setpoint(self, stamp: int) -> float:
        """Return the position setpoint [rad] the controller used for the state at ``stamp``."""
        return self.reports[stamp].position_setpoint


def _ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


@pytest.fixture(scope='module')
def loop(context):
    from walker_core.joint_roles import PHYSICAL_JOINT_NAMES

    period = int(round(1e9 / context.robot.timing.control_rate))
    with isolated_domain() as domain:
        env = ros_environment(domain)
        common = ['--ros-args', '-r', '__ns:=/walker', '-p', 'use_sim_time:=true']
        with NodeProcess([str(PLANNER), *common, '-p', 'planner.send_whole_trajectories:=true'],
                         env, 'planner') as planner, \
                NodeProcess([str(CONTROLLER), *common, '-p', f'joint_name:={JOINT}',
                             '-p', 'control.state_rate:=500.0',
                             '-p', 'control.setpoint_timeout:=30.0',
                             '-p', 'control.state_timeout:=30.0'], env, 'controller') \
                as controller:
            probe = Loop(domain, PHYSICAL_JOINT_NAMES, period)
            try:
                assert planner.wait_for_output('planner ready', WAIT), planner.output
                assert probe.planner.wait_for_service(timeout_sec=WAIT), planner.output
                assert probe.follow.wait_for_server(timeout_sec=WAIT), planner.output
                assert controller.wait_for_output(JOINT, WAIT), controller.output
                assert probe.spin_until(lambda: probe.states.get_subscription_count() >= 2
                                        and probe.mode.get_subscription_count() >= 2)
                # the trajectory topic's reader in the graph, then time for the planner's
                # participant to match it too: a reader matched late misses a trajectory
                assert probe.spin_until(lambda: probe.node.count_subscribers(
                    '/walker/controllers/joint_trajectory') >= 2)
                probe.spin_until(lambda: False, timeout=DISCOVERY)
                probe.logs = lambda: f'{planner.output[-3000:]}\n{controller.output[-3000:]}'
                yield probe
            finally:
                probe.close()
            assert controller.process.poll() is None, controller.output


@pytest.fixture(scope='module')
def context():
    from walker_core.robot_parameters import load_walker_parameters
    from walker_planner.core.parameters import PREFIX, PlannerParameters
    from walker_planner.core.planning import PlanningContext
    from walker_core.parameter_schema import load_parameter_file, section_from_flat
    from walker_core.robot_parameters import default_parameter_file

    planner = section_from_flat(PlannerParameters, load_parameter_file(default_parameter_file()),
                                PREFIX)
    return PlanningContext.from_parameters(load_walker_parameters(), planner)


def _follow(loop, start, delta, duration):
    """Plan a minimum-jerk move and send it as a goal; return the handle, plan and message."""
    from walker_planner.conversions import sampled_trajectory

    answer = loop.planner.call_async(loop.Request(
        trajectory_type='joint_min_jerk', base_gripper='a', start=list(start),
        goal=list(np.asarray(start) + delta), duration=duration))
    assert loop.spin_until(answer.done) and answer.result().success, answer.result()
    count = len(loop.trajectories)
    sent = loop.follow.send_goal_async(loop.Goal(trajectory=answer.result().trajectory))
    assert loop.spin_until(sent.done) and sent.result().accepted
    assert loop.spin_until(lambda: len(loop.trajectories) > count), 'no trajectory was sent'
    message = loop.trajectories[-1]
    # the plant steps on once the supervisor has the acceptance, a few hops after the
    # trajectory went out: the controller has it by then (nothing makes sure; one late would be
    # sampled at its own time from its arrival on)
    loop.spin_until(lambda: False, timeout=0.3)
    return sent.result(), sampled_trajectory(message), _ns(message.header.stamp)


def test_the_controller_follows_the_planners_trajectory_sent_once_and_a_cancel_holds(loop,
                                                                                      context):
    from action_msgs.msg import GoalStatus

    column = loop.names.index(JOINT)
    stance = context.kinematics.inverse([0.0, 0.9, 0.03, 0.0, 0.0])
    loop.step(stance)
    loop.mode.publish(loop.ControlMode(mode=loop.ControlMode.FINE, base_gripper='a',
                                       commander='/walker/supervisor'))
    for _ in range(100):
        loop.step(stance)
        if loop.reports[loop.now - loop.period].mode == loop.ControlMode.FINE:
            break
    assert loop.reports[loop.now - loop.period].mode == loop.ControlMode.FINE
    delta = np.zeros(5)
    delta[column] = 0.04
    handle, plan, origin = _follow(loop, stance, delta, 0.6)
    assert origin == loop.now  # one period after the newest state, the next one's stamp
    result = handle.get_result_async()
    stamps = []
    while not result.done():
        stamps.append(loop.now)
        loop.step(stance)  # the joints stay put: what is checked is the reference
        assert len(stamps) < 1000, 'the goal did not end'
    off = [(stamp - origin) // loop.period for stamp in stamps
           if abs(loop.setpoint(stamp) - plan.sample((stamp - origin) * 1e-9).position[column])
           > 1e-9]
    assert off == [], f'periods of the plan whose setpoint was not the plan: {off}\n' \
        f'{[(k, loop.setpoint(origin + k * loop.period)) for k in off[:3]]}\n{loop.logs()}'
    assert result.result().status == GoalStatus.STATUS_SUCCEEDED
    assert stamps[-1] >= origin + round(plan.duration * 1e9) - 2 * loop.period
    for _ in range(10):  # after the end its last point is held
        loop.step(stance)
        assert loop.setpoint(loop.now - loop.period) == pytest.approx(
            plan.positions[-1][column], abs=1e-12)
    assert len(loop.trajectories) == 1 and loop.setpoints == []

    # a cancel in the middle: the controller follows the plan up to the hold, then holds where
    # the plan was a period before it, at rest
    start = plan.positions[-1]
    handle, plan, origin = _follow(loop, start, -delta, 0.6)
    for _ in range(100):
        loop.step(start)
    cancelled_at = loop.now - loop.period  # the newest state and clock
    loop.spin_until(lambda: False, timeout=0.3)  # the planner has taken them
    cancelling = handle.cancel_goal_async()
    assert loop.spin_until(cancelling.done)
    result = handle.get_result_async()
    assert loop.spin_until(result.done)
    assert result.result().status == GoalStatus.STATUS_CANCELED
    assert loop.spin_until(lambda: len(loop.trajectories) == 3), 'no hold was sent'
    hold = loop.trajectories[-1]
    hold_at = _ns(hold.header.stamp)
    # from the next state on, at most the stream's lookahead (10 periods at most) later
    assert cancelled_at < hold_at <= cancelled_at + 11 * loop.period
    assert (hold_at - origin) % loop.period == 0 and len(hold.points) == 1
    where = plan.sample((hold_at - loop.period - origin) * 1e-9).position[column]
    assert abs(where - start[column]) > 1e-3  # under way
    assert hold.points[0].positions[column] == pytest.approx(where, abs=1e-12)
    while loop.now <= hold_at + 5 * loop.period:
        stamp = loop.now
        loop.step(start)
        expected = where if stamp >= hold_at else \
            plan.sample((stamp - origin) * 1e-9).position[column]
        assert loop.setpoint(stamp) == pytest.approx(expected, abs=1e-9), (stamp - hold_at)
    assert loop.reports[loop.now - loop.period].velocity_setpoint == 0.0
    assert loop.setpoints == []
