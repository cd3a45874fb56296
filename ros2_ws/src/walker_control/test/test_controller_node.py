"""A real joint controller process over Fast DDS, driven by a stand-in plant in the test.

The stand-in publishes joint accelerations and joint states, as the plant does, and waits for
the effort that answers each state (the sim-time lock-step). Each test runs in a ROS domain of
its own with discovery on loopback. No timing is asserted: waits are generous and only bound a
hang.
"""

import math
import time

import pytest

pytestmark = pytest.mark.integration

JOINT = 'a_yaw_joint'
NODE = 'controller_a_yaw'
STANCE = [0.0, 0.85, 1.45, 0.85, 0.0]
PERIOD_NS = 2_000_000
WAIT = 20.0


def controller_executable():
    from ament_index_python.packages import get_package_prefix

    return f'{get_package_prefix("walker_control")}/lib/walker_control/joint_controller_node'


# Timeouts long enough that a loaded machine never trips them, unless a test wants it to.
RELAXED = ('-p', 'control.setpoint_timeout:=30.0', '-p', 'control.state_timeout:=30.0')
STRICT = ('-p', 'control.setpoint_timeout:=1.0', '-p', 'control.state_timeout:=1.0')


# A controller state for every period, so that every step of the stand-in can check one.
EVERY_STATE = ('-p', 'control.state_rate:=500.0')


def start_controller(ros_env, *extra, timeouts=RELAXED, state_rate=EVERY_STATE):
    from ros_test_support import NodeProcess

    return NodeProcess([controller_executable(), '--ros-args', '-r', '__ns:=/walker',
                        '-p', f'joint_name:={JOINT}', *timeouts, *state_rate, *extra],
                       ros_env, NODE)


class StandInPlant:
    """Publishes states, collects efforts and controller states, in the test process."""

    def __init__(self, context):
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node
        from sensor_msgs.msg import JointState
        from walker_control.joint_controller_node import COMMAND_QOS, MODE_QOS, STATE_QOS
        from walker_msgs.msg import ControllerState, ControlMode, JointAccelerations, JointCommand

        self.node = Node('stand_in_plant', namespace='/walker', context=context)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.state_pub = self.node.create_publisher(JointState, 'joint_states', STATE_QOS)
        self.accel_pub = self.node.create_publisher(JointAccelerations, 'joint_accelerations',
                                                    STATE_QOS)
        self.mode_pub = self.node.create_publisher(ControlMode, 'control_mode', MODE_QOS)
        self.setpoint_pub = self.node.create_publisher(
            JointCommand, f'controllers/{JOINT}/setpoint', COMMAND_QOS)
        self.efforts = []
        self.states = []
        self.node.create_subscription(JointState, 'effort_commands', self.efforts.append,
                                      COMMAND_QOS)
        self.node.create_subscription(ControllerState, f'controllers/{JOINT}/state',
                                      self.states.append, COMMAND_QOS)
        self.stamp_ns = 1_000_000_000
        self.position = list(STANCE)
        self.clock_pub = None

    def close(self):
        self.executor.shutdown()
        self.node.destroy_node()

    def spin_until(self, predicate, timeout=WAIT):
        from ros_test_support import spin_executor_until

        return spin_executor_until(self.executor, predicate, timeout)

    def _stamp(self, msg, stamp_ns):
        from ros_test_support import set_stamp

        set_stamp(msg, stamp_ns)

    def publish_state(self, acceleration=0.0):
        from sensor_msgs.msg import JointState
        from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
        from walker_msgs.msg import JointAccelerations

        accel = JointAccelerations(name=list(PHYSICAL_JOINT_NAMES),
                                   acceleration=[acceleration] * 5)
        self._stamp(accel, self.stamp_ns)
        self.accel_pub.publish(accel)
        state = JointState(name=list(PHYSICAL_JOINT_NAMES), position=list(self.position),
                           velocity=[0.0] * 5, effort=[0.0] * 5)
        self._stamp(state, self.stamp_ns)
        self.state_pub.publish(state)

    def answered(self, stamp_ns):
        return any(e.header.stamp.sec * 1_000_000_000 + e.header.stamp.nanosec == stamp_ns
                   for e in self.efforts[-5:])

    def step(self, acceleration=0.0):
        """Advance one period; publish the state until its effort comes back."""
        self.stamp_ns += PERIOD_NS
        for _ in range(int(WAIT / 0.05)):
            self.publish_state(acceleration)  # again if lost: best effort, as the plant does
            if self.spin_until(lambda: self.answered(self.stamp_ns), timeout=0.05):
                self.spin_until(lambda: self.state_for(self.stamp_ns) is not None, 1.0)
                return self.efforts[-1]
        raise AssertionError(f'no effort for the state stamped {self.stamp_ns} ns')

    def state_for(self, stamp_ns):
        for state in reversed(self.states):
            if state.header.stamp.sec * 1_000_000_000 + state.header.stamp.nanosec == stamp_ns:
                return state
        return None

    def publish_clock(self, stamp_ns):
        """Publish the simulated clock at ``stamp_ns`` on ``/clock``, as the plant does."""
        from rosgraph_msgs.msg import Clock

        if self.clock_pub is None:
            from rclpy.qos import qos_profile_system_default
            self.clock_pub = self.node.create_publisher(Clock, '/clock',
                                                        qos_profile_system_default)
        msg = Clock()
        msg.clock.sec, msg.clock.nanosec = divmod(stamp_ns, 1_000_000_000)
        self.clock_pub.publish(msg)

    def command(self, mode, base='a'):
        from walker_msgs.msg import ControlMode

        self.mode_pub.publish(ControlMode(mode=mode, base_gripper=base,
                                          commander='/walker/supervisor'))

    def setpoint(self, stamp_ns, position, velocity=0.0):
        from walker_msgs.msg import JointCommand

        msg = JointCommand(joint_name=JOINT, position=position, velocity=velocity)
        self._stamp(msg, stamp_ns)
        self.setpoint_pub.publish(msg)

    def step_until(self, predicate, steps=2000, setpoints=None):
        """Step until ``predicate(controller_state)`` holds for the state just answered.

        ``setpoints(stamp_ns)`` gives the setpoint position for a stamp; each is published a
        period ahead of its state, as the planner streams them.
        """
        if setpoints is not None:
            self.setpoint(self.stamp_ns + PERIOD_NS, setpoints(self.stamp_ns + PERIOD_NS))
        for _ in range(steps):
            if setpoints is not None:
                ahead = self.stamp_ns + 2 * PERIOD_NS
                self.setpoint(ahead, setpoints(ahead))
            self.step()
            state = self.state_for(self.stamp_ns)
            if state is not None and predicate(state):
                return state
        raise AssertionError(f'condition not reached; last state: {self.states[-1:]}')


@pytest.fixture
def plant(rclpy_context):
    stand_in = StandInPlant(rclpy_context)
    yield stand_in
    stand_in.close()


def test_an_effort_answers_every_state_with_its_stamp_and_name(ros_env, plant):
    from walker_msgs.msg import ControllerState

    with start_controller(ros_env) as controller:
        plant.step()  # waits for discovery
        # the discovery step's state may have gone out more than once, and a copy's answer may
        # come in after this count: it names that step's stamp, not one of the 100 below
        discovery = plant.stamp_ns
        first = len(plant.efforts)
        for _ in range(100):
            effort = plant.step()
            stamp = effort.header.stamp.sec * 1_000_000_000 + effort.header.stamp.nanosec
            assert stamp == plant.stamp_ns
            assert list(effort.name) == [JOINT] and len(effort.effort) == 1
            assert math.isfinite(effort.effort[0])
        stamps = {e.header.stamp.sec * 1_000_000_000 + e.header.stamp.nanosec
                  for e in plant.efforts[first:]} - {discovery}
        assert stamps == {discovery + k * PERIOD_NS for k in range(1, 101)}
        state = plant.state_for(plant.stamp_ns)
        assert state.mode == ControllerState.HOLD and state.role == 1 and not state.stale
        assert state.position_setpoint == STANCE[0]  # holds the measured position
        assert controller.process.poll() is None, controller.output


def test_modes_setpoints_and_the_role_follow_control_mode(ros_env, plant):
    from walker_msgs.msg import ControlMode

    with start_controller(ros_env) as controller:
        plant.step()
        plant.command(ControlMode.COARSE, 'a')

        def ramp(stamp_ns):
            return 0.1 + 1e-4 * (stamp_ns // PERIOD_NS % 1000)
        state = plant.step_until(lambda s: s.mode == ControlMode.COARSE, setpoints=ramp)
        # The setpoint in force is the one stamped for this state (streamed a period ahead).
        state = plant.step_until(lambda s: s.position_setpoint != STANCE[0], setpoints=ramp)
        assert state.position_setpoint == pytest.approx(ramp(plant.stamp_ns), abs=1e-12)
        assert state.acceleration_feedback_effort == 0.0  # measured acceleration is zero
        plant.command(ControlMode.HOLD, 'b')  # base swap while holding: a_yaw plays J5
        state = plant.step_until(lambda s: s.role == 5)
        assert state.mode == ControlMode.HOLD
        plant.command(ControlMode.COARSE, 'b')
        plant.step_until(lambda s: s.mode == ControlMode.COARSE)
        plant.command(ControlMode.COARSE, 'a')  # base swap while moving: refused, holds
        state = plant.step_until(lambda s: s.mode == ControlMode.HOLD)
        assert state.role == 5
        assert controller.wait_for_output('only while holding', WAIT), controller.output


@pytest.mark.parametrize('position, velocity, words', [
    (math.nan, 0.0, 'finite'),
    (10.0, 0.0, 'joint limits'),
    (0.1, math.inf, 'finite'),
])
def test_bad_setpoints_are_refused_and_the_joint_holds(ros_env, plant, position, velocity,
                                                      words):
    from walker_msgs.msg import ControlMode

    with start_controller(ros_env) as controller:
        plant.step()
        plant.command(ControlMode.FINE, 'a')
        plant.step_until(lambda s: s.mode == ControlMode.FINE)
        plant.setpoint(plant.stamp_ns + PERIOD_NS, position, velocity)
        state = plant.step_until(lambda s: s.mode == ControlMode.HOLD)
        assert math.isfinite(state.effort) and math.isfinite(state.position_setpoint)
        assert state.position_setpoint == pytest.approx(STANCE[0])
        assert controller.wait_for_output('refused', WAIT), controller.output
        assert words in controller.output


def test_a_stopped_setpoint_stream_makes_the_joint_hold_and_report_it(ros_env, plant):
    from walker_msgs.msg import ControlMode

    with start_controller(ros_env, timeouts=STRICT) as controller:
        plant.step()
        plant.command(ControlMode.COARSE, 'a')
        plant.step_until(lambda s: s.mode == ControlMode.COARSE)
        for _ in range(20):
            plant.setpoint(plant.stamp_ns + PERIOD_NS, 0.01)
            plant.step()
        state = plant.step_until(lambda s: s.mode == ControlMode.HOLD)  # no more setpoints
        assert state.stale
        assert state.position_setpoint == pytest.approx(STANCE[0])  # where the joint was
        assert controller.wait_for_output('stale', WAIT), controller.output


def start_paced_stream(plant, position, states=10):
    """COARSE, then ``states`` states each with its setpoint sent a period ahead (the planner)."""
    from walker_msgs.msg import ControlMode

    plant.step()
    plant.command(ControlMode.COARSE, 'a')
    plant.step_until(lambda s: s.mode == ControlMode.COARSE)
    for _ in range(states):
        plant.setpoint(plant.stamp_ns + PERIOD_NS, position)
        plant.step()
    assert plant.state_for(plant.stamp_ns).position_setpoint == pytest.approx(position)


def publish_late_state(plant):
    """Publish the next state without the setpoint its stream owes it; say if it is answered."""
    plant.stamp_ns += PERIOD_NS
    plant.publish_state()
    return plant.spin_until(lambda: plant.answered(plant.stamp_ns), timeout=1.0)


@pytest.mark.parametrize('sim_time', [True, False], ids=['sim time', 'real time'])
def test_a_state_waits_for_the_setpoint_its_stream_owes_it_in_sim_time_only(ros_env, plant,
                                                                           sim_time):
    with start_controller(ros_env, '-p', f'use_sim_time:={str(sim_time).lower()}',
                          '-p', 'control.sim_time_setpoint_wait:=10.0') as controller:
        start_paced_stream(plant, 0.01)
        answered = publish_late_state(plant)
        if sim_time:
            # lock-stepped: the plant waits for the effort, the effort for the setpoint
            assert not answered, 'a sim-time state was answered without its setpoint'
            plant.setpoint(plant.stamp_ns, 0.02)
            assert plant.spin_until(lambda: plant.answered(plant.stamp_ns))
            plant.spin_until(lambda: plant.state_for(plant.stamp_ns) is not None)
            assert plant.state_for(plant.stamp_ns).position_setpoint == pytest.approx(0.02)
        else:
            # like hardware: never wait; the older setpoint (at rest) is carried on
            assert answered, 'a real-time state waited for its setpoint'
            plant.spin_until(lambda: plant.state_for(plant.stamp_ns) is not None)
            assert plant.state_for(plant.stamp_ns).position_setpoint == pytest.approx(0.01)
        assert controller.process.poll() is None, controller.output


def test_a_state_waits_no_longer_than_its_bound_and_a_dead_stream_only_once(ros_env, plant):
    with start_controller(ros_env, '-p', 'use_sim_time:=true',
                          '-p', 'control.sim_time_setpoint_wait:=0.3') as controller:
        start_paced_stream(plant, 0.01)
        plant.stamp_ns += PERIOD_NS
        plant.publish_state()
        assert plant.spin_until(lambda: plant.answered(plant.stamp_ns))  # after the bound
        assert controller.wait_for_output('answered without it', WAIT), controller.output
        # the stream is no longer paced: the next states are answered at once, from the last
        # setpoint, until the setpoint timeout makes the joint hold
        for _ in range(3):
            assert publish_late_state(plant), 'a state waited again for a stream that stopped'
        assert plant.spin_until(lambda: plant.state_for(plant.stamp_ns) is not None)
        assert plant.state_for(plant.stamp_ns).position_setpoint == pytest.approx(0.01)


def test_a_setpoint_sent_ahead_survives_the_switch_from_coarse_to_fine(ros_env, plant):
    """The supervisor switches to FINE while the stream goes on: no period without it."""
    from walker_msgs.msg import ControlMode

    with start_controller(ros_env) as controller:
        start_paced_stream(plant, 0.1)
        plant.setpoint(plant.stamp_ns + PERIOD_NS, 0.1)  # the next state's, sent ahead
        plant.command(ControlMode.FINE, 'a')
        assert controller.wait_for_output('mode FINE', WAIT), controller.output
        plant.step()  # the first state in FINE: its setpoint came before the mode
        state = plant.state_for(plant.stamp_ns)
        assert state.mode == ControlMode.FINE
        assert state.position_setpoint == pytest.approx(0.1)  # not the measured 0.0, held
        assert not state.stale


def test_a_new_tracking_mode_after_a_stale_hold_reports_fresh_inputs_at_once(ros_env, plant):
    from walker_msgs.msg import ControlMode

    with start_controller(ros_env, timeouts=STRICT):
        plant.step()
        plant.command(ControlMode.COARSE, 'a')
        plant.step_until(lambda s: s.mode == ControlMode.COARSE)
        plant.setpoint(plant.stamp_ns + PERIOD_NS, 0.01)
        plant.step()
        assert plant.step_until(lambda s: s.mode == ControlMode.HOLD).stale
        plant.command(ControlMode.HOLD, 'a')  # the supervisor's hold, then its resume
        plant.step_until(lambda s: s.mode == ControlMode.HOLD, steps=1)
        plant.command(ControlMode.FINE, 'a')
        state = plant.step_until(lambda s: s.mode == ControlMode.FINE)
        assert not state.stale, 'the first state in the new mode still reports stale inputs'


def test_a_stopped_state_stream_is_reported_stale(ros_env, plant):
    from walker_msgs.msg import ControlMode

    with start_controller(ros_env, timeouts=STRICT):
        plant.step()
        plant.command(ControlMode.COARSE, 'a')
        plant.step_until(lambda s: s.mode == ControlMode.COARSE)
        count = len(plant.states)
        # No more states: the controller's steady-clock watchdog reports on its own.
        assert plant.spin_until(lambda: any(s.stale and s.mode == ControlMode.HOLD
                                            for s in plant.states[count:]))


def test_in_sim_time_a_clock_held_still_owes_no_states_and_a_running_one_does(ros_env, plant):
    """The supervisor holds the simulated clock while it waits for an answer: no stale hold.

    A controller that took that silence for a dead plant held, and stayed holding until the
    next mode command: the step then stood still. Once the clock runs on without states, the
    silence is stale as on the wall clock.
    """
    with start_controller(ros_env, '-p', 'use_sim_time:=true', timeouts=STRICT) as controller:
        for _ in range(5):
            plant.publish_clock(plant.stamp_ns + PERIOD_NS)
            plant.step()
        held = time.monotonic()
        while time.monotonic() - held < 3.0:  # three state timeouts, the clock held still
            plant.publish_clock(plant.stamp_ns)
            plant.spin_until(lambda: False, timeout=0.1)
        assert 'input stale' not in controller.output, controller.output
        running = plant.stamp_ns
        deadline = time.monotonic() + WAIT
        while 'no joint state' not in controller.output and time.monotonic() < deadline:
            running += PERIOD_NS  # the clock runs, no state comes
            plant.publish_clock(running)
            plant.spin_until(lambda: False, timeout=0.05)
        assert 'input stale: no joint state' in controller.output, controller.output


def _subscriptions_of_controller(plant, topic):
    return [info for info in plant.node.get_subscriptions_info_by_topic(topic)
            if info.node_name == NODE]


def test_a_state_stream_silent_for_long_is_subscribed_anew_and_followed_again(ros_env, plant):
    """A subscription that stopped receiving (a restarted plant not matched) heals itself."""
    from walker_msgs.msg import ControlMode

    with start_controller(ros_env, timeouts=STRICT) as controller:
        plant.step()
        plant.command(ControlMode.COARSE, 'a')
        plant.step_until(lambda s: s.mode == ControlMode.COARSE)
        # two state timeouts of silence: the subscription is made anew, once per interval
        assert controller.wait_for_output('joint_states: silent for', WAIT), controller.output
        assert plant.spin_until(
            lambda: len(_subscriptions_of_controller(plant, '/walker/joint_states')) == 1)
        # the new subscription is answered, and the controller reports fresh inputs again
        count = len(plant.states)
        plant.step()
        plant.command(ControlMode.FINE, 'a')
        state = plant.step_until(lambda s: s.mode == ControlMode.FINE)
        assert not state.stale and len(plant.states) > count


def test_a_setpoint_stream_silent_for_long_is_subscribed_anew_and_followed_again(ros_env,
                                                                                  plant):
    from walker_msgs.msg import ControlMode

    with start_controller(ros_env, timeouts=STRICT) as controller:
        plant.step()
        plant.command(ControlMode.COARSE, 'a')
        plant.step_until(lambda s: s.mode == ControlMode.COARSE)
        plant.setpoint(plant.stamp_ns + PERIOD_NS, 0.01)
        plant.step()
        deadline = time.monotonic() + WAIT  # states go on, setpoints do not
        while 'subscription made anew' not in controller.output \
                and time.monotonic() < deadline:
            plant.step()
        assert 'subscription made anew' in controller.output, controller.output
        assert plant.spin_until(lambda: len(_subscriptions_of_controller(
            plant, f'/walker/controllers/{JOINT}/setpoint')) == 1)
        # the stream resumes on the new subscription and is tracked after a mode command
        plant.command(ControlMode.COARSE, 'a')
        target = STANCE[0] + 0.002
        state = plant.step_until(
            lambda s: s.mode == ControlMode.COARSE and not s.stale
            and s.position_setpoint == pytest.approx(target, abs=1e-5),
            setpoints=lambda stamp_ns: target)
        assert state.position_setpoint == pytest.approx(target, abs=1e-5)


def _parameter_call(plant, service_type, name, request):
    client = plant.node.create_client(service_type, f'/walker/{NODE}/{name}')
    assert plant.spin_until(lambda: client.service_is_ready())
    future = client.call_async(request)
    assert plant.spin_until(future.done)
    plant.node.destroy_client(client)
    return future.result()


def test_an_unstable_parameter_update_is_refused_and_changes_nothing(ros_env, plant):
    from rcl_interfaces.srv import GetParameters, SetParameters
    from rclpy.parameter import Parameter

    name = 'control.fine.bandwidth'
    with start_controller(ros_env):
        plant.step()

        def get():
            response = _parameter_call(plant, GetParameters, 'get_parameters',
                                       GetParameters.Request(names=[name]))
            return list(response.values[0].double_array_value)

        before = get()
        unstable = Parameter(name, value=[5.0, 5.0, 5.0, 8.0, 8.0]).to_parameter_msg()
        result = _parameter_call(plant, SetParameters, 'set_parameters',
                                 SetParameters.Request(parameters=[unstable])).results[0]
        assert not result.successful
        assert 'J1' in result.reason and 'unstable' in result.reason
        assert get() == before
        stable = Parameter(name, value=[0.6, 5.0, 5.0, 8.0, 8.0]).to_parameter_msg()
        result = _parameter_call(plant, SetParameters, 'set_parameters',
                                 SetParameters.Request(parameters=[stable])).results[0]
        assert result.successful, result.reason
        assert get() == [0.6, 5.0, 5.0, 8.0, 8.0]
        plant.step()  # still controlling


def test_refuses_to_start_on_a_bad_joint_or_unstable_gains(ros_env, tmp_path):
    from ros_test_support import NodeProcess

    with NodeProcess([controller_executable(), '--ros-args', '-p', 'joint_name:=elbow'],
                     ros_env) as bad_joint:
        assert bad_joint.process.wait(timeout=WAIT) == 2
        assert 'elbow' in bad_joint.output and 'refusing to start' in bad_joint.output
    with NodeProcess([controller_executable(), '--ros-args', '-p', 'joint_name:=5'],
                     ros_env) as bad_type:
        assert bad_type.process.wait(timeout=WAIT) == 2
        assert 'joint_name refused' in bad_type.output and 'Traceback' not in bad_type.output
    params = tmp_path / 'unstable.yaml'
    params.write_text('/**:\n  ros__parameters:\n    control:\n      coarse:\n'
                      '        acceleration_feedback: [0.5, 0.0, 0.0, 1.5, 0.0]\n')
    with start_controller(ros_env, '--params-file', str(params)) as unstable:
        assert unstable.process.wait(timeout=WAIT) == 2
        assert 'J4' in unstable.output and 'unstable' in unstable.output


def test_controller_states_come_at_the_state_rate_and_efforts_every_period(ros_env, plant):
    with start_controller(ros_env, state_rate=('-p', 'control.state_rate:=100.0')):
        plant.step()
        first = len(plant.states)
        stamps = []
        for _ in range(20):
            stamps.append(plant.step().header.stamp)  # an effort for every state
        plant.spin_until(lambda: False, timeout=0.3)
        published = [s.header.stamp.sec * 1_000_000_000 + s.header.stamp.nanosec
                     for s in plant.states[first:]]
        assert len(stamps) == 20
        assert 3 <= len(published) <= 5, published  # 20 periods of 2 ms at 100 Hz
        assert all(b - a == 10_000_000 for a, b in zip(published, published[1:], strict=False))


@pytest.mark.parametrize('priority', [50, 0])
def test_the_controller_process_asks_for_its_real_time_priority(ros_env, priority):
    """On the wall clock the process runs under SCHED_FIFO at timing.realtime_priority.

    Where the machine refuses the privilege the node says so and keeps the default policy;
    at 0 (what a sim-time graph gives the controllers) it leaves the scheduling alone.
    """
    import os

    from ros_test_support import realtime_permitted, thread_policies

    with start_controller(ros_env, '-p', f'timing.realtime_priority:={priority}') as controller:
        assert controller.wait_for_output('controlling', WAIT), controller.output
        assert controller.wait_for_output('scheduling' if priority == 0 else 'SCHED_FIFO',
                                          WAIT), controller.output
        policies = thread_policies(controller.process.pid)
        if priority and realtime_permitted():
            assert policies == {(os.SCHED_FIFO, 50)}, (policies, controller.output)
            assert 'SCHED_FIFO priority 50 on' in controller.output
        else:
            assert policies == {(os.SCHED_OTHER, 0)}, (policies, controller.output)


def trajectory_message(start_ns, times, yaw_positions):
    """Return a whole-arm trajectory moving a_yaw_joint from ``start_ns``, the others still."""
    from builtin_interfaces.msg import Duration
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
    from walker_core.joint_roles import PHYSICAL_JOINT_NAMES

    msg = JointTrajectory(joint_names=list(PHYSICAL_JOINT_NAMES))
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(start_ns, 1_000_000_000)
    for t, position in zip(times, yaw_positions, strict=True):
        seconds, nanoseconds = divmod(int(round(t * 1e9)), 1_000_000_000)
        msg.points.append(JointTrajectoryPoint(
            positions=[position, *STANCE[1:]],
            time_from_start=Duration(sec=seconds, nanosec=nanoseconds)))
    return msg


def test_a_whole_trajectory_is_held_replaced_from_its_start_and_never_waited_for(ros_env,
                                                                                  plant):
    """joint_trajectory_controller's contract on the real node, lock-stepped in sim time.

    A trajectory sent late (its start already past) is sampled at its own time, as if it had
    come in time; a second one replaces it from its own start time, not from its arrival;
    with no message at all for longer than the setpoint timeout the joint keeps tracking,
    and no state waits for anything.
    """
    from rclpy.duration import Duration
    from trajectory_msgs.msg import JointTrajectory
    from walker_control.joint_controller_node import COMMAND_QOS
    from walker_msgs.msg import ControlMode

    publisher = plant.node.create_publisher(JointTrajectory, 'controllers/joint_trajectory',
                                            COMMAND_QOS)

    def send(msg):
        publisher.publish(msg)
        # acknowledged: in the controller's reader before the next state, which its
        # executor serves after the trajectory (creation order)
        assert publisher.wait_for_all_acked(Duration(seconds=WAIT))

    with start_controller(ros_env, '-p', 'use_sim_time:=true', timeouts=STRICT) as controller:
        plant.step()
        assert plant.spin_until(lambda: publisher.get_subscription_count() > 0)
        plant.command(ControlMode.COARSE, 'a')
        plant.step_until(lambda s: s.mode == ControlMode.COARSE)
        duration = 0.4  # [s] a_yaw_joint from 0 to 0.1 rad
        first = plant.stamp_ns - 20 * PERIOD_NS  # sent 20 periods late

        def ramp(stamp_ns):
            return 0.1 * min(1.0, max(0.0, (stamp_ns - first) * 1e-9 / duration))
        send(trajectory_message(first, (0.0, duration), (0.0, 0.1)))
        for _ in range(10):
            plant.step()
            state = plant.state_for(plant.stamp_ns)
            assert state.position_setpoint == pytest.approx(ramp(plant.stamp_ns), abs=1e-9)
        # replaced from 30 periods on: from where the first one is then to -0.05 rad in 25
        second = plant.stamp_ns + 30 * PERIOD_NS
        send(trajectory_message(second, (25 * PERIOD_NS * 1e-9,), (-0.05,)))
        for _ in range(29):
            plant.step()
            assert plant.state_for(plant.stamp_ns).position_setpoint == pytest.approx(
                ramp(plant.stamp_ns), abs=1e-9)
        plant.step()
        assert plant.stamp_ns == second
        assert plant.state_for(second).position_setpoint == pytest.approx(ramp(second), abs=1e-9)
        for _ in range(25):
            plant.step()
        assert plant.state_for(plant.stamp_ns).position_setpoint == pytest.approx(-0.05)
        # silent for longer than the setpoint timeout: still tracking, nothing stale, and a
        # state is answered at once (nothing is owed to it)
        time.sleep(1.5)
        assert publish_late_state(plant), 'a state waited although a trajectory is held'
        assert plant.spin_until(lambda: plant.state_for(plant.stamp_ns) is not None)
        state = plant.state_for(plant.stamp_ns)
        assert state.mode == ControlMode.COARSE and not state.stale
        assert state.position_setpoint == pytest.approx(-0.05)
        assert controller.process.poll() is None, controller.output
