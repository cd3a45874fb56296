"""Faults injected into the running walker, over real DDS in sim time (issue 8).

One graph serves the module: the recorder, the plant, five controllers, the planner and the
supervisor, each a separate process. The tests kill nodes with SIGKILL in the middle of a step,
freeze the plant with SIGSTOP, and send bad inputs over DDS. Every case checks that the fault is
reported (the supervisor's phase reason, ``/diagnostics``, or the refusal itself), that the walker
ends in a safe hold or a completed step, and that an operator can resume without restarting the
graph. Whatever the tests do, the module checks that at least one gripper was attached in every
``gripper_states`` message seen, and that the bag holds every safe hold with its reason and the
gripper states up to the end of the run.

The tests run in file order and share the walker's stance: each fault case takes one step.
"""

import dataclasses
import math
import os
import signal
import time
from pathlib import Path

import pytest

from ros_test_support import (
    SharedMemoryGuard, ros_environment, running_graph)

pytestmark = pytest.mark.integration

TIMEOUT = 300.0  # [s] of wall time for a step (or the rest of one) on a loaded 2-core machine
FAULT_TIMEOUT = 60.0  # [s] wall time for a fault to be noticed and reported
WATCHDOG = 3.0  # [s] steady clock: the supervisor's watchdog (shipped: 1 s)
INPUT_TIMEOUTS = (('control.setpoint_timeout', '2.0'),  # [s] the controllers' (shipped: 0.5 s)
                  ('control.state_timeout', '2.0'))
STILL = 1e-3  # [rad] joints that moved less than this did not move
LINK_INPUT = 'controllers/vertex_joint/setpoint'  # the planner's stream to the vertex joint
LINK_OUTPUT = 'controllers/vertex_joint/setpoint_lossy'  # what the vertex controller reads


class FaultGraph:
    """The running graph, a client, and everything seen on the topics the checks need."""

    def __init__(self, tmp: Path, domain: int) -> None:
        from walker_bringup.graph import NodeSpec, walker_graph
        from walker_bringup.processes import ProcessGroup
        from walker_core.robot_parameters import default_parameter_file, load_walker_parameters

        self.params = load_walker_parameters(default_parameter_file())
        self.bag = tmp / 'bag' / 'faults'
        env = ros_environment(domain)
        # The graph's nodes talk over UDP on loopback only: a participant killed with SIGKILL
        # leaves its Fast DDS shared-memory ports behind, and a node restarted in its place has
        # been seen deaf to the graph (no control mode, no states) over shared memory.
        env['FASTDDS_BUILTIN_TRANSPORTS'] = 'UDPv4'
        self.specs = {spec.name: spec for spec in walker_graph(
            default_parameter_file(), sim_time=True, record=True, bag_path=self.bag)}
        # Timeouts that tolerate a loaded shared machine's pauses (a planning request holds the
        # planner's interpreter, and with it its setpoint stream, for up to a second there): a
        # healthy node is never taken for a dead one, and a dead one is still named within
        # seconds. The shipped values are shorter (README).
        for name, spec in list(self.specs.items()):
            extra = INPUT_TIMEOUTS if name.startswith('controller_') else \
                (('supervisor.watchdog_timeout', str(WATCHDOG)),) if name == 'supervisor' else ()
            self.specs[name] = dataclasses.replace(spec, parameters=(*spec.parameters, *extra))
        # The vertex controller reads its setpoints through a lossy link, lossless until a test
        # sets it to drop, delay or cut
        vertex = self.specs['controller_vertex']
        self.specs['controller_vertex'] = dataclasses.replace(
            vertex, remaps=(*vertex.remaps, (LINK_INPUT, LINK_OUTPUT)))
        self.specs['lossy_link'] = NodeSpec(
            'walker_bringup', 'lossy_link', 'lossy_link', vertex.namespace, vertex.params_file,
            parameters=(('input', LINK_INPUT), ('output', LINK_OUTPUT),
                        ('type', 'walker_msgs/msg/JointCommand'), ('seed', '5')))
        self.group = ProcessGroup(tmp / 'logs', env)
        self.processes = {}
        self.context = None
        self.guard = SharedMemoryGuard(lambda: [os.getpid()] + [
            p.popen.pid for p in self.processes.values() if p.alive], period=0.05).__enter__()
        try:
            self._bring_up(domain)
        except BaseException:
            self.close()
            raise

    def _bring_up(self, domain: int) -> None:
        from diagnostic_msgs.msg import DiagnosticArray
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from sensor_msgs.msg import JointState
        from walker_msgs.msg import GripperStates, StepPhase, StepReport

        from walker_bringup.graph_client import GraphClient, init_context

        self.processes = {name: self.group.start(spec) for name, spec in self.specs.items()}
        self.context = init_context(domain)
        self.client = GraphClient('/walker', self.context)
        node = self.client.node
        self.gripper_states = []
        self.phases = []  # (monotonic time, StepPhase)
        self.diagnostics = []  # (monotonic time, DiagnosticStatus) of the supervisor
        self.positions: dict[str, float] = {}
        reliable = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE,
                              durability=DurabilityPolicy.TRANSIENT_LOCAL)
        node.create_subscription(GripperStates, 'gripper_states', self.gripper_states.append,
                                 reliable)
        node.create_subscription(StepPhase, 'phase',
                                 lambda m: self.phases.append((time.monotonic(), m)), reliable)
        self.step_reports = []
        node.create_subscription(StepReport, 'step_reports', self.step_reports.append, reliable)
        node.create_subscription(DiagnosticArray, '/diagnostics', self._on_diagnostics,
                                 QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE))
        node.create_subscription(
            JointState, 'joint_states',
            lambda m: self.positions.update(zip(m.name, m.position, strict=True)),
            QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT))
        self.client.wait_until_ready([s.full_name for s in self.specs.values()], 180.0,
                                     should_stop=lambda: bool(self.group.poll_deaths()))
        self.wait_until(lambda: self.phase is not None and len(self.positions) == 5, 60.0,
                        'the first phase and joint states')
        if self.phase.phase == 5:  # SAFE_HOLD: the start was slow enough for the watchdog
            self.resume_when_healthy(120.0)
        self.wait_until(lambda: self.phase.phase == 0, 60.0, 'the walker idle')
        self.started = time.monotonic()

    def _on_diagnostics(self, message) -> None:
        for status in message.status:
            if status.name.endswith('supervisor: walker'):
                self.diagnostics.append((time.monotonic(), status))

    def close(self) -> dict:
        if getattr(self, 'client', None) is not None:
            self.client.close()
            self.client = None
        if self.context is not None:
            self.context.try_shutdown()
            self.context = None
        try:
            return self.group.stop_all()
        finally:
            self.guard.__exit__(None, None, None)

    # ------------------------------------------------------------------ waiting
    def wait_until(self, condition, timeout: float, what: str) -> None:
        """Spin until ``condition()`` holds (bounded polling, no sleeps as synchronisation)."""
        deadline = time.monotonic() + timeout
        while not condition():
            assert time.monotonic() < deadline, f'{what}: not within {timeout:.0f} s'
            assert not [p for p in self.group.poll_deaths() if p.popen.returncode != -9], \
                'a node died by itself'
            self.client.spin_for(0.1)

    @property
    def phase(self):
        return self.client.phase

    def wait_phase(self, phase: int, timeout: float, since: float = 0.0):
        """Wait for a phase message (received after ``since``) in ``phase``; return it."""
        found = []

        def seen() -> bool:
            found[:] = [m for t, m in self.phases if t >= since and m.phase == phase]
            return bool(found)

        self.wait_until(seen, timeout, f'phase {phase}')
        return found[0]

    # ------------------------------------------------------------------ the walker's state
    def attached_nodes(self) -> dict:
        """Gripper -> node of the newest gripper states (attached grippers only)."""
        from walker_msgs.msg import GripperState

        self.client.spin_for(0.2)
        newest = self.gripper_states[-1]
        return {g.name: g.node for g in newest.grippers if g.state == GripperState.ATTACHED}

    def joints(self) -> list[float]:
        from walker_core.joint_roles import PHYSICAL_JOINT_NAMES

        self.client.spin_for(0.3)
        return [self.positions[name] for name in PHYSICAL_JOINT_NAMES]

    def one_step(self):
        """Return a step the walker can take now (the supervisor plans the same way)."""
        from walker_core.truss import Truss
        from walker_supervisor.core.route import Stance, possible_steps

        base = self.phase.base_gripper
        other = 'b' if base == 'a' else 'a'
        nodes = self.attached_nodes()
        yaws = (self.positions['a_yaw_joint'], self.positions['b_yaw_joint'])
        drive = self.params.robot.drive.yaw
        steps = possible_steps(Truss.from_parameters(self.params),
                               Stance(base, nodes[base], nodes[other]), yaws,
                               (drive.position_min, drive.position_max))
        steps.sort(key=lambda s: (abs(s.sweep), s.to_node))  # quarter turns first
        return steps[0]

    # ------------------------------------------------------------------ commands
    def start_walk(self, target: str):
        """Send a walk goal and return its handle once accepted (the walk runs on)."""
        from walker_msgs.action import WalkTo

        client = self.client
        assert client.walk_client.wait_for_server(timeout_sec=30.0)
        handle = client._wait(client.walk_client.send_goal_async(WalkTo.Goal(target_node=target)),
                              30.0, None, 'the walk goal')
        assert handle.accepted
        return handle

    def result(self, handle, timeout: float = TIMEOUT):
        return self.client._wait(handle.get_result_async(), timeout, None, 'the walk result')

    def kill(self, name: str) -> None:
        """SIGKILL a node: no clean shutdown, as a crash."""
        process = self.processes[name]
        os.killpg(process.popen.pid, signal.SIGKILL)
        process.popen.wait(timeout=30)

    def restart(self, name: str, ready: str | None = None) -> None:
        """Start a killed node again and wait until its log says ``ready`` (if given)."""
        process = self.processes[name] = self.group.restart(self.processes[name])
        if ready is None:
            return

        def logged() -> bool:
            return ready in process.log_path.read_text(errors='replace').rsplit(
                '--- restarted', 1)[-1]

        self.wait_until(logged, FAULT_TIMEOUT, f'{name} restarted')

    def resume_when_healthy(self, timeout: float = FAULT_TIMEOUT):
        """Call resume until the supervisor accepts it (it refuses while the graph is unwell)."""
        answers = []

        def resumed() -> bool:
            answers.append(self.client.call_trigger('resume', timeout=30.0))
            if not answers[-1].success:
                self.client.spin_for(0.5)
            return answers[-1].success

        self.wait_until(resumed, timeout, f'resume (answers: {[a.message for a in answers]})')
        return answers[-1]

    def resume_and_complete(self, step, attempts: int = 3) -> None:
        """Resume until the interrupted step completes, as an operator would.

        A node restarted a moment ago may not be matched yet with the supervisor's clients: a
        request it never answers ends in safe hold again, and the operator resumes again.
        """
        from walker_msgs.msg import StepPhase

        for _ in range(attempts):
            since = time.monotonic()
            answer = self.resume_when_healthy()
            if 'ready for a step' in answer.message:  # it had got as far as screwing in
                self.complete_step(step, since)
                return
            assert step.to_node in answer.message, answer.message
            # moving, or held again at once (a motion refused before its phase was published)
            moving = self.wait_phase_in(
                (StepPhase.EXTRACTION, StepPhase.FINE, StepPhase.SAFE_HOLD), TIMEOUT, since)
            if self.last_phase.phase != StepPhase.SAFE_HOLD:
                self.wait_phase_in((StepPhase.IDLE, StepPhase.SAFE_HOLD), TIMEOUT, moving)
            if self.last_phase.phase == StepPhase.IDLE:
                self.complete_step(step, since)
                return
            self.client.spin_for(2.0)  # an operator's pause before trying again
        raise AssertionError(f'the step did not complete after {attempts} resumes: '
                             f'{self.last_phase.reason}')

    def wait_phase_in(self, phases, timeout: float, since: float) -> float:
        """Wait for a phase message in ``phases`` received after ``since``; return its time."""
        found = []

        def seen() -> bool:
            found[:] = [(t, m) for t, m in self.phases if t > since and m.phase in phases]
            return bool(found)

        self.wait_until(seen, timeout, f'a phase in {phases}')
        self.last_phase = found[0][1]
        return found[0][0]

    def gripper_command(self, gripper: str, command: int):
        from walker_msgs.srv import GripperCommand

        client = self.client.gripper_client
        assert client.wait_for_service(timeout_sec=30.0)
        return self.client._wait(client.call_async(GripperCommand.Request(
            gripper=gripper, command=command)), 30.0, None, 'the gripper command')

    def parameters(self, node: str, service: str, request):
        from rcl_interfaces.srv import GetParameters, SetParameters

        kind = {'set_parameters': SetParameters, 'get_parameters': GetParameters}[service]
        client = self.client.node.create_client(kind, f'/walker/{node}/{service}')
        try:
            assert client.wait_for_service(timeout_sec=30.0)
            return self.client._wait(client.call_async(request), 30.0, None, service)
        finally:
            self.client.node.destroy_client(client)

    def complete_step(self, step, since: float) -> None:
        """Wait until the step has ended with its moving gripper screwed in at its target."""
        from walker_msgs.msg import StepPhase

        self.wait_phase(StepPhase.IDLE, TIMEOUT, since)
        self.wait_until(lambda: self.attached_nodes().get(step.moving_gripper) == step.to_node,
                        30.0, f'gripper {step.moving_gripper} attached in {step.to_node}')
        assert set(self.attached_nodes()) == {'a', 'b'}
        assert self.phase.phase == StepPhase.IDLE and self.phase.base_gripper \
            == step.moving_gripper


@pytest.fixture(scope='module')
def graph(tmp_path_factory):
    # every node must stop cleanly: the ones killed were replaced by processes that do
    with running_graph(FaultGraph, tmp_path_factory.mktemp('faults')) as running:
        yield running
    _assert_the_bag_holds_the_faults(running)


def _assert_the_bag_holds_the_faults(graph: FaultGraph) -> None:
    """Check that the bag holds every safe hold seen, with its reason, and the gripper states."""
    from walker_bag.core.bag_reader import read_messages
    from walker_msgs.msg import StepPhase

    recorded = list(read_messages(graph.bag, ['/walker/phase', '/walker/gripper_states']))
    holds_seen = {m.reason for t, m in graph.phases
                  if t > graph.started and m.phase == StepPhase.SAFE_HOLD}
    holds_recorded = {r.message.reason for r in recorded
                      if r.topic == '/walker/phase' and r.message.phase == StepPhase.SAFE_HOLD}
    assert holds_seen and holds_seen <= holds_recorded, holds_seen - holds_recorded
    grippers = [r.message for r in recorded if r.topic == '/walker/gripper_states']
    assert grippers, 'no gripper states in the bag'
    for message in grippers:
        assert [g.name for g in message.grippers if g.state == 2], 'a recorded instant with ' \
            'no gripper attached'  # 2: walker_msgs/GripperState.ATTACHED
    last_seen = graph.gripper_states[-1].header.stamp
    assert max((m.header.stamp.sec, m.header.stamp.nanosec) for m in grippers) >= \
        (last_seen.sec, last_seen.nanosec), 'the bag stops before the last gripper state seen'


def _assert_still(before, after) -> None:
    moved = max(abs(a - b) for a, b in zip(before, after, strict=True))
    assert moved < STILL, f'a joint moved by {moved:.2e} rad'


# ---------------------------------------------------------------------- bad inputs, idle
def test_bad_parameter_updates_are_refused_and_nothing_moves(graph):
    from rcl_interfaces.srv import GetParameters, SetParameters
    from rclpy.parameter import Parameter

    before = graph.joints()
    cases = [  # (node, parameter, bad value, words of the reason)
        ('controller_vertex', 'control.fine.bandwidth', [5.0, 5.0, 5.0, 8.0, 8.0], 'eq (15)'),
        ('controller_vertex', 'control.state_timeout', -1.0, 'state_timeout'),
        ('supervisor', 'supervisor.watchdog_timeout', 1000.0, 'watchdog_timeout'),
        ('supervisor', 'supervisor.insertion_alignment', 0.1, 'insertion_alignment'),
        ('planner', 'gripper.insertion_position_tolerance', 0.5, 'read-only'),
    ]
    for node, name, value, words in cases:
        values = graph.parameters(node, 'get_parameters', GetParameters.Request(names=[name]))
        request = SetParameters.Request(parameters=[Parameter(name, value=value)
                                                    .to_parameter_msg()])
        result = graph.parameters(node, 'set_parameters', request).results[0]
        assert not result.successful, (node, name)
        assert words in result.reason, (node, name, result.reason)
        after = graph.parameters(node, 'get_parameters', GetParameters.Request(names=[name]))
        assert after.values == values.values, f'{node} {name} changed'
    # a value of the wrong type
    request = SetParameters.Request(parameters=[Parameter(
        'supervisor.settle_time', value='long').to_parameter_msg()])
    assert not graph.parameters('supervisor', 'set_parameters', request).results[0].successful
    _assert_still(before, graph.joints())


def test_commands_in_the_wrong_phase_and_malformed_commands_are_refused(graph):
    from action_msgs.msg import GoalStatus
    from walker_msgs.msg import StepPhase
    from walker_msgs.srv import GripperCommand

    before = graph.joints()
    answer = graph.client.call_trigger('resume', timeout=30.0)
    assert not answer.success and 'not in SAFE_HOLD' in answer.message
    for gripper, command, words in [('c', GripperCommand.Request.UNSCREW, 'gripper'),
                                    ('a', 7, 'unknown gripper command'),
                                    ('a', GripperCommand.Request.SCREW_IN, 'ATTACHED')]:
        response = graph.gripper_command(gripper, command)
        assert not response.success and words in response.message, response.message
    # an operator's hold: walks are refused until resume
    since = time.monotonic()
    assert graph.client.call_trigger('hold', timeout=30.0).success
    held = graph.wait_phase(StepPhase.SAFE_HOLD, FAULT_TIMEOUT, since)
    assert 'operator' in held.reason
    status, result = graph.client.walk_to(graph.one_step().to_node, 60.0)
    assert status == GoalStatus.STATUS_ABORTED and 'resume' in result.message
    since = time.monotonic()
    assert graph.client.call_trigger('resume', timeout=30.0).success
    graph.wait_phase(StepPhase.IDLE, FAULT_TIMEOUT, since)
    _assert_still(before, graph.joints())
    assert set(graph.attached_nodes()) == {'a', 'b'}


# ---------------------------------------------------------------------- a node killed mid-step
def test_a_controller_killed_in_coarse_motion_holds_then_rejoins_and_the_step_completes(graph):
    from action_msgs.msg import GoalStatus
    from walker_msgs.msg import StepPhase
    from walker_msgs.srv import GripperCommand

    step = graph.one_step()
    started = time.monotonic()
    handle = graph.start_walk(step.to_node)
    graph.wait_phase(StepPhase.EXTRACTION, TIMEOUT, started)
    # a second goal while a walk runs is refused, the walk goes on
    status, result = graph.client.walk_to(step.to_node, 60.0)
    assert status == GoalStatus.STATUS_ABORTED and 'is running' in result.message
    graph.wait_phase(StepPhase.COARSE, TIMEOUT, started)
    since = time.monotonic()
    graph.kill('controller_vertex')
    held = graph.wait_phase(StepPhase.SAFE_HOLD, FAULT_TIMEOUT, since)
    wrapped = graph.result(handle)
    assert wrapped.status == GoalStatus.STATUS_ABORTED and not wrapped.result.success
    graph.wait_until(lambda: 'vertex_joint' in graph.phase.reason, FAULT_TIMEOUT,
                     'the hold reason names the dead controller')
    assert graph.phase.phase == StepPhase.SAFE_HOLD and held.to_node == step.to_node
    # the free gripper's step is held; the base cannot be released, nothing resumes
    assert graph.attached_nodes() == {step.base_gripper: step.base_node}
    response = graph.gripper_command(step.base_gripper, GripperCommand.Request.UNSCREW)
    assert not response.success and 'interlock' in response.message
    answer = graph.client.call_trigger('resume', timeout=30.0)
    assert not answer.success and 'vertex_joint' in answer.message
    graph.restart('controller_vertex', 'controlling vertex_joint')
    graph.resume_and_complete(step)


def test_the_planner_killed_in_fine_motion_holds_then_rejoins_and_the_step_completes(graph):
    """Also: the walk after a step completed by resume takes a step of its own."""
    from action_msgs.msg import GoalStatus
    from walker_msgs.msg import StepPhase

    step = graph.one_step()
    started = time.monotonic()
    handle = graph.start_walk(step.to_node)
    fine = graph.wait_phase(StepPhase.FINE, TIMEOUT, started)
    assert (fine.from_node, fine.to_node) == (step.from_node, step.to_node)
    since = time.monotonic()
    graph.kill('planner')
    held = graph.wait_phase(StepPhase.SAFE_HOLD, FAULT_TIMEOUT, since)
    assert 'stale' in held.reason or 'planner' in held.reason, held.reason
    wrapped = graph.result(handle)
    assert wrapped.status == GoalStatus.STATUS_ABORTED
    assert graph.attached_nodes() == {step.base_gripper: step.base_node}
    graph.restart('planner', 'planner ready')
    graph.resume_and_complete(step)


def test_the_supervisor_killed_in_insertion_is_restarted_and_completes_the_step(graph):
    from walker_msgs.msg import StepPhase

    step = graph.one_step()
    started = time.monotonic()
    graph.start_walk(step.to_node)
    graph.wait_phase(StepPhase.INSERTION, TIMEOUT, started)
    graph.kill('supervisor')
    since = time.monotonic()
    graph.restart('supervisor')

    def taken_up() -> bool:
        return any(t >= since and m.phase == StepPhase.SAFE_HOLD
                   and 'restarted in the middle of the step' in m.reason
                   for t, m in graph.phases)

    def screwed_in() -> bool:  # the kill came as the screw-in had started: nothing to take up
        return graph.attached_nodes().get(step.moving_gripper) == step.to_node

    graph.wait_until(lambda: taken_up() or screwed_in(), FAULT_TIMEOUT * 2,
                     'the restarted supervisor takes the step up')
    if taken_up():
        graph.resume_and_complete(step)
    else:
        graph.wait_until(lambda: graph.phase.phase == StepPhase.IDLE, FAULT_TIMEOUT,
                         'the restarted supervisor idle')
        assert set(graph.attached_nodes()) == {'a', 'b'}


# ---------------------------------------------------------------------- a jammed insertion
def test_a_jammed_insertion_is_retried_a_bounded_number_of_times_then_held_and_resumed(graph):
    """A fouled thread jams every try: the step ends in safe hold; resume completes it.

    The plant's thread is fouled (``sim.jam_screw_ins``) for as many screw-ins as the
    supervisor tries; the base holds throughout; with the thread clear again, resume completes
    the step.
    """
    from action_msgs.msg import GoalStatus
    from rcl_interfaces.srv import GetParameters, SetParameters
    from rclpy.parameter import Parameter
    from walker_msgs.msg import GripperState, StepPhase

    def plant_jams() -> int:
        answer = graph.parameters('plant', 'get_parameters',
                                  GetParameters.Request(names=['sim.jam_screw_ins']))
        return answer.values[0].integer_value

    attempts = graph.parameters('supervisor', 'get_parameters', GetParameters.Request(
        names=['supervisor.max_insertion_attempts'])).values[0].integer_value
    assert attempts >= 2, 'the bounded retry needs at least two attempts to show'
    injected = SetParameters.Request(parameters=[
        Parameter('sim.jam_screw_ins', value=attempts).to_parameter_msg()])
    assert graph.parameters('plant', 'set_parameters', injected).results[0].successful
    assert plant_jams() == attempts
    step = graph.one_step()
    started = time.monotonic()
    handle = graph.start_walk(step.to_node)
    held = graph.wait_phase(StepPhase.SAFE_HOLD, TIMEOUT, started)
    assert f'insertion jammed {attempts} times' in held.reason, held.reason
    assert 'fouled' in held.reason, held.reason
    wrapped = graph.result(handle)
    assert wrapped.status == GoalStatus.STATUS_ABORTED and not wrapped.result.success
    report = graph.step_reports[-1]
    assert not report.success and report.insertion_attempts == attempts, report
    assert plant_jams() == 0, 'each jam counts the injected fault down'
    # the base holds the walker; the jammed gripper is free, never screwed in
    assert graph.attached_nodes() == {step.base_gripper: step.base_node}
    moving = [g for message in graph.gripper_states for g in message.grippers
              if g.name == step.moving_gripper]
    assert any(g.state == GripperState.JAMMED and g.node == step.to_node for g in moving)
    graph.resume_and_complete(step)


# ---------------------------------------------------------------------- a lossy link
def test_a_lossy_late_setpoint_link_still_walks_and_a_cut_one_holds_then_resumes(graph):
    """Dropped and late setpoints cost accuracy, not safety; a cut stream holds the walker.

    The vertex joint's setpoints pass through the lossy link. With a third of them dropped and
    the rest 20-30 ms late, a step completes. Cut (every setpoint dropped) in fine motion, the
    controller's setpoint watchdog holds the joint and the supervisor holds the walker, naming
    the joint; restored, resume completes the step.
    """
    from action_msgs.msg import GoalStatus
    from walker_msgs.msg import StepPhase

    def link(**settings) -> None:
        from rcl_interfaces.srv import SetParameters
        from rclpy.parameter import Parameter

        request = SetParameters.Request(parameters=[
            Parameter(name, value=value).to_parameter_msg() for name, value in settings.items()])
        results = graph.parameters('lossy_link', 'set_parameters', request).results
        assert all(r.successful for r in results), [r.reason for r in results]

    link(drop_probability=0.3, delay=0.02, jitter=0.01)
    try:
        step = graph.one_step()
        status, result = graph.client.walk_to(step.to_node, TIMEOUT)
        assert status == GoalStatus.STATUS_SUCCEEDED and result.success, result.message
    finally:
        link(drop_probability=0.0, delay=0.0, jitter=0.0)
    assert graph.attached_nodes().get(step.moving_gripper) == step.to_node
    log = graph.processes['lossy_link'].log_path.read_text()
    assert ' dropped ' in log and not log.rsplit('received, ', 1)[-1].startswith('0 dropped')

    step = graph.one_step()
    started = time.monotonic()
    handle = graph.start_walk(step.to_node)
    graph.wait_phase(StepPhase.FINE, TIMEOUT, started)
    since = time.monotonic()
    link(drop_probability=1.0)
    try:
        held = graph.wait_phase(StepPhase.SAFE_HOLD, FAULT_TIMEOUT, since)
        graph.wait_until(lambda: 'vertex_joint' in graph.phase.reason, FAULT_TIMEOUT,
                         'the hold reason names the joint whose setpoints stopped')
        assert graph.attached_nodes() == {step.base_gripper: step.base_node}, held.reason
        wrapped = graph.result(handle)
        assert wrapped.status == GoalStatus.STATUS_ABORTED
    finally:
        link(drop_probability=0.0)
    graph.resume_and_complete(step)


# ---------------------------------------------------------------------- a silent publisher
def test_a_frozen_plant_is_reported_and_the_walker_resumes_when_it_is_back(graph):
    from walker_msgs.msg import StepPhase

    step = graph.one_step()
    started = time.monotonic()
    graph.start_walk(step.to_node)
    graph.wait_phase(StepPhase.FINE, TIMEOUT, started)
    plant = graph.processes['plant'].popen.pid
    since = time.monotonic()
    os.killpg(plant, signal.SIGSTOP)
    try:
        graph.wait_phase(StepPhase.SAFE_HOLD, FAULT_TIMEOUT, since)
        graph.wait_until(
            lambda: any(t > since and 'plant joint states: silent' in s.message
                        or any('plant joint states' == v.key and 'silent' in v.value
                               for v in s.values)
                        for t, s in graph.diagnostics),
            FAULT_TIMEOUT, 'the diagnostics name the silent plant')
        answer = graph.client.call_trigger('resume', timeout=30.0)
        assert not answer.success and 'plant' in answer.message
    finally:
        os.killpg(plant, signal.SIGCONT)
    graph.resume_and_complete(step)
    assert math.isfinite(sum(graph.joints()))
