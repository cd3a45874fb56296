"""The fault-injection graph: the whole walker over DDS in sim time, and what the checks need.

The graph is a walk session's (:mod:`walker_bringup.session`); this module holds what is the
fault tests' own. Shared by the fault suite (``tests/integration/test_faults.py``) and the
fault matrix (``tests/fault_matrix/``): the recorder, the plant, five controllers (the vertex
one reading the planner's motions through a ``lossy_link``, lossless until a test degrades it:
its whole trajectories, or with ``planner.send_whole_trajectories`` false its setpoint stream),
the planner and the supervisor, each a separate process, with timeouts that tolerate a loaded
machine; a client that keeps every phase, gripper state, step report and supervisor
diagnostic seen; and the operations a test needs (a step, a kill, a restart, a resume until
the step completes).
"""

import contextlib
import dataclasses
import json
import os
import signal
import sys
import tempfile
import time
from pathlib import Path

from ros_test_support import SharedMemoryGuard, log_tails

__all__ = ['FaultGraph', 'assert_the_bag_holds_the_faults', 'write_outcomes', 'TIMEOUT',
           'TEST_TIMEOUT', 'lossy_link_options', 'LOADED_MACHINE_TIMEOUTS', 'STARTUP_TIMEOUT',
           'FAULT_TIMEOUT', 'WATCHDOG', 'INPUT_TIMEOUTS', 'STILL', 'LossyInput',
           'TRAJECTORY_LINK', 'SETPOINT_LINK']

TIMEOUT = 300.0  # [s] of wall time for a step (or the rest of one) on a loaded 2-core machine
#: [s] pytest's limit for a test on this graph: above its waits' own, so that a wait that is
#: not met fails with what it waited for (the project's default limit is TIMEOUT)
TEST_TIMEOUT = 3 * TIMEOUT
FAULT_TIMEOUT = 60.0  # [s] wall time for a fault to be noticed and reported
WATCHDOG = 3.0  # [s] steady clock: the supervisor's watchdog (shipped: 1 s)
INPUT_TIMEOUTS = (('control.setpoint_timeout', '2.0'),  # [s] the controllers' (shipped: 0.5 s)
                  ('control.state_timeout', '2.0'))
STILL = 1e-3  # [rad] joints that moved less than this did not move
STARTUP_TIMEOUT = 180.0  # [s] of wall time for the graph to come up on a loaded machine
# Timeouts that tolerate a loaded shared machine's pauses (a planning request holds the
# planner's interpreter, and with it its setpoint stream, for up to a second there): a healthy
# node is never taken for a dead one, and a dead one is still named within seconds. The
# shipped values are shorter (docs/faults.md). (node pattern, parameter, value)
LOADED_MACHINE_TIMEOUTS = (*(('controller*', name, value) for name, value in INPUT_TIMEOUTS),
                           ('supervisor', 'supervisor.watchdog_timeout', str(WATCHDOG)))




@dataclasses.dataclass(frozen=True)
class LossyInput:
    """The vertex controller's input from the planner that the lossy link sits on."""

    topic: str  # what the planner publishes
    lossy: str  # what the vertex controller reads instead
    type: str  # the message type of both


#: the planner's whole trajectories (to every controller; the vertex one reads them lossy)
TRAJECTORY_LINK = LossyInput('controllers/joint_trajectory', 'controllers/joint_trajectory_lossy',
                             'trajectory_msgs/msg/JointTrajectory')
#: the planner's setpoint stream to the vertex joint (``planner.send_whole_trajectories`` false)
SETPOINT_LINK = LossyInput('controllers/vertex_joint/setpoint',
                           'controllers/vertex_joint/setpoint_lossy',
                           'walker_msgs/msg/JointCommand')


def lossy_link_options(params_file: Path, link: LossyInput) -> dict:
    """Return the session options of the lossy link the vertex controller reads through.

    A ``lossy_link`` node between the planner's ``link`` to the vertex joint and the vertex
    controller (remapped to read its output), lossless until a test sets it to drop, delay or
    cut.
    """
    from walker_bringup.graph import NodeSpec

    node = NodeSpec('walker_bringup', 'lossy_link', 'lossy_link', '/walker', str(params_file),
                    parameters=(('input', link.topic), ('output', link.lossy),
                                ('type', link.type), ('seed', '5')))
    return {'extra_nodes': (node,), 'remaps': (('controller_vertex', link.topic, link.lossy),)}


class FaultGraph:
    """The running graph, a client, and everything seen on the topics the checks need.

    A walk session's graph (:mod:`walker_bringup.session`) in the domain ``domain``, output
    in ``tmp``; what is the fault tests' own is given to it as options: the lossy link and
    the vertex controller's remap to it, the longer timeouts, no restarts (a test kills and
    restarts nodes itself), and pytest's signal handlers left in place. With ``grouped``, the
    five joint controllers run as one node (``controllers``, one process; ``run_all.py
    --grouped-controllers``) and there is no lossy link. ``parameters`` are given to every node
    (``-p`` overrides), e.g. ``(('sim.wait_for_decisions', 'true'),)``.
    """

    def __init__(self, tmp: Path, domain: int, grouped: bool = False,
                 parameters: tuple[tuple[str, str], ...] = ()) -> None:
        from walker_bringup.core.respawn import RespawnPolicy
        from walker_bringup.domains import domain_environment
        from walker_bringup.processes import STOP_TIMEOUT
        from walker_bringup.session import Arrangement, SessionOptions, WalkSession
        from walker_config.core.configuration import load_configuration
        from walker_core.parameter_schema import load_parameter_file
        from walker_core.progress import ProgressLine

        configuration = load_configuration()
        self.params = configuration.walker
        whole = dict(parameters).get('planner.send_whole_trajectories', str(load_parameter_file(
            configuration.path)['planner.send_whole_trajectories']))
        #: the planner sends whole trajectories (else it streams setpoints)
        self.whole_trajectories = whole.lower() == 'true'
        self.link = TRAJECTORY_LINK if self.whole_trajectories else SETPOINT_LINK
        self.bag = tmp / 'bag'
        self.processes = {}
        self.killed: set[str] = set()  # nodes killed by the test and not restarted since
        self.client = None
        self.session = WalkSession(configuration, SessionOptions(
            arrangement=Arrangement.GROUPED if grouped else Arrangement.PROCESSES,
            sim_time=True, record=True, report=False, out=tmp, respawn=RespawnPolicy(limit=0),
            startup_timeout=STARTUP_TIMEOUT, quiet=True, overrides=tuple(parameters),
            # The graph's nodes are reached over UDP on loopback only: a participant killed
            # with SIGKILL leaves its Fast DDS shared-memory ports behind, and a node restarted
            # in its place has been seen deaf to the graph over them (walker_bringup.transport).
            transport='udp', node_parameters=LOADED_MACHINE_TIMEOUTS,
            **({} if grouped else lossy_link_options(configuration.path, self.link)),
            stop_timeout=STOP_TIMEOUT, handle_signals=False),
            ProgressLine(True, stream=sys.stderr), on_client=self._subscribe)
        self._environment = contextlib.ExitStack()
        # the domain and a ROS home of the graph's own (the supervisor's step file stays apart
        # from every other graph's), given back when the graph is closed
        self._environment.enter_context(domain_environment(
            domain, Path(tempfile.mkdtemp(prefix=f'walker-ros-home-{domain}-')),
            PYTHONUNBUFFERED='1'))
        self.guard = SharedMemoryGuard(lambda: [os.getpid()] + [
            p.popen.pid for w in self.session.backend.walkers for p in w.group.processes
            if p.alive], period=0.05).__enter__()
        try:
            self._bring_up()
        except BaseException:
            self.close()
            raise

    @property
    def group(self):
        """The graph's :class:`~walker_bringup.processes.ProcessGroup`."""
        return self.session.backend.walkers[0].group

    def _subscribe(self, client) -> None:
        """Keep every message the checks need, from the graph's start on."""
        from diagnostic_msgs.msg import DiagnosticArray
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from sensor_msgs.msg import JointState
        from walker_msgs.msg import GripperStates, StepPhase, StepReport

        self.client = client
        node = client.node
        self.gripper_states = []
        self.phases = []  # (monotonic time, StepPhase)
        self.walk_handle = None  # the last walk goal sent, until its result is known
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

    def _bring_up(self) -> None:
        self.session.start()
        self.processes = {p.spec.name: p for p in self.group.processes}
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
        """Stop the graph; return each node's exit code (killed and not restarted: left out)."""
        try:
            self.session.stop()
        finally:
            self.client = None
            self.guard.__exit__(None, None, None)
            self._environment.close()
        # a node the test killed and a failure kept it from restarting is no unclean exit:
        # the failure is reported as itself, not again at teardown
        return {name: code for name, code in self.session.exit_codes.items()
                if not (name in self.killed and code == -signal.SIGKILL)}

    # ------------------------------------------------------------------ waiting
    def wait_until(self, condition, timeout: float, what: str) -> None:
        """Spin until ``condition()`` holds (bounded polling, no sleeps as synchronisation)."""
        deadline = time.monotonic() + timeout
        while not condition():
            assert time.monotonic() < deadline, \
                f'{what() if callable(what) else what}: not within {timeout:.0f} s'
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
        assert set(nodes) == {'a', 'b'}, (
            f'the walker is not at rest on both grippers (attached: {nodes}; phase '
            f'{self.phase.phase}: {self.phase.reason!r}): an earlier test on this graph left '
            f'its step unfinished')
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
        self.walk_handle = handle
        return handle

    def result(self, handle, timeout: float = TIMEOUT):
        return self.client._wait(handle.get_result_async(), timeout, None, 'the walk result')

    def kill(self, name: str) -> None:
        """SIGKILL a node: no clean shutdown, as a crash."""
        process = self.processes[name]
        os.killpg(process.popen.pid, signal.SIGKILL)
        process.popen.wait(timeout=30)
        self.killed.add(name)
        if name == 'supervisor':  # its walk goal died with it: no result will come
            self.walk_handle = None

    def restart(self, name: str, ready: str | None = None) -> None:
        """Start a killed node again and wait until its log says ``ready`` (if given)."""
        process = self.processes[name] = self.group.restart(self.processes[name])
        self.killed.discard(name)
        if ready is None:
            return

        def logged() -> bool:
            return ready in process.log_path.read_text(errors='replace').rsplit(
                '--- restarted', 1)[-1]

        self.wait_until(logged, FAULT_TIMEOUT, f'{name} restarted')

    def fail_in_phase(self, name: str, phase: str, freeze: bool = False,
                      ready: str | None = None) -> dict:
        """Take a step, fail node ``name`` in ``phase``, and see the step through; the outcome.

        The node is killed (SIGKILL) and started again (waiting for ``ready`` in its log), or,
        with ``freeze``, stopped (SIGSTOP) until the walker holds, then continued. The walker
        must hold with a reason, or complete the step by itself where the fault came too late
        to matter; a held step is resumed until it completes. Both grippers end attached.
        """
        from walker_msgs.msg import StepPhase

        step = self.one_step()
        started = time.monotonic()
        self.start_walk(step.to_node)
        self.wait_phase(getattr(StepPhase, phase), TIMEOUT, started)
        since = time.monotonic()
        if freeze:
            pid = self.processes[name].popen.pid
            os.killpg(pid, signal.SIGSTOP)
            try:
                self.wait_phase(StepPhase.SAFE_HOLD, FAULT_TIMEOUT, since)
            finally:
                os.killpg(pid, signal.SIGCONT)
        else:
            self.kill(name)
            self.restart(name, ready)
        # held (with a reason), or the step got as far as screwing in and ended by itself
        self.wait_phase_in((StepPhase.SAFE_HOLD, StepPhase.IDLE), FAULT_TIMEOUT * 2, since)
        first = self.last_phase
        assert first.phase == StepPhase.IDLE or first.reason, 'a safe hold without a reason'
        resumes = 0
        if first.phase == StepPhase.SAFE_HOLD:
            resumes = self.resume_and_complete(step)
        else:
            self.complete_step(step, since)
        assert set(self.attached_nodes()) == {'a', 'b'}
        return {'node': name, 'phase': phase,
                'outcome': 'held' if first.phase == StepPhase.SAFE_HOLD else 'completed',
                'reason': first.reason, 'resumes': resumes,
                'wall_s': round(time.monotonic() - since, 1)}

    def resume_when_healthy(self, timeout: float = FAULT_TIMEOUT):
        """Call resume until the supervisor accepts it (it refuses while the graph is unwell)."""
        answers = []

        def resumed() -> bool:
            answers.append(self.client.call_trigger('resume', timeout=30.0))
            if not answers[-1].success:
                self.client.spin_for(0.5)
            return answers[-1].success

        self.wait_until(resumed, timeout, lambda: f'resume (answers: '
                        f'{[a.message for a in answers]})')
        return answers[-1]

    def resume_and_complete(self, step, attempts: int = 3) -> int:
        """Resume until the interrupted step completes, as an operator would; return how often.

        A node restarted a moment ago may not be matched yet with the supervisor's clients: a
        request it never answers ends in safe hold again, and the operator resumes again. A
        planner that answers none is asked where it stands (:meth:`probe`), for the failure.
        """
        from walker_msgs.msg import StepPhase

        probes = []
        for attempt in range(1, attempts + 1):
            since = time.monotonic()
            answer = self.resume_when_healthy()
            if 'ready for a step' in answer.message:  # it had got as far as screwing in
                self.complete_step(step, since)
                return attempt
            assert step.to_node in answer.message, answer.message
            # the supervisor publishes the phase a resume enters at once (a SAFE_HOLD seen
            # first would be the old hold, published again as the walk it stopped ended)
            moving = self.wait_phase_in((StepPhase.EXTRACTION, StepPhase.FINE), TIMEOUT, since)
            self.wait_phase_in((StepPhase.IDLE, StepPhase.SAFE_HOLD), TIMEOUT, moving,
                               tails=('supervisor', 'planner'))
            if self.last_phase.phase == StepPhase.IDLE:
                self.complete_step(step, since)
                return attempt
            if 'planner answered no' in self.last_phase.reason:
                probes.append(self.probe('planner', 'stop_trajectory')[1])
            self.client.spin_for(2.0)  # an operator's pause before trying again
        tails = self.log_tails('supervisor', 'planner')
        raise AssertionError(f'the step did not complete after {attempts} resumes: '
                             f'{self.last_phase.reason}\n{tails}\n' + '\n'.join(probes))

    def probe(self, name: str, trigger: str) -> tuple[bool, str]:
        """Ask node ``name`` where it stands: its threads, its stacks, a call to ``trigger``.

        For a node that has stopped answering: the state and kernel wait of each of its threads
        (``/proc``), a call of its ``Trigger`` service ``trigger`` from this process's client,
        and the Python stack of every thread, which the node writes to its log on ``SIGUSR1``.
        Returns whether the call was answered, and the report.
        """
        from std_srvs.srv import Trigger

        from walker_runtime.spinning import STACK_DUMP_SIGNAL

        pid = self.processes[name].popen.pid
        threads = []
        for task in sorted(Path(f'/proc/{pid}/task').glob('*')):
            try:
                stat = (task / 'stat').read_text()
                wchan = (task / 'wchan').read_text()
            except OSError:
                continue
            comm, rest = stat[stat.index('(') + 1:stat.rindex(')')], stat[stat.rindex(')') + 2:]
            threads.append(f'{task.name} {comm} {rest.split()[0]} {wchan}')
        calls = []
        for _ in range(3):  # the first call of a new client can be lost (as the supervisor's)
            client = self.client.node.create_client(Trigger, trigger)
            try:
                ready = client.wait_for_service(timeout_sec=5.0)
                future = client.call_async(Trigger.Request())
                deadline = time.monotonic() + 5.0
                while not future.done() and time.monotonic() < deadline:
                    self.client.spin_for(0.1)
            finally:
                self.client.node.destroy_client(client)
            calls.append(f'discovered {ready}, ' + (repr(future.result().message)
                                                   if future.done() else 'no answer in 5 s'))
            if future.done():
                break
        os.kill(pid, STACK_DUMP_SIGNAL)
        self.client.spin_for(1.0)
        return future.done(), (f'--- {name} (pid {pid}): {trigger} calls, each over a new '
                               f'client: {calls}\n'
                               f'threads (tid name state wchan): {threads}\n'
                               f'{self.log_tails(name)}')

    def log_tails(self, *names: str) -> str:
        """Return the end of the named nodes' logs, for a failure message."""
        return log_tails(self.group, list(names))

    def streams_refused_for_moved_joints(self) -> int:
        """How often the supervisor's log says a stream was refused: the joints had moved away.

        A resume plans from the measured joints; the planner refuses a stream that starts
        farther from them than ``planner.stream.start_tolerance``.
        """
        return self.count_in_log('supervisor', 'away from the measured')

    def count_in_log(self, name: str, text: str) -> int:
        """How often ``text`` appears in the log of the node ``name`` so far."""
        return log_tails(self.group, [name], 100_000).count(text)

    def wait_step_end(self, since: float):
        """Wait for a step started after ``since`` to end; return its last phase message.

        The step has begun once EXTRACTION is seen; it ends in IDLE (completed) or SAFE_HOLD.
        A test expecting one fails at once on the other, with its reason, instead of waiting.
        """
        from walker_msgs.msg import StepPhase

        began = self.wait_phase_in((StepPhase.EXTRACTION,), TIMEOUT, since)
        self.wait_phase_in((StepPhase.IDLE, StepPhase.SAFE_HOLD), TIMEOUT, began)
        return self.last_phase

    def wait_phase_in(self, phases, timeout: float, since: float, tails=()) -> float:
        """Wait for a phase message in ``phases`` received after ``since``; return its time.

        A timeout names the phase last seen and the end of the logs of the nodes in ``tails``.
        """
        found = []

        def seen() -> bool:
            found[:] = [(t, m) for t, m in self.phases if t > since and m.phase in phases]
            return bool(found)

        def what() -> str:
            last = self.phases[-1][1] if self.phases else None
            return (f'a phase in {phases} (last seen: '
                    f'{(last.phase, last.reason) if last else None})'
                    + (f'\n{self.log_tails(*tails)}' if tails else ''))

        self.wait_until(seen, timeout, what)
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
        # The phase is IDLE once the gripper is screwed in; a walk that got that far ends
        # only after the joints' relaxation under the new base, and until then the next walk
        # would be refused: wait for its result
        if self.walk_handle is not None:
            self.result(self.walk_handle, 60.0)
            self.walk_handle = None


def assert_the_bag_holds_the_faults(graph: FaultGraph, some_hold: bool = True) -> None:
    """Check that the bag holds every safe hold seen, with its reason, and the gripper states.

    With ``some_hold`` the graph must have seen a safe hold (its faults could not all be
    survived without one).
    """
    from walker_bag.core.bag_reader import read_messages
    from walker_msgs.msg import StepPhase

    # the history: every phase, also those published before the recorder matched
    recorded = list(read_messages(graph.bag, ['/walker/phase_history',
                                              '/walker/gripper_states']))
    holds_seen = {m.reason for t, m in graph.phases
                  if t > graph.started and m.phase == StepPhase.SAFE_HOLD}
    holds_recorded = {r.message.reason for r in recorded
                      if r.topic == '/walker/phase_history'
                      and r.message.phase == StepPhase.SAFE_HOLD}
    assert holds_seen or not some_hold, 'no safe hold seen'
    assert holds_seen <= holds_recorded, holds_seen - holds_recorded
    grippers = [r.message for r in recorded if r.topic == '/walker/gripper_states']
    assert grippers, 'no gripper states in the bag'
    for message in grippers:
        assert [g.name for g in message.grippers if g.state == 2], 'a recorded instant with ' \
            'no gripper attached'  # 2: walker_msgs/GripperState.ATTACHED
    last_seen = graph.gripper_states[-1].header.stamp
    assert max((m.header.stamp.sec, m.header.stamp.nanosec) for m in grippers) >= \
        (last_seen.sec, last_seen.nanosec), 'the bag stops before the last gripper state seen'


def write_outcomes(path: Path, outcomes: list[dict]) -> None:
    """Write the cases' outcomes (:meth:`FaultGraph.fail_in_phase`) to ``path`` and print them."""
    path.write_text(json.dumps(outcomes, indent=1))
    print('\nnode        phase       outcome     resumes  wall [s]  reason')
    for row in outcomes:
        print(f'{row["node"]:<11} {row["phase"]:<11} {row["outcome"]:<11} '
              f'{row["resumes"]:>7}  {row["wall_s"]:>8.1f}  {row["reason"][:70]}')
