"""The walk end to end over real DDS, in sim time: the whole graph as separate processes.

One graph serves the module (bringing it up takes seconds, a step tens of seconds of wall time).
Every ``gripper_states`` message the plant publishes during the module is checked: at least one
gripper is attached at every published state, whatever the test does.
"""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from ros_test_support import (
    REPO_ROOT, isolated_domain, processes_with, ros_environment, running_graph)

WALK_TIMEOUT = 600.0  # [s] of wall time for a walk on a loaded 2-core machine

# above the walk's own limit, so that a walk that does not end fails as itself
pytestmark = [pytest.mark.integration, pytest.mark.timeout(WALK_TIMEOUT + 300.0)]


class Graph:
    """The running graph, a client, and every gripper state seen."""

    def __init__(self, tmp: Path, domain: int) -> None:
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from sensor_msgs.msg import JointState
        from walker_msgs.msg import GripperStates, StepPhase

        from walker_bringup.graph import walker_graph
        from walker_bringup.graph_client import GraphClient, init_context
        from walker_bringup.processes import ProcessGroup
        from walker_core.robot_parameters import default_parameter_file

        env = ros_environment(domain)
        self.domain = domain
        self.nodes = walker_graph(default_parameter_file(), sim_time=True)
        self.group = ProcessGroup(tmp / 'logs', env)
        for spec in self.nodes:
            self.group.start(spec)
        self.context = init_context(domain)
        self.client = GraphClient('/walker', self.context)
        self.gripper_states = []
        self.joint_states = []
        self.phases = []
        qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.client.node.create_subscription(GripperStates, 'gripper_states',
                                             self.gripper_states.append, qos)
        # every phase message of the walk: the history (``phase`` gives the phase now)
        self.client.node.create_subscription(StepPhase, 'phase_history', self.phases.append,
                                             qos)
        self.client.node.create_subscription(
            JointState, 'joint_states', lambda m: self.joint_states.append(list(m.position)),
            QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT))
        try:
            self.client.wait_until_ready([n.full_name for n in self.nodes], 120.0,
                                         should_stop=lambda: bool(self.group.poll_deaths()))
        except BaseException:
            self.close()  # a graph that never came up leaves no process behind
            raise

    def close(self) -> dict:
        self.client.close()
        self.context.try_shutdown()
        return self.group.stop_all()

    def attached_nodes(self) -> dict:
        """Gripper -> node of the newest gripper states (attached grippers only)."""
        from walker_msgs.msg import GripperState

        newest = self.gripper_states[-1]
        return {g.name: g.node for g in newest.grippers if g.state == GripperState.ATTACHED}

    def latest_positions(self):
        self.client.spin_for(0.3)
        return self.joint_states[-1]


@pytest.fixture(scope='module')
def graph(tmp_path_factory):
    with running_graph(Graph, tmp_path_factory.mktemp('walk')) as running:
        yield running


@pytest.mark.parametrize('action, target, words', [
    ('walk_to', 'n99_99', 'not on the truss'),
    ('walk_to', 'node7', 'not a node name'),
    ('walk_to', 'n4_03', 'not a node name'),  # not n4_3 in another spelling
    ('step', 'n4_3\n', 'not a node name'),
    ('step', 'n4_3', 'not one step away'),
])
def test_unknown_and_unreachable_targets_are_rejected_at_goal_time_with_the_reason(
        graph, action, target, words):
    from walker_bringup.graph_client import GoalRejectedError

    before = graph.latest_positions()
    send = graph.client.walk_to if action == 'walk_to' else graph.client.step
    with pytest.raises(GoalRejectedError) as rejected:  # rejected, not accepted and aborted
        send(target, 30.0)
    assert words in rejected.value.reason, rejected.value.reason
    assert (rejected.value.action, rejected.value.target) == (action, target)
    after = graph.latest_positions()
    assert max(abs(a - b) for a, b in zip(before, after, strict=True)) < 1e-4, 'the arm moved'
    assert set(graph.attached_nodes()) == {'a', 'b'}


def test_a_three_step_walk_with_quarter_and_half_turns_reaches_its_target(graph):
    import math

    reports_before = len(graph.client.reports)
    phases_before = len(graph.phases)
    # From the start stance (gripper a in n1_1, b in n2_1, J1 at -pi/2) three steps reach
    # n3_2: two quarter turns and a half turn (other routes would wind the yaws too far).
    status, result = graph.client.walk_to('n3_2', WALK_TIMEOUT)
    graph.client.spin_for(1.0)
    assert result.success, result.message
    assert result.steps_taken == 3 and list(result.path) == ['n1_2', 'n2_2', 'n3_2']
    reports = graph.client.reports[reports_before:]
    assert [r.success for r in reports] == [True, True, True]
    sweeps = sorted(abs(round(math.degrees(r.sweep))) for r in reports)
    assert sweeps == [90, 90, 180]
    tolerance = 0.002  # gripper.insertion_position_tolerance of the parameter file [m]
    assert all(r.insertion_error < tolerance for r in reports)
    # and the tip is still at the mouth when the screw-in starts: it rings less than that
    assert all(r.residual_vibration < tolerance for r in reports), \
        [r.residual_vibration for r in reports]
    assert all(r.time_optimal_bound > 0 and r.duration > r.time_optimal_bound for r in reports)
    assert 'n3_2' in graph.attached_nodes().values()
    assert set(graph.attached_nodes()) == {'a', 'b'}
    _assert_the_phase_progress_grows_through_each_phase(graph.phases[phases_before:], 3)
    # the plant's record of the loop reaches the client (run_all.py prints it): lock-stepped
    loop = graph.client.loop
    assert loop is not None and loop.clock_mode == 'sim_time', loop
    assert loop.plant_time > sum(r.duration for r in reports) and loop.lockstep_timeouts == 0
    assert set(loop.late_efforts) == {'a_yaw_joint', 'a_pitch_joint', 'vertex_joint',
                                      'b_pitch_joint', 'b_yaw_joint'}
    assert loop.summary(500.0).startswith('loop: lock-stepped in sim time')


def _assert_the_phase_progress_grows_through_each_phase(phases, steps):
    """Every phase of every step is published with a progress that grows towards 1.

    EXTRACTION, COARSE and INSERTION are timed against their plans: each is published again
    as it advances (by quarters) and reaches at least three quarters; FINE goes by the tip error.
    """
    from walker_msgs.msg import StepPhase

    runs = {}
    for message in phases:
        if message.phase in (StepPhase.IDLE, StepPhase.SAFE_HOLD):
            assert message.phase_progress == 0.0
            continue
        runs.setdefault((message.step_index, message.phase), []).append(message.phase_progress)
    timed = (StepPhase.EXTRACTION, StepPhase.COARSE, StepPhase.INSERTION)
    assert {key for key in runs if key[1] in timed} == {
        (index, phase) for index in range(steps) for phase in timed}
    for (index, phase), values in runs.items():
        assert values == sorted(values) and 0.0 <= values[0] and values[-1] <= 1.0, \
            (index, phase, values)
        if phase in timed:
            assert len(values) >= 4 and values[-1] >= 0.75, (index, phase, values)


def test_a_cancelled_walk_finishes_its_step_and_ends_attached(graph):
    from action_msgs.msg import GoalStatus
    from walker_msgs.action import WalkTo
    from walker_msgs.msg import StepPhase

    client = graph.client
    handle = client._wait(client.walk_client.send_goal_async(WalkTo.Goal(target_node='n0_0')),
                          30.0, None, 'the walk goal')
    assert handle.accepted
    deadline = time.monotonic() + WALK_TIMEOUT
    while not (client.phase is not None and client.phase.phase == StepPhase.COARSE):
        assert time.monotonic() < deadline, 'the walk never reached its coarse motion'
        client.spin_for(0.1)
    client._wait(handle.cancel_goal_async(), 30.0, None, 'the cancel request')
    wrapped = client._wait(handle.get_result_async(), WALK_TIMEOUT, None, 'the cancelled walk')
    assert wrapped.status == GoalStatus.STATUS_CANCELED
    assert wrapped.result.steps_taken == 1, 'the step under way finishes, no other starts'
    client.spin_for(1.0)
    assert set(graph.attached_nodes()) == {'a', 'b'}
    assert client.phase.phase == StepPhase.IDLE


def test_a_late_subscriber_to_the_phase_gets_the_phase_now_and_the_history_has_the_rest(graph):
    """A late joiner of ``phase`` (``ros2 topic echo --once``) gets the phase now.

    ``phase`` is latched with depth 1, not a history whose old messages come first;
    ``phase_history`` keeps the recent ones, the newest last.
    """
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from walker_msgs.msg import StepPhase

    graph.client.spin_for(1.0)
    now = graph.client.phase
    assert now is not None and now.phase == StepPhase.IDLE
    late, history = [], []
    qos = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
    node = graph.client.node
    subscriptions = [node.create_subscription(StepPhase, 'phase', late.append, qos),
                     node.create_subscription(StepPhase, 'phase_history', history.append, qos)]
    try:
        graph.client.spin_for(3.0)
    finally:
        for subscription in subscriptions:
            node.destroy_subscription(subscription)
    assert len(late) == 1, [(m.phase, m.step_index) for m in late]
    assert (late[0].phase, late[0].base_gripper, late[0].header.stamp) == (
        now.phase, now.base_gripper, now.header.stamp)
    assert len(history) > 1 and history[-1].header.stamp == now.header.stamp
    assert {StepPhase.EXTRACTION, StepPhase.INSERTION} <= {m.phase for m in history}


def test_run_all_refuses_a_namespace_a_live_graph_already_uses(graph, tmp_path):
    """Two graphs in one namespace would answer each other's goals: nothing is started."""
    args = [sys.executable, str(REPO_ROOT / 'scripts' / 'run_all.py'), '--sim-time',
            '--no-walk', '--no-record', '--out', str(tmp_path / 'run')]
    run = subprocess.run(args, env=ros_environment(graph.domain), capture_output=True,
                         text=True, cwd=REPO_ROOT, timeout=180)
    text = run.stdout + run.stderr
    assert run.returncode == 2, text
    assert f'already running in /walker on ROS domain {graph.domain}' in text
    assert any(node.name in text for node in graph.nodes) and '--namespace' in text
    assert 'starting' not in text, 'nothing may be started'
    assert graph.group.poll_deaths() == []


def test_a_step_reports_its_phase_progress_in_its_feedback(graph):
    """``Step`` feedback carries ``phase_progress`` in [0, 1], as ``phase`` does."""
    from walker_msgs.msg import StepPhase

    from walker_core.robot_parameters import default_parameter_file, load_walker_parameters
    from walker_core.truss import Truss
    from walker_supervisor.core.route import Stance, possible_steps

    params = load_walker_parameters(default_parameter_file())
    base = graph.client.phase.base_gripper
    nodes = graph.attached_nodes()
    positions = graph.latest_positions()
    drive = params.robot.drive.yaw
    step = min(possible_steps(Truss.from_parameters(params),
                              Stance(base, nodes[base], nodes['b' if base == 'a' else 'a']),
                              (positions[0], positions[4]),
                              (drive.position_min, drive.position_max)),
               key=lambda s: (abs(s.sweep), s.to_node))
    feedback = []
    status, result = graph.client.step(step.to_node, WALK_TIMEOUT, feedback.append)
    assert result.success, result.message
    timed = [f for f in feedback if f.phase in (StepPhase.EXTRACTION, StepPhase.COARSE)]
    assert timed and all(0.0 <= f.phase_progress <= 1.0 for f in feedback)
    for phase in (StepPhase.EXTRACTION, StepPhase.COARSE):
        values = [f.phase_progress for f in feedback if f.phase == phase]
        assert values == sorted(values) and values[-1] > 0.5, (phase, values)


@pytest.mark.parametrize('interrupt', [False, True])
def test_run_all_leaves_no_process_behind(tmp_path, interrupt):
    namespace = f'/walker_leak_check_{os.getpid()}_{int(interrupt)}'
    with isolated_domain() as domain:
        env = ros_environment(domain)
        args = [sys.executable, str(REPO_ROOT / 'scripts' / 'run_all.py'), '--sim-time',
                '--namespace', namespace, '--out', str(tmp_path / 'run'), '--no-record']
        args += ['--target', 'n1_2'] if interrupt else ['--no-walk']
        run = subprocess.Popen(args, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                               text=True, cwd=REPO_ROOT)
        output = []
        if interrupt:  # Ctrl-C once the walk has started
            for line in run.stdout:
                output.append(line)
                if 'walking to' in line:
                    run.send_signal(signal.SIGINT)
                    break
        output.append(run.communicate(timeout=180)[0])
        text = ''.join(output)
        assert run.returncode == (130 if interrupt else 0), text
        assert 'all node processes stopped' in text
        assert processes_with(namespace) == [], text
