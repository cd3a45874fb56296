"""The five joint controllers in one process (``joint_controllers_node``) over Fast DDS.

A stand-in plant in the test publishes the same joint states, accelerations, mode commands and
setpoints to two namespaces: ``/grouped``, where one ``joint_controllers_node`` drives the
joints, and ``/single``, where a ``joint_controller_node`` of its own drives the vertex joint.
What the user needs true: one effort message answers each state for all the node's joints,
each joint keeps its own state topic, and a joint's effort is exactly what its own controller
process would answer. Each test runs in a ROS domain of its own with discovery on loopback; no
timing is asserted.
"""

import math

import pytest

pytestmark = pytest.mark.integration

STANCE = [0.0, 0.85, 1.45, 0.85, 0.0]
PERIOD_NS = 2_000_000
WAIT = 20.0
OPTIONS = ('-p', 'control.setpoint_timeout:=30.0', '-p', 'control.state_timeout:=30.0',
           '-p', 'control.state_rate:=500.0')


def executable(name):
    from ament_index_python.packages import get_package_prefix

    return f'{get_package_prefix("walker_control")}/lib/walker_control/{name}'


def start_grouped(ros_env, *extra, namespace='/grouped'):
    from ros_test_support import NodeProcess

    return NodeProcess([executable('joint_controllers_node'), '--ros-args',
                        '-r', f'__ns:={namespace}', *OPTIONS, *extra], ros_env, 'controllers')


def start_single(ros_env, joint, namespace='/single'):
    from ros_test_support import NodeProcess

    return NodeProcess([executable('joint_controller_node'), '--ros-args',
                        '-r', f'__ns:={namespace}', '-p', f'joint_name:={joint}', *OPTIONS],
                       ros_env, 'single')


def _ns(stamp):
    return stamp.sec * 1_000_000_000 + stamp.nanosec


class StandIn:
    """Publishes the same inputs to several namespaces and collects their answers."""

    def __init__(self, context, namespaces):
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node
        from sensor_msgs.msg import JointState
        from walker_msgs.msg import (
            ControlMode, ControllerState, JointAccelerations, JointCommand)

        from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
        from walker_control.joint_controller_node import COMMAND_QOS, MODE_QOS, STATE_QOS

        self.node = Node('stand_in', context=context)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.namespaces = namespaces
        self.pubs = {}
        self.efforts = {ns: [] for ns in namespaces}
        self.states = {ns: [] for ns in namespaces}
        for ns in namespaces:
            self.pubs[ns] = {
                'state': self.node.create_publisher(JointState, f'{ns}/joint_states',
                                                    STATE_QOS),
                'accel': self.node.create_publisher(JointAccelerations,
                                                    f'{ns}/joint_accelerations', STATE_QOS),
                'mode': self.node.create_publisher(ControlMode, f'{ns}/control_mode', MODE_QOS),
                'setpoint': {j: self.node.create_publisher(
                    JointCommand, f'{ns}/controllers/{j}/setpoint', COMMAND_QOS)
                    for j in PHYSICAL_JOINT_NAMES}}
            self.node.create_subscription(JointState, f'{ns}/effort_commands',
                                          self.efforts[ns].append, COMMAND_QOS)
            for joint in PHYSICAL_JOINT_NAMES:
                self.node.create_subscription(ControllerState, f'{ns}/controllers/{joint}/state',
                                              self.states[ns].append, COMMAND_QOS)
        self.stamp_ns = 1_000_000_000
        self.position = list(STANCE)

    def close(self):
        self.executor.shutdown()
        self.node.destroy_node()

    def spin_until(self, predicate, timeout=WAIT):
        from ros_test_support import spin_executor_until

        return spin_executor_until(self.executor, predicate, timeout)

    def _stamped(self, msg, stamp_ns):
        from ros_test_support import set_stamp

        return set_stamp(msg, stamp_ns)

    def answers(self, ns, stamp_ns):
        return [e for e in self.efforts[ns][-5:] if _ns(e.header.stamp) == stamp_ns]

    def step(self, velocity=None):
        """Advance one period; publish the state until every namespace has answered it."""
        from sensor_msgs.msg import JointState
        from walker_msgs.msg import JointAccelerations

        from walker_core.joint_roles import PHYSICAL_JOINT_NAMES

        self.stamp_ns += PERIOD_NS
        names = list(PHYSICAL_JOINT_NAMES)
        for _ in range(int(WAIT / 0.05)):
            for ns in self.namespaces:
                self.pubs[ns]['accel'].publish(self._stamped(
                    JointAccelerations(name=names, acceleration=[0.1] * 5), self.stamp_ns))
                self.pubs[ns]['state'].publish(self._stamped(JointState(
                    name=names, position=list(self.position),
                    velocity=list(velocity or [0.0] * 5), effort=[0.0] * 5), self.stamp_ns))
            if self.spin_until(lambda: all(self.answers(ns, self.stamp_ns)
                                           for ns in self.namespaces), timeout=0.05):
                return {ns: self.answers(ns, self.stamp_ns)[-1] for ns in self.namespaces}
        raise AssertionError(f'no effort for the state stamped {self.stamp_ns} ns')

    def command(self, mode, base='a'):
        from walker_msgs.msg import ControlMode

        for ns in self.namespaces:
            self.pubs[ns]['mode'].publish(ControlMode(mode=mode, base_gripper=base,
                                                      commander=f'{ns}/supervisor'))

    def setpoint(self, joint, stamp_ns, position, velocity=0.0):
        from walker_msgs.msg import JointCommand

        for ns in self.namespaces:
            self.pubs[ns]['setpoint'][joint].publish(self._stamped(
                JointCommand(joint_name=joint, position=position, velocity=velocity),
                stamp_ns))


@pytest.fixture
def stand_in(rclpy_context):
    plant = StandIn(rclpy_context, ['/grouped', '/single'])
    yield plant
    plant.close()


def test_one_effort_message_answers_each_state_for_every_joint(ros_env, rclpy_context):
    from walker_core.joint_roles import PHYSICAL_JOINT_NAMES

    plant = StandIn(rclpy_context, ['/grouped'])
    try:
        with start_grouped(ros_env) as node:
            first = plant.step()['/grouped']  # waits for discovery
            assert list(first.name) == list(PHYSICAL_JOINT_NAMES)
            start = len(plant.efforts['/grouped'])
            for _ in range(50):
                answer = plant.step()['/grouped']
                assert list(answer.name) == list(PHYSICAL_JOINT_NAMES)
                assert len(answer.effort) == 5 and all(math.isfinite(e) for e in answer.effort)
            plant.spin_until(lambda: False, timeout=0.2)
            # one message per state naming every joint, not one per joint (a state the stand-in
            # asked for again, on a loaded machine, is answered again)
            answers = plant.efforts['/grouped'][start:]
            assert all(list(a.name) == list(PHYSICAL_JOINT_NAMES) for a in answers)
            stamps = {(a.header.stamp.sec, a.header.stamp.nanosec) for a in answers}
            stamps.discard((first.header.stamp.sec, first.header.stamp.nanosec))
            assert len(stamps) == 50
            joints = {s.joint_name for s in plant.states['/grouped']}
            assert joints == set(PHYSICAL_JOINT_NAMES)
            assert 'controlling a_yaw_joint (J1), a_pitch_joint (J2)' in node.output
    finally:
        plant.close()


def test_each_joint_answers_as_its_own_controller_process_would(ros_env, stand_in):
    """Same inputs, same effort: the vertex joint in the group and in a process of its own."""
    import time

    from walker_control.core.modes import Mode
    from walker_msgs.msg import ControllerState

    joint = 'vertex_joint'
    with start_grouped(ros_env), start_single(ros_env, joint):
        stand_in.step()  # both discovered
        stand_in.command(int(Mode.COARSE))

        def coarse_in_both() -> bool:
            newest = {ns: [s.mode for s in stand_in.states[ns] if s.joint_name == joint][-1:]
                      for ns in ('/grouped', '/single')}
            return all(modes == [ControllerState.COARSE] for modes in newest.values())

        deadline = time.monotonic() + WAIT
        while not coarse_in_both():  # the mode has reached both, however loaded the machine
            assert time.monotonic() < deadline, 'the COARSE command did not reach both'
            stand_in.step()
        compared = 0
        for k in range(300):
            # a ramp of the vertex joint's setpoint, ten periods ahead of the state it applies
            # to, so that both processes hold it when that state comes
            ahead = stand_in.stamp_ns + 10 * PERIOD_NS
            stand_in.setpoint(joint, ahead, STANCE[2] + 0.0005 * k, 0.25)
            stand_in.position[2] = STANCE[2] + 0.0004 * k  # the joint lags its setpoint
            answers = stand_in.step(velocity=[0.0, 0.0, 0.2, 0.0, 0.0])
            grouped = dict(zip(answers['/grouped'].name, answers['/grouped'].effort,
                               strict=True))
            single = dict(zip(answers['/single'].name, answers['/single'].effort, strict=True))
            assert grouped[joint] == single[joint], (k, grouped[joint], single[joint])
            compared += 1
        assert compared == 300
        # the comparison meant something: the joint was driven, not held at zero effort
        efforts = [s.effort for s in stand_in.states['/single'][-100:]]
        assert max(abs(e) for e in efforts) > 0.1, efforts
        assert {s.mode for s in stand_in.states['/grouped'][-50:]} == {int(Mode.COARSE)}


def test_a_subset_of_joints_is_answered_alone(ros_env, rclpy_context):
    plant = StandIn(rclpy_context, ['/grouped'])
    try:
        with start_grouped(ros_env, '-p', 'joint_names:=[b_yaw_joint, vertex_joint]'):
            answer = plant.step()['/grouped']
            assert list(answer.name) == ['b_yaw_joint', 'vertex_joint']
            assert len(answer.effort) == 2
    finally:
        plant.close()


@pytest.mark.parametrize('names, wrong', [('[vertex_joint, elbow]', 'elbow'),
                                          ('[vertex_joint, vertex_joint]', 'distinct'),
                                          ('[]', 'distinct'), ('5', 'joint_names refused')])
def test_refuses_to_start_on_unknown_or_repeated_joints(ros_env, names, wrong):
    with start_grouped(ros_env, '-p', f'joint_names:={names}') as node:
        assert node.process.wait(timeout=WAIT) == 2
        assert wrong in node.output and 'refusing to start' in node.output, node.output


def test_states_handed_over_by_call_take_their_setpoints_without_the_executor(rclpy_context):
    """The loop by call: the node answers a state with the setpoints received for it.

    With the node in this process and the plant handing it states by call
    (``answer_plant_directly``), the setpoints are taken from the middleware as each state is
    handed over: once the mode is in, nothing spins the node, and still every joint follows
    the setpoints the stand-in planner sent ahead.
    """
    from rclpy.executors import SingleThreadedExecutor
    from sensor_msgs.msg import JointState
    from walker_msgs.msg import JointAccelerations

    from ros_test_support import set_stamp, spin_executor_until
    from walker_control.core.modes import Mode
    from walker_control.joint_controllers_node import JointControllersNode
    from walker_core.joint_roles import PHYSICAL_JOINT_NAMES

    names = list(PHYSICAL_JOINT_NAMES)
    node = JointControllersNode(context=rclpy_context, cli_args=[
        '--ros-args', '-r', '__ns:=/bycall', '-p', 'use_sim_time:=true', *OPTIONS])
    answers = []
    node.answer_plant_directly(answers.append)
    plant = StandIn(rclpy_context, ['/bycall'])
    executor = SingleThreadedExecutor(context=rclpy_context)
    executor.add_node(node)

    def hand_over(stamp_ns):
        node.take_accelerations(set_stamp(JointAccelerations(name=names,
                                                             acceleration=[0.0] * 5), stamp_ns))
        node.take_state(set_stamp(JointState(name=names, position=list(STANCE),
                                             velocity=[0.0] * 5, effort=[0.0] * 5), stamp_ns))
        assert answers and _ns(answers[-1].header.stamp) == stamp_ns

    def latest_states():
        return {s.joint_name: s for s in plant.states['/bycall']}

    try:
        plant.command(int(Mode.FINE))
        for _ in range(int(WAIT / 0.05)):  # the mode goes in through the executor
            plant.stamp_ns += PERIOD_NS
            hand_over(plant.stamp_ns)
            spin_executor_until(executor, lambda: False, 0.05)
            plant.spin_until(lambda: False, timeout=0.02)
            states = latest_states()
            if len(states) == 5 and all(s.mode == int(Mode.FINE) for s in states.values()):
                break
        else:
            raise AssertionError(f'the mode did not reach every joint: {latest_states()}')
        executor.remove_node(node)  # from here on, nothing spins the controllers' node
        ahead = plant.stamp_ns + 10 * PERIOD_NS
        goal = [position + 0.01 for position in STANCE]
        for joint, position in zip(names, goal, strict=True):
            plant.setpoint(joint, ahead, position)
        # states after the setpoints' stamp: they apply, and no state waits for a stream
        for _ in range(int(WAIT / 0.01)):  # until the middleware has delivered them
            plant.stamp_ns = max(plant.stamp_ns, ahead) + PERIOD_NS
            hand_over(plant.stamp_ns)
            plant.spin_until(lambda: False, timeout=0.01)
            states = latest_states()
            if all(_ns(states[j].header.stamp) == plant.stamp_ns
                   and states[j].position_setpoint == pytest.approx(goal[k], abs=1e-12)
                   for k, j in enumerate(names)):
                break
        else:
            raise AssertionError(f'the setpoints were never taken: {latest_states()}')
        assert all(s.mode == int(Mode.FINE) and not s.stale for s in states.values())
    finally:
        executor.shutdown()
        plant.close()
        node.destroy_node()
