"""The plant node over DDS: names, rates and QoS in both clock modes, the lock-step, the service.

Each test starts the real node (``plant_node``, as ``ros2 run`` would) in a process of its own,
in a ROS domain of its own, and talks to it from this process.
"""

import os
import time
import xml.etree.ElementTree as ElementTree
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from ros_test_support import NodeProcess

pytestmark = pytest.mark.integration

NAMESPACE = '/walker'
JOINTS = ['a_yaw_joint', 'a_pitch_joint', 'vertex_joint', 'b_pitch_joint', 'b_yaw_joint']
START_TIMEOUT = 60.0  # [s] start-up of a node on a loaded machine (not a measurement)


def plant_executable():
    from ament_index_python.packages import get_package_prefix

    return str(Path(get_package_prefix('walker_sim')) / 'lib' / 'walker_sim' / 'plant_node')


def start_plant(env, *parameters):
    args = [plant_executable(), '--ros-args', '-r', f'__ns:={NAMESPACE}']
    for parameter in parameters:
        args += ['-p', parameter]
    return NodeProcess(args, env, 'plant')


class Probe:
    """A test node in this process, with an executor of its own."""

    def __init__(self, context, name='probe'):
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node

        self.node = Node(name, context=context)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)

    def spin_until(self, condition, timeout):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline and not condition():
            self.executor.spin_once(timeout_sec=0.01)
        return condition()

    def spin_for(self, seconds):
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.01)

    def close(self):
        self.executor.remove_node(self.node)
        self.node.destroy_node()
        self.executor.shutdown()


@pytest.fixture
def probe(rclpy_context):
    node = Probe(rclpy_context)
    yield node
    node.close()


def stamp_ns(stamp):
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def qos_of(endpoints):
    return [(e.qos_profile.reliability, e.qos_profile.durability) for e in endpoints]


def wait_for_endpoints(probe, topic, publishers=True):
    lookup = (probe.node.get_publishers_info_by_topic if publishers
              else probe.node.get_subscriptions_info_by_topic)
    probe.spin_until(lambda: lookup(topic), 10.0)
    return lookup(topic)


def test_real_time_mode_publishes_the_five_joints_at_the_control_rate(ros_env, probe):
    from rclpy.qos import DurabilityPolicy, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from std_msgs.msg import String

    from walker_msgs.msg import GripperStates, JointAccelerations
    from walker_sim.messages import LATCHED_QOS, SENSOR_QOS

    from diagnostic_msgs.msg import DiagnosticArray

    states, accelerations, descriptions, grippers, diagnostics = [], [], [], [], []
    node = probe.node
    node.create_subscription(JointState, f'{NAMESPACE}/joint_states', states.append,
                             SENSOR_QOS)
    node.create_subscription(JointAccelerations, f'{NAMESPACE}/joint_accelerations',
                             accelerations.append, SENSOR_QOS)
    node.create_subscription(DiagnosticArray, '/diagnostics', diagnostics.append, 10)
    # real time as run_all.py --realtime runs it (the default scheduler leaves the period to
    # the machine's load)
    with start_plant(ros_env, 'sim.clock_mode:=real_time',
                     'timing.realtime_priority:=50') as plant:
        assert probe.spin_until(lambda: len(states) > 0, START_TIMEOUT), plant.output
        states.clear()
        probe.spin_until(lambda: len(states) >= 400, 10.0)
        # late joiners get the latched topics
        node.create_subscription(String, f'{NAMESPACE}/robot_description', descriptions.append,
                                 LATCHED_QOS)
        node.create_subscription(GripperStates, f'{NAMESPACE}/gripper_states',
                                 grippers.append, LATCHED_QOS)
        assert probe.spin_until(lambda: descriptions and grippers, 10.0), plant.output

        reliable, volatile = ReliabilityPolicy.RELIABLE, DurabilityPolicy.VOLATILE
        best_effort, latched = ReliabilityPolicy.BEST_EFFORT, DurabilityPolicy.TRANSIENT_LOCAL
        topic = f'{NAMESPACE}/'.__add__
        assert qos_of(wait_for_endpoints(probe, topic('joint_states'))) == [
            (best_effort, volatile)]
        assert qos_of(wait_for_endpoints(probe, topic('joint_accelerations'))) == [
            (best_effort, volatile)]
        assert qos_of(wait_for_endpoints(probe, topic('tip_pose'))) == [(best_effort, volatile)]
        assert qos_of(wait_for_endpoints(probe, topic('gripper_states'))) == [
            (reliable, latched)]
        assert qos_of(wait_for_endpoints(probe, topic('robot_description'))) == [
            (reliable, latched)]
        assert qos_of(wait_for_endpoints(probe, topic('effort_commands'), False)) == [
            (reliable, volatile)]
        assert node.get_publishers_info_by_topic('/clock') == []
        assert probe.spin_until(lambda: diagnostics, 15.0), plant.output
    # the loop's record (walker_bringup.loop_health): no controller answered, so the loop
    # never closed and its longest standstill is still none
    report = diagnostics[-1].status[0]
    assert report.message.startswith('real_time, t=')
    assert {v.key: v.value for v in report.values}['longest tick interval [ms]'] == '0.0'
    assert len(states) >= 100, 'too few joint states to judge the rate'
    for message in states:
        assert list(message.name) == JOINTS
        assert len(message.position) == len(message.velocity) == len(message.effort) == 5
    # On a loaded machine the timer is sometimes late (the plant then catches up with the
    # wall clock and skips publishing); the period it keeps whenever it runs is still the
    # most common one: the control period, 2 ms.
    stamps = sorted({stamp_ns(m.header.stamp) for m in states})
    bins = Counter(round((b - a) / 250_000) for a, b in zip(stamps, stamps[1:], strict=False))
    assert bins.most_common(1)[0][0] == 8, f'periods [0.25 ms]: {sorted(bins.items())}'
    assert accelerations and list(accelerations[-1].name) == JOINTS
    urdf = ElementTree.fromstring(descriptions[-1].data)
    moving = [j.get('name') for j in urdf.findall('joint') if j.get('type') != 'fixed']
    assert moving == JOINTS
    assert [g.name for g in grippers[-1].grippers] == ['a', 'b']
    # which gripper is the base is the supervisor's to say (phase, control_mode), never
    # the plant's: a second source disagreed with the supervisor after every step
    assert 'base_gripper' not in grippers[-1].get_fields_and_field_types()


def test_sim_time_mode_is_lock_stepped_with_the_controllers(ros_env, probe):
    """Answer every state with five efforts: each is applied, /clock advances one period."""
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import JointState

    from walker_sim.messages import COMMAND_QOS, SENSOR_QOS

    period = 2_000_000  # [ns] the default control rate, 500 Hz
    node = probe.node
    states, clocks = {}, []
    efforts = node.create_publisher(JointState, f'{NAMESPACE}/effort_commands', COMMAND_QOS)
    hold = {'answer': True}

    def command(step, joint):
        return 0.001 * ((7 * step + 3 * JOINTS.index(joint)) % 100) - 0.05  # N*m, distinct

    def on_state(message):
        stamp = stamp_ns(message.header.stamp)
        states.setdefault(stamp, message)
        if not hold['answer']:
            return
        # a controller answers every state it gets, including the plant's re-sends of t=0
        for joint in JOINTS:
            answer = JointState(name=[joint], effort=[command(stamp // period, joint)])
            answer.header.stamp = message.header.stamp
            efforts.publish(answer)

    node.create_subscription(JointState, f'{NAMESPACE}/joint_states', on_state, SENSOR_QOS)
    diagnostics = []
    node.create_subscription(DiagnosticArray, '/diagnostics', diagnostics.append, 10)
    # a deep reliable queue, so that this test sees every tick (the plant offers keep-last-1)
    node.create_subscription(Clock, '/clock', lambda m: clocks.append(stamp_ns(m.clock)),
                             QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE))
    with start_plant(ros_env, 'sim.clock_mode:=sim_time', 'sim.lockstep_timeout:=30.0') as plant:
        assert probe.spin_until(lambda: len(states) >= 300, START_TIMEOUT + 60), plant.output
        clock_qos = qos_of(wait_for_endpoints(probe, '/clock'))
        # stop answering: the plant must wait (its timeout is 30 s)
        hold['answer'] = False
        probe.spin_for(0.3)
        newest = max(states)
        probe.spin_for(0.5)
        assert max(states) == newest, 'the plant stepped without the efforts'
        hold['answer'] = True
        on_state(states[newest])
        assert probe.spin_until(lambda: max(states) > newest + 10 * period, 30.0)
        hold['answer'] = False
        probe.spin_until(lambda: clocks and max(clocks) >= max(states), 5.0)
        diagnostics.clear()
        # published at 1 Hz; a loaded machine may delay one by seconds
        assert probe.spin_until(lambda: diagnostics, 15.0), plant.output
    report = {v.key: v.value for v in diagnostics[-1].status[0].values}
    assert all(report[f'missed {joint}'] == '0' for joint in JOINTS), report
    stamps = sorted(states)
    assert stamps == [k * period for k in range(len(stamps))], 'a step was skipped'
    assert all(list(m.name) == JOINTS and len(m.position) == 5 for m in states.values())
    for stamp in stamps[1:]:
        applied = list(states[stamp].effort)
        expected = [command(stamp // period - 1, joint) for joint in JOINTS]
        assert applied == pytest.approx(expected, abs=1e-12), f'at t={stamp * 1e-9:.3f} s'
    # /clock ticks at sim.clock_rate (100 Hz by default): every 5th state's stamp, evenly
    ticks = sorted(set(clocks))
    clock_period = round(1e9 / 100.0)
    assert ticks and set(ticks) <= set(stamps)
    assert all(b - a == clock_period for a, b in zip(ticks, ticks[1:], strict=False))
    assert max(ticks) > max(stamps) - clock_period - 1
    assert clock_qos == [(ReliabilityPolicy.RELIABLE, clock_qos[0][1])]


def test_the_gripper_service_releases_one_gripper_and_refuses_the_other(ros_env, probe):
    from walker_msgs.msg import GripperState, GripperStates
    from walker_msgs.srv import GripperCommand
    from walker_sim.messages import LATCHED_QOS

    node = probe.node
    grippers = []
    node.create_subscription(GripperStates, f'{NAMESPACE}/gripper_states', grippers.append,
                             LATCHED_QOS)
    client = node.create_client(GripperCommand, f'{NAMESPACE}/gripper_command')

    def call(gripper, command):
        future = client.call_async(GripperCommand.Request(gripper=gripper, command=command))
        assert probe.spin_until(future.done, 10.0)
        return future.result()

    def mode_of(gripper):
        return {g.name: g.state for g in grippers[-1].grippers}[gripper] if grippers else None

    with start_plant(ros_env, 'sim.clock_mode:=real_time') as plant:
        assert probe.spin_until(client.service_is_ready, START_TIMEOUT), plant.output
        released = call('b', GripperCommand.Request.UNSCREW)
        assert released.success and released.state.state == GripperState.UNSCREWING
        refused = call('a', GripperCommand.Request.UNSCREW)
        assert not refused.success and 'interlock' in refused.message
        assert refused.state.state == GripperState.ATTACHED
        assert probe.spin_until(lambda: mode_of('b') == GripperState.FREE, 10.0)
        unknown = call('c', GripperCommand.Request.SCREW_IN)
        assert not unknown.success and "unknown gripper 'c'" in unknown.message
        again = call('b', GripperCommand.Request.SCREW_IN)
        assert again.success and again.state.state == GripperState.SCREWING
        assert probe.spin_until(lambda: mode_of('b') == GripperState.ATTACHED, 10.0)


@pytest.mark.parametrize('parameter, words', [
    ('sim.clock_mode:=fast', 'sim.clock_mode'),
    ('sim.start.other_node:=n9_9', 'sim.start.other_node'),
    ('sim.physics_rate:=1250.0', 'integer multiple'),
])
def test_the_node_refuses_to_start_on_invalid_parameters(ros_env, parameter, words):
    with start_plant(ros_env, parameter) as plant:
        plant.process.wait(timeout=START_TIMEOUT)
        assert plant.process.returncode == 2  # walker_runtime.node_main.EXIT_REFUSED
        assert 'refusing to start' in plant.output and words in plant.output
        assert 'Traceback' not in plant.output


def test_runtime_updates_are_validated_and_read_only_settings_refused(rclpy_context):
    from rclpy.parameter import Parameter

    from walker_sim.plant_node import PlantNode

    node = PlantNode(context=rclpy_context, namespace=NAMESPACE)
    try:
        # built in this process, the node leaves its scheduling alone (only main() asks)
        assert (os.sched_getscheduler(0), os.sched_getparam(0).sched_priority) == (
            os.SCHED_OTHER, 0)
        applied = node.set_parameters([Parameter('sim.lockstep_timeout', value=2.5)])[0]
        assert applied.successful and node.lockstep.timeout == 2.5
        refused = node.set_parameters([Parameter('sim.command_timeout', value=-1.0)])[0]
        assert not refused.successful and node.commands.command_timeout == 0.1
        frozen = node.set_parameters([Parameter('sim.physics_rate', value=4000.0)])[0]
        assert not frozen.successful and node.sim.physics_rate == 1000.0
        described = node.describe_parameter('sim.physics_rate')
        assert '[Hz]' in described.description and described.read_only
    finally:
        node.destroy_node()


def test_an_injected_fouled_thread_jams_screw_ins_and_the_parameter_counts_down(rclpy_context):
    from rclpy.parameter import Parameter
    from walker_msgs.srv import GripperCommand

    from walker_sim.plant_node import PlantNode

    node = PlantNode(context=rclpy_context, namespace=NAMESPACE)
    try:
        refused = node.set_parameters([Parameter('sim.jam_screw_ins', value=-1)])[0]
        assert not refused.successful and node.plant.fouled_screw_ins == 0
        assert node.set_parameters([Parameter('sim.jam_screw_ins', value=2)])[0].successful
        assert node.plant.fouled_screw_ins == 2
        # the start stance has both grippers attached: let b go, then screw it back in
        release = GripperCommand.Request(gripper='b', command=GripperCommand.Request.UNSCREW)
        assert node._on_gripper_command(release, GripperCommand.Response()).success
        for _ in range(1000):  # 10 s of plant time, far more than the screw time
            if node.plant.gripper_status('b').mode.name == 'FREE':
                break
            node.plant.step(np.zeros(5), 0.01)
        assert node.plant.gripper_status('b').mode.name == 'FREE'
        screw_in = GripperCommand.Request(gripper='b', command=GripperCommand.Request.SCREW_IN)
        for remaining in (1, 0):
            answer = node._on_gripper_command(screw_in, GripperCommand.Response())
            assert not answer.success and 'fouled' in answer.message
            assert node.get_parameter('sim.jam_screw_ins').value == remaining
        answer = node._on_gripper_command(screw_in, GripperCommand.Response())
        assert answer.success, answer.message
    finally:
        node.destroy_node()


@pytest.mark.parametrize('clock_mode', ['real_time', 'sim_time'])
def test_the_plant_runs_under_real_time_scheduling_on_the_wall_clock_only(ros_env, clock_mode):
    """On the wall clock the plant runs under SCHED_FIFO; in sim time under the default policy.

    On the wall clock (``timing.realtime_priority`` 50, what ``run_all.py --realtime`` asks
    for; the shipped file asks for none) every thread, the
    middleware's included, runs under it where the machine permits it, and the plant says why
    not where it does not.
    """
    from ros_test_support import realtime_permitted, thread_policies

    with start_plant(ros_env, f'sim.clock_mode:={clock_mode}',
                     'timing.realtime_priority:=50') as plant:
        assert plant.wait_for_output('plant ready', START_TIMEOUT), plant.output
        if clock_mode == 'real_time':  # main() asks after the node is built, and logs it
            assert plant.wait_for_output('SCHED_FIFO', START_TIMEOUT), plant.output
        policies = thread_policies(plant.process.pid)
        if clock_mode == 'sim_time':
            assert policies == {(os.SCHED_OTHER, 0)}, policies
        elif realtime_permitted():
            assert policies == {(os.SCHED_FIFO, 50)}, (policies, plant.output)
            assert 'SCHED_FIFO priority 50 on' in plant.output
        else:
            assert policies == {(os.SCHED_OTHER, 0)}, policies
            assert 'SCHED_FIFO priority 50 refused' in plant.output, plant.output


PERIOD_NS = 2_000_000  # [ns] the control period


def _stand_in_supervisor(probe):
    """Answer every state with five efforts; return (states, /clock times, release)."""
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import JointState

    from walker_sim.messages import COMMAND_QOS, SENSOR_QOS

    node = probe.node
    states, clocks = {}, []
    efforts = node.create_publisher(JointState, f'{NAMESPACE}/effort_commands', COMMAND_QOS)
    decided = node.create_publisher(Clock, f'{NAMESPACE}/supervisor/decided_until', COMMAND_QOS)

    def on_state(message):
        states.setdefault(stamp_ns(message.header.stamp), message)
        for joint in JOINTS:  # every controller answers at once
            answer = JointState(name=[joint], effort=[0.0])
            answer.header.stamp = message.header.stamp
            efforts.publish(answer)

    def release(until):
        message = Clock()
        message.clock.sec, message.clock.nanosec = divmod(until, 1_000_000_000)
        decided.publish(message)

    node.create_subscription(JointState, f'{NAMESPACE}/joint_states', on_state, SENSOR_QOS)
    node.create_subscription(Clock, '/clock', lambda m: clocks.append(stamp_ns(m.clock)),
                             QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE))
    return states, clocks, release


def test_with_wait_for_decisions_the_plant_steps_no_further_than_the_supervisor_released(
        ros_env, probe):
    """A stand-in supervisor releases the clock to 40 ms, then 60 ms, then falls silent."""
    period = PERIOD_NS
    states, clocks, release = _stand_in_supervisor(probe)
    with start_plant(ros_env, 'sim.clock_mode:=sim_time', 'sim.lockstep_timeout:=30.0',
                     'sim.wait_for_decisions:=true', 'sim.decision_timeout:=2.0') as plant:
        assert probe.spin_until(lambda: states, START_TIMEOUT), plant.output
        wait_for_endpoints(probe, f'{NAMESPACE}/supervisor/decided_until', publishers=False)
        release(0)  # the supervisor's first word: it has decided at t = 0
        probe.spin_for(0.5)
        held = max(states)
        release(40 * period // 2)  # up to 40 ms
        assert probe.spin_until(lambda: max(states) == 20 * period, 10.0), plant.output
        probe.spin_for(0.5)
        assert max(states) == 20 * period, 'stepped past the release'
        release(23 * period)  # 46 ms: off the 10 ms grid of /clock
        assert probe.spin_until(lambda: max(states) == 23 * period, 10.0), plant.output
        probe.spin_until(lambda: clocks and max(clocks) == 23 * period, 5.0)
        assert max(clocks) == 23 * period  # /clock reaches the release: the supervisor's
        # ROS-time timer sees the time it released up to
        # a supervisor holding the clock where it stands (awaiting an answer), then silent
        # for longer than decision_timeout: the plant steps on without it
        release(23 * period)
        assert probe.spin_until(lambda: max(states) > 60 * period, 15.0), plant.output
        assert plant.wait_for_output('has not decided beyond', 5.0), plant.output
    assert held <= period  # held at the first release (t = 0; the first state answered)


def test_turning_the_wait_for_decisions_off_lets_a_held_plant_step_on_at_once(ros_env, probe):
    """Held at the supervisor's release, the plant steps on when the wait is turned off.

    The decision timeout (30 s) is far beyond the test's waits: what moves it is the
    parameter, set at run time as an operator would.
    """
    from rcl_interfaces.srv import SetParameters
    from rclpy.parameter import Parameter

    states, _, release = _stand_in_supervisor(probe)
    with start_plant(ros_env, 'sim.clock_mode:=sim_time', 'sim.lockstep_timeout:=30.0',
                     'sim.wait_for_decisions:=true', 'sim.decision_timeout:=30.0') as plant:
        assert probe.spin_until(lambda: states, START_TIMEOUT), plant.output
        wait_for_endpoints(probe, f'{NAMESPACE}/supervisor/decided_until', publishers=False)
        release(0)
        probe.spin_for(1.0)
        assert max(states) <= PERIOD_NS, 'stepped past the release'
        client = probe.node.create_client(SetParameters, f'{NAMESPACE}/plant/set_parameters')
        assert probe.spin_until(client.service_is_ready, 10.0)
        off = Parameter('sim.wait_for_decisions', value=False).to_parameter_msg()
        future = client.call_async(SetParameters.Request(parameters=[off]))
        assert probe.spin_until(future.done, 10.0) and future.result().results[0].successful
        assert probe.spin_until(lambda: max(states) > 100 * PERIOD_NS, 10.0), plant.output


def test_a_camera_trigger_sends_one_frame_of_the_next_step_and_none_streams(ros_env, probe):
    """Sim time, cameras on: a frame a trigger, of a state the plant published, none unasked.

    A subscriber listens to the image all along; with ``sim.camera.frame_rate`` 0 (the
    default) nothing is rendered for it until the trigger. The frame is exposed at a state the
    plant stepped to after the trigger was taken, and image and calibration carry that stamp.
    """
    from rclpy.qos import ReliabilityPolicy
    from sensor_msgs.msg import CameraInfo, Image, JointState
    from std_srvs.srv import Trigger

    from walker_runtime.qos import IMAGE_QOS
    from walker_sim.messages import COMMAND_QOS, SENSOR_QOS

    node = probe.node
    states, images, infos = [], [], []
    efforts = node.create_publisher(JointState, f'{NAMESPACE}/effort_commands', COMMAND_QOS)

    def answer(message):  # five controllers that command no torque
        states.append(stamp_ns(message.header.stamp))
        efforts.publish(JointState(header=message.header, name=JOINTS, effort=[0.0] * 5))

    node.create_subscription(JointState, f'{NAMESPACE}/joint_states', answer, SENSOR_QOS)
    node.create_subscription(Image, f'{NAMESPACE}/camera_b/image_raw', images.append,
                             IMAGE_QOS)
    node.create_subscription(CameraInfo, f'{NAMESPACE}/camera_b/camera_info', infos.append,
                             IMAGE_QOS)
    trigger = node.create_client(Trigger, f'{NAMESPACE}/camera_b/trigger')
    with start_plant(ros_env, 'sim.clock_mode:=sim_time', 'sim.lockstep_timeout:=30.0',
                     'gripper.camera.enabled:=true') as plant:
        assert probe.spin_until(lambda: len(states) >= 100 and trigger.service_is_ready(),
                                START_TIMEOUT + 60), plant.output
        probe.spin_until(lambda: len(states) >= 600, 10.0)  # a second of plant time, heard
        assert images == [] and infos == [], 'a frame nobody asked for'
        reliable = ReliabilityPolicy.RELIABLE
        assert [e.qos_profile.reliability for e in node.get_publishers_info_by_topic(
            f'{NAMESPACE}/camera_b/image_raw')] == [reliable]
        asked_after = states[-1]
        future = trigger.call_async(Trigger.Request())
        assert probe.spin_until(future.done, 10.0), plant.output
        assert future.result().success and 'next plant step' in future.result().message
        assert probe.spin_until(lambda: images and infos, 30.0), plant.output
        probe.spin_for(1.0)  # more steps, no more frames
    image, = images  # one frame a call
    info, = infos
    exposure = stamp_ns(image.header.stamp)
    assert exposure > asked_after and exposure in states  # a state stepped to after the call
    assert stamp_ns(info.header.stamp) == exposure
    assert (image.encoding, image.width, image.height) == ('rgb8', 400, 300)
    assert image.header.frame_id == info.header.frame_id == 'camera_b_optical'
    assert len(image.data) == 3 * 400 * 300
