"""Teleoperation over real DDS, in sim time: refused commands move nothing, valid jogs move.

The whole graph runs as separate processes, as ``scripts/run_all.py`` starts it. From the start
stance (both grippers attached) a jog is refused, as it is during a step; a hold in the step's
extraction leaves gripper b free, gripper a holding the walker. Then a jog beyond the limits of
the parameter file is refused, from ``walkerctl`` too, and nothing moves; a jog within them
moves the joint it names, and a tip jog lifts the free gripper. Every ``gripper_states``
message seen is checked: at least one gripper is attached at every instant.
"""

import math
import subprocess
import sys
import time

import pytest

from ros_test_support import REPO_ROOT, ros_environment, running_graph

pytestmark = pytest.mark.integration

STARTUP_TIMEOUT = 120.0  # [s] wall, for the graph to come up on a loaded machine
ANSWER_TIMEOUT = 60.0  # [s] wall, for a jog (a few seconds of sim time) to be answered
STILL = 2e-3  # [rad] the joints of a walker that was told nothing move less than this
B_YAW = 4  # index of b_yaw_joint in the physical order of joint_states
#: Timeouts [s] of this test's parameter file, and the file's own.
PATIENT_TIMEOUTS = {'watchdog_timeout': 5.0, 'setpoint_timeout': 2.0, 'state_timeout': 2.0}
DEFAULT_TIMEOUTS = {'watchdog_timeout': 2.0, 'setpoint_timeout': 0.5, 'state_timeout': 0.5}


class Graph:
    """The running graph, a client node with the teleoperation clients, the states seen."""

    def __init__(self, tmp, domain: int) -> None:
        from walker_bringup.graph import walker_graph
        from walker_bringup.processes import ProcessGroup

        self.env = ros_environment(domain)
        self.nodes = walker_graph(_patient_parameters(tmp), sim_time=True)
        self.group = ProcessGroup(tmp / 'logs', self.env)
        self.context = self.client = None
        try:
            self._start(domain)
        except BaseException:  # a graph that did not come up is stopped, not left running
            self.close()
            raise

    def _start(self, domain: int) -> None:
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from sensor_msgs.msg import JointState
        from walker_msgs.msg import GripperStates
        from walker_msgs.srv import GripperCommand, JogJoint, JogTip

        from walker_bringup.graph_client import GraphClient, init_context

        for spec in self.nodes:
            self.group.start(spec)
        self.context = init_context(domain)
        self.client = GraphClient('/walker', self.context)
        node = self.client.node
        self.jog_joint = node.create_client(JogJoint, 'jog_joint')
        self.jog_tip = node.create_client(JogTip, 'jog_tip')
        self.operate_gripper = node.create_client(GripperCommand, 'operate_gripper')
        self.gripper_states = []
        self.joint_states = []
        node.create_subscription(JointState, 'joint_states', self.joint_states.append,
                                 QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT))
        node.create_subscription(GripperStates, 'gripper_states', self.gripper_states.append,
                                 QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE,
                                            durability=DurabilityPolicy.TRANSIENT_LOCAL))
        self.client.wait_until_ready([n.full_name for n in self.nodes], STARTUP_TIMEOUT,
                                     should_stop=lambda: bool(self.group.poll_deaths()))
        for service in (self.jog_joint, self.jog_tip, self.operate_gripper):
            assert service.wait_for_service(timeout_sec=30.0), service.srv_name

    def close(self) -> dict:
        if self.client is not None:
            self.client.close()
        if self.context is not None:
            self.context.try_shutdown()
        return self.group.stop_all()

    def call(self, service, request, timeout: float = ANSWER_TIMEOUT):
        return self.client._wait(service.call_async(request), timeout, None, service.srv_name)

    def jog(self, joint: str, delta: float, max_velocity: float = 0.0):
        from walker_msgs.srv import JogJoint

        return self.call(self.jog_joint, JogJoint.Request(joint_name=joint, delta=delta,
                                                          max_velocity=max_velocity))

    def positions(self) -> list[float]:
        """Return the newest joint angles [rad], physical order, after 0.3 s of spinning."""
        from walker_core.joint_roles import PHYSICAL_JOINT_NAMES

        self.client.spin_for(0.3)
        newest = self.joint_states[-1]
        angles = dict(zip(newest.name, newest.position, strict=True))
        return [angles[name] for name in PHYSICAL_JOINT_NAMES]

    def grippers(self) -> dict[str, str]:
        from walker_msgs.msg import GripperState

        names = {GripperState.FREE: 'free', GripperState.SCREWING: 'screwing',
                 GripperState.ATTACHED: 'attached', GripperState.UNSCREWING: 'unscrewing',
                 GripperState.JAMMED: 'jammed'}
        return {g.name: names[g.state] for g in self.gripper_states[-1].grippers}

    def wait_for(self, condition, timeout: float, what: str) -> None:
        deadline = time.monotonic() + timeout
        while not condition():
            assert time.monotonic() < deadline, f'waited {timeout:g} s for {what}'
            self.client.spin_for(0.1)

    def walkerctl(self, *args: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, str(REPO_ROOT / 'scripts' / 'walkerctl'), *args],
                              env=self.env, capture_output=True, text=True, timeout=120,
                              cwd=REPO_ROOT)


def _patient_parameters(tmp):
    """Write the parameter file with timeouts longer than a loaded machine stalls.

    The watchdog and the controllers' stale inputs have tests of their own (they stop the
    walker in safe hold, which also stops a jog); here a process delayed by other test runs
    on the machine must not end the step or the jogs this test needs.
    """
    from walker_core.robot_parameters import default_parameter_file

    text = default_parameter_file().read_text()
    for name, value in PATIENT_TIMEOUTS.items():
        line = f'{name}: {DEFAULT_TIMEOUTS[name]} '
        assert text.count(line) == 1, line
        text = text.replace(line, f'{name}: {value} ')
    path = tmp / 'walker.yaml'
    path.write_text(text)
    return path


@pytest.fixture(scope='module')
def graph(tmp_path_factory):
    with running_graph(Graph, tmp_path_factory.mktemp('teleop')) as running:
        yield running


def _moved(before, after) -> float:
    return max(abs(a - b) for a, b in zip(before, after, strict=True))


def test_jogs_out_of_limits_or_in_the_wrong_phase_are_refused_and_valid_ones_move(graph):
    from walker_msgs.action import Step
    from walker_msgs.msg import StepPhase
    from walker_msgs.srv import GripperCommand, JogTip

    client = graph.client
    # Both grippers screwed in: the chain is closed, no joint may move alone.
    before = graph.positions()
    answer = graph.jog('b_yaw_joint', 0.1)
    assert not answer.success and 'both grippers are screwed in' in answer.message
    assert _moved(before, graph.positions()) < STILL

    # During a step: refused with the reason; then a hold stops the step in its extraction.
    handle = client._wait(client.step_client.send_goal_async(Step.Goal(target_node='n1_2')),
                          30.0, None, 'the step goal')
    assert handle.accepted
    result = handle.get_result_async()
    stepping = (StepPhase.EXTRACTION, StepPhase.COARSE, StepPhase.FINE, StepPhase.INSERTION)
    graph.wait_for(lambda: result.done() or client.phase.phase in stepping, 60.0, 'the step')
    assert not result.done(), result.result().result.message
    answer = graph.jog('b_yaw_joint', 0.1)
    assert not answer.success and 'under way' in answer.message, answer.message
    refused = graph.call(graph.operate_gripper, GripperCommand.Request(
        gripper='a', command=GripperCommand.Request.UNSCREW))
    assert not refused.success and 'under way' in refused.message, refused.message
    assert client.call_trigger('hold').success
    client._wait(result, ANSWER_TIMEOUT, None, 'the held step')
    graph.wait_for(lambda: client.phase.phase == StepPhase.SAFE_HOLD
                   and not {'screwing', 'unscrewing'} & set(graph.grippers().values()),
                   ANSWER_TIMEOUT, 'safe hold with the grippers at rest')
    if graph.grippers()['b'] == 'attached':  # the hold came before the step unscrewed it
        released = graph.call(graph.operate_gripper, GripperCommand.Request(
            gripper='b', command=GripperCommand.Request.UNSCREW))
        assert released.success, released.message
    assert graph.grippers() == {'a': 'attached', 'b': 'free'}
    # a target that is not a node name is rejected as such, before anything else is judged
    run = graph.walkerctl('walk-to', 'n4_3\n')
    assert run.returncode == 1, run.stdout + run.stderr
    assert "walk-to n4_3\n refused: 'n4_3\\n' is not a node name" in run.stdout, run.stdout

    # Out of the parameter file's limits: refused, from walkerctl too, and nothing moves.
    before = graph.positions()
    answer = graph.jog('b_yaw_joint', 0.5)
    assert not answer.success and 'teleop.max_joint_jog' in answer.message, answer.message
    answer = graph.jog('b_yaw_joint', 0.1, max_velocity=1.0)
    assert not answer.success and 'teleop.max_joint_speed' in answer.message, answer.message
    run = graph.walkerctl('jog-joint', 'b_yaw_joint', '0.5')
    assert run.returncode == 1, run.stdout + run.stderr
    assert 'larger than a jog may be (teleop.max_joint_jog = 0.2 rad)' in run.stdout
    run = graph.walkerctl('jog-joint', 'b_yaw_joint', 'nan')
    assert run.returncode == 2 and "must be a finite number, got 'nan'" in run.stderr
    # what the plain ros2 CLI sends: refused in words an operator reads (no numpy repr, the
    # reason said once)
    unknown = graph.call(graph.operate_gripper, GripperCommand.Request(gripper='b', command=7))
    assert not unknown.success
    assert unknown.message == 'unknown gripper command 7: expected SCREW_IN (1) or UNSCREW (2)'
    nan = graph.call(graph.jog_tip, JogTip.Request(delta=[math.nan, 0.0, 0.0]))
    assert not nan.success and nan.message == 'delta must be a finite number, got nan m'
    assert _moved(before, graph.positions()) < STILL

    # Within the limits: the free gripper turns about its own axis (its contact point stays),
    # then lifts straight up along its axis.
    answer = graph.jog('b_yaw_joint', 0.1, max_velocity=0.2)
    assert answer.success, answer.message
    after = graph.positions()
    assert after[B_YAW] - before[B_YAW] == pytest.approx(0.1, abs=0.01)
    assert abs(answer.position_error) < 0.01
    lift = graph.call(graph.jog_tip, JogTip.Request(delta=[0.0, 0.0, 0.02], max_velocity=0.02))
    assert lift.success, lift.message
    assert lift.position_error < 0.002  # [m] corrected while beyond insertion_alignment, 1 mm
    assert _moved(after, graph.positions()) > 0.005
    assert graph.grippers() == {'a': 'attached', 'b': 'free'}


def test_the_controllers_mode_is_the_supervisors_alone(graph):
    """An operator's control_mode commands move nothing: the supervisor commands the mode.

    The sequence a hostile test once sent with gripper b free: HOLD with the free gripper as
    base, then a, b, a. Each base change started the controllers' relaxation dither with the
    chain open, and the free gripper ended 13 mm off, tilted and below the surface.
    """
    from geometry_msgs.msg import PoseStamped
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from walker_msgs.msg import ControlMode, StepPhase

    assert graph.grippers() == {'a': 'attached', 'b': 'free'}
    node = graph.client.node
    poses = []
    node.create_subscription(PoseStamped, 'gripper_b_pose', poses.append,
                             QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT))
    operator = node.create_publisher(ControlMode, 'control_mode', QoSProfile(
        depth=10, reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL))
    graph.wait_for(lambda: operator.get_subscription_count() >= 6, 30.0,
                   'the controllers and the planner to match the operator')
    before, phase = graph.positions(), graph.client.phase.phase

    def tip() -> list[float]:
        graph.client.spin_for(0.3)
        p = poses[-1].pose.position
        return [p.x, p.y, p.z]

    start = tip()
    for base in ('b', 'a', 'b', 'a'):
        operator.publish(ControlMode(mode=ControlMode.HOLD, base_gripper=base))
        graph.client.spin_for(0.5)  # longer than the relaxation dither (control.relaxation)
    for mode, base in ((ControlMode.OFF, 'a'), (ControlMode.HOLD, ''),
                       (ControlMode.FINE, 'b')):
        operator.publish(ControlMode(mode=mode, base_gripper=base))
        graph.client.spin_for(0.5)
    node.destroy_publisher(operator)
    moved = max(abs(a - b) for a, b in zip(start, tip(), strict=True))
    assert moved < 2e-4, f'the free gripper moved {moved * 1e3:.2f} mm'
    assert _moved(before, graph.positions()) < STILL
    assert graph.client.phase.phase == phase == StepPhase.SAFE_HOLD
    assert graph.grippers() == {'a': 'attached', 'b': 'free'}


def test_status_shows_the_mode_the_controllers_are_in_now(graph):
    """A late joiner of control_mode (walkerctl status) gets the mode commanded now.

    Each jog commands FINE, then HOLD once it has settled: after five the supervisor's last
    ten commands alternate, the oldest of them FINE. The controllers hold, with gripper a as
    base.
    """
    for delta in (0.05, -0.05, 0.05, -0.05, 0.05):
        answer = graph.jog('b_yaw_joint', delta, max_velocity=0.2)
        assert answer.success, answer.message
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from walker_msgs.msg import ControlMode

    # a late subscriber of the usual depth 10 (`ros2 topic echo --once --qos-depth 10`) takes
    # the first message it gets
    first = []
    late = graph.client.node.create_subscription(
        ControlMode, 'control_mode', lambda m: first.append(m) if not first else None,
        QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                   durability=DurabilityPolicy.TRANSIENT_LOCAL))
    graph.wait_for(lambda: bool(first), 30.0, 'the latched control_mode')
    graph.client.node.destroy_subscription(late)
    assert (first[0].mode, first[0].base_gripper) == (ControlMode.HOLD, 'a')
    run = graph.walkerctl('status')
    assert run.returncode == 0, run.stdout + run.stderr
    assert 'controllers  HOLD, roles from gripper a' in run.stdout, run.stdout
