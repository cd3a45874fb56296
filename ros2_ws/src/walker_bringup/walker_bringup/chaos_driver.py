"""Apply a chaos plan to a running graph: faults on its processes, the walk kept going.

An operator tool for trying a graph's fault tolerance, run by
``python3 benchmarks/chaos_benchmark.py`` and documented in docs/reliability.md ("The chaos
driver as an operator tool").

The driver is the operator of a ``run_all.py --serve`` graph under fire. It walks the walker
back and forth between two truss nodes (``walk_to`` goals), and applies the faults of a plan
(:func:`walker_bringup.core.chaos.plan_faults`) one after another: it waits for the fault's
phase of a step and its delay, finds the node's process id in the bring-up's ``pids.json``
(:func:`walker_bringup.processes.read_pids`, never by matching command lines), and sends
``SIGKILL`` (then waits for the bring-up to start the node again) or ``SIGSTOP`` (then
``SIGCONT`` after the fault's hold). Whenever the supervisor holds, it calls its ``resume``
service until the supervisor accepts, as an operator with ``walkerctl resume`` would. What
each fault came to is a :class:`~walker_bringup.core.chaos.FaultOutcome`.

A live grip monitor runs beside it: every ``gripper_states`` message is counted, and those
with no gripper attached are grip losses (:class:`~walker_bringup.core.chaos.GripCount`).
"""

from __future__ import annotations

import contextlib
import os
import signal
import time
from collections.abc import Callable, Sequence
from pathlib import Path

from walker_msgs.action import WalkTo
from walker_msgs.msg import GripperState, GripperStates, StepPhase

from walker_bringup.core.chaos import (
    FREEZE, PHASES, Fault, FaultOutcome, GripCount, moved_on, next_target)
from walker_bringup.graph_client import GraphClient, GraphNotReadyError
from walker_bringup.processes import read_pids
from walker_runtime.qos import latched_qos
from walker_teleop.core.goal_answer import ACCEPTED

__all__ = ['ChaosDriver', 'ChaosError', 'GripMonitor', 'phase_name']

#: [s] wall clock between two resumes the supervisor refused (the graph not well yet)
RESUME_RETRY = 1.0
#: [s] wall clock between two walk goals the supervisor refused (a step still settling)
WALK_RETRY = 1.0
_SPIN = 0.05  # [s]


class ChaosError(RuntimeError):
    """The chaos run could not go on: what it waited for and did not come."""


def phase_name(phase: int) -> str:
    """Name of a ``walker_msgs/StepPhase`` phase: ``COARSE``, ``SAFE_HOLD``, ..."""
    names = {StepPhase.IDLE: 'IDLE', StepPhase.SAFE_HOLD: 'SAFE_HOLD',
             **{getattr(StepPhase, name): name for name in PHASES}}
    return names.get(phase, f'phase {phase}')


class GripMonitor:
    """Count every gripper state the plant publishes, and those with no gripper attached."""

    def __init__(self, client: GraphClient) -> None:
        self.count = GripCount()
        client.node.create_subscription(GripperStates, 'gripper_states', self._on_states,
                                        latched_qos(1000))

    def _on_states(self, message: GripperStates) -> None:
        stamp = message.header.stamp.sec + message.header.stamp.nanosec * 1e-9
        self.count.add([g.name for g in message.grippers if g.state == GripperState.ATTACHED],
                       stamp)


class ChaosDriver:
    """Walk between two nodes and apply faults to the graph's processes.

    Parameters
    ----------
    client : GraphClient
        A client of the graph's namespace.
    log_dir : Path
        The bring-up's log directory (its ``pids.json``).
    targets : sequence of str
        Truss nodes to walk between: the walker goes to one no gripper is in, so two nodes
        one step apart must not both hold a gripper once a step ends (the start's base node
        is not one of them); :class:`ChaosError` when every target holds one.
    timeout : float
        Wall-clock seconds any one wait may take (a phase to come, a node to come back, the
        walker to move on after a fault).
    say : callable
        ``say(line)`` for progress.
    """

    def __init__(self, client: GraphClient, log_dir: Path, targets: Sequence[str],
                 timeout: float = 300.0, say: Callable[[str], None] = print) -> None:
        self.client = client
        self.log_dir = Path(log_dir)
        self.targets = list(targets)
        self.timeout = timeout
        self.say = say
        self.phases: list[tuple[float, StepPhase]] = []  # (monotonic receipt time, message)
        client.node.create_subscription(StepPhase, 'phase',
                                        lambda m: self.phases.append((time.monotonic(), m)),
                                        latched_qos(1000))
        self.pids_seen: set[int] = set()
        self.outcomes: list[FaultOutcome] = []
        self.target = self.targets[0]
        self._goal = None  # (SentGoal, supervisor pid) of the walk goal under way
        self._result = None
        self._walk_retry_at = 0.0
        self._resume_retry_at = 0.0
        self._finishing = False  # walk to the current target, then stay
        self._moved_at = 0.0  # when the walker moved on after the last hold
        self._refused = ''  # the supervisor's last reason to refuse a resume

    # ------------------------------------------------------------------ the graph's state
    def pids(self) -> dict[str, int]:
        """Node -> id of its newest process, from the bring-up."""
        pids = read_pids(self.log_dir)
        self.pids_seen.update(pids.values())
        return pids

    @property
    def phase(self) -> StepPhase | None:
        """The newest phase message (None before the first)."""
        return self.phases[-1][1] if self.phases else None

    def attached_nodes(self) -> set[str]:
        """Nodes a gripper is screwed into, from the newest gripper states."""
        states = self.client.grippers
        return set() if states is None else {
            g.node for g in states.grippers if g.state == GripperState.ATTACHED}

    # ------------------------------------------------------------------ tending the walk
    def tend(self, resume: bool = True) -> None:
        """Spin once; resume a hold; keep a walk goal under way when the walker is idle.

        Without ``resume``, a hold is left as it is (the faulty node is not back yet: an
        operator waits for it before resuming).
        """
        self.client.spin_for(_SPIN)
        phase = self.phase
        if phase is None:
            return
        now = time.monotonic()
        if phase.phase == StepPhase.SAFE_HOLD:
            if resume and now >= self._resume_retry_at:
                self._resume(phase)
        elif phase.phase == StepPhase.IDLE:
            self._keep_walking(now)

    def _resume(self, hold: StepPhase) -> None:
        try:
            answer = self.client.call_trigger('resume', timeout=10.0)
        except (GraphNotReadyError, TimeoutError) as error:
            answer = None
            self.say(f'[chaos] resume not answered: {error}')
        if answer is None or not answer.success:
            self._resume_retry_at = time.monotonic() + RESUME_RETRY
            if answer is not None and answer.message != self._refused:  # each reason once
                self.say(f'[chaos] resume refused: {answer.message}')
            self._refused = '' if answer is None else answer.message
            return
        self._refused = ''
        self.say(f'[chaos] resumed ({hold.reason[:80]}): {answer.message[:80]}')
        if self.outcomes:
            outcome = self.outcomes[-1]
            outcome.held = True
            outcome.resumes += 1
            outcome.reason = outcome.reason or hold.reason
        # the supervisor publishes the phase it enters at once; wait for it, so the old
        # hold is not resumed twice
        deadline = time.monotonic() + 10.0
        while self.phase.phase == StepPhase.SAFE_HOLD and time.monotonic() < deadline:
            self.client.spin_for(_SPIN)

    def _keep_walking(self, now: float) -> None:
        if self._result is not None and not self._result.done() and \
                self._goal[1] == self.pids().get('supervisor'):
            return  # a walk goal under way (one of a supervisor since killed is lost)
        if self._goal is not None and not self._goal[0].answer():
            return
        self._result = None
        if now < self._walk_retry_at:
            return
        attached = self.attached_nodes()
        if self.target in attached and self._finishing:
            return
        try:
            self.target = next_target(self.targets, self.target, attached)
        except ValueError as error:
            raise ChaosError(str(error)) from None
        sent = self.client.walk_goals.send(WalkTo.Goal(target_node=self.target))
        self._goal = (sent, self.pids().get('supervisor'))
        try:
            self.client._wait_until(sent.answer, 30.0, None, f'the walk to {self.target}')
        except TimeoutError:  # a supervisor frozen or gone: its successor is asked again
            self._goal, self._walk_retry_at = None, time.monotonic() + WALK_RETRY
            return
        if sent.answer() == ACCEPTED:  # its response, or the goal seen running
            self._result = sent.handle().get_result_async()
            self.say(f'[chaos] walking to {self.target}')
        else:
            self._walk_retry_at = time.monotonic() + WALK_RETRY

    def wait(self, condition: Callable[[], bool], what: str,
             timeout: float | None = None, resume: bool = True) -> None:
        """Tend the walk until ``condition()`` holds; :class:`ChaosError` after ``timeout``.

        ``resume`` as :meth:`tend`'s.
        """
        deadline = time.monotonic() + (self.timeout if timeout is None else timeout)
        while not condition():
            if time.monotonic() > deadline:
                last = self.phase
                raise ChaosError(f'{what}: not within {self.timeout:.0f} s (last phase '
                                 f'{phase_name(last.phase) if last else None}: '
                                 f'{last.reason if last else ""!r})')
            self.tend(resume)

    # ------------------------------------------------------------------ faults
    def apply(self, fault: Fault) -> FaultOutcome:
        """Wait for the fault's phase and delay, apply it, see the walker move on."""
        phase = getattr(StepPhase, fault.phase)

        def due() -> bool:
            time_seen, message = self.phases[-1] if self.phases else (0.0, None)
            return message is not None and message.phase == phase and \
                time.monotonic() - time_seen >= fault.delay

        self.wait(due, f'{fault.describe()}: the phase')
        node_pid = self.pids()[fault.node]
        outcome = FaultOutcome(fault, phase_name(self.phase.phase))
        self.outcomes.append(outcome)
        self.say(f'[chaos] {fault.describe()}: pid {node_pid}, phase seen {outcome.phase}')
        started = time.monotonic()
        if fault.kind == FREEZE:
            os.killpg(node_pid, signal.SIGSTOP)
            try:
                self.wait(lambda: time.monotonic() - started >= fault.hold, 'the freeze',
                          resume=False)
            finally:
                os.killpg(node_pid, signal.SIGCONT)
        else:
            os.killpg(node_pid, signal.SIGKILL)
            self.wait(lambda: self._started_again(fault.node, node_pid),
                      f'{fault.describe()}: {fault.node} started again', resume=False)
        back = time.monotonic()
        # the walker moves on for good (a hold meanwhile is resumed by tend)
        self.wait(lambda: self._moving_since(back), f'{fault.describe()}: the walker moving on')
        outcome.recovered = True
        outcome.time_to_recover = (self._moved_at if outcome.held else back) - started
        how = f'held, {outcome.resumes} resume(s)' if outcome.held else 'no hold'
        self.say(f'[chaos] {fault.describe()}: recovered in {outcome.time_to_recover:.1f} s '
                 f'({how})')
        return outcome

    def _started_again(self, node: str, old_pid: int) -> bool:
        pid = self.pids().get(node)
        if pid is None or pid == old_pid:
            return False
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, 0)
            return True
        return False

    def _moving_since(self, back: float) -> bool:
        """Tell whether the walker has moved on for good since ``back`` (:func:`moved_on`)."""
        moved = moved_on([(t, m.phase == StepPhase.SAFE_HOLD) for t, m in self.phases], back,
                         time.monotonic())
        self._moved_at = moved if moved is not None else self._moved_at
        return moved is not None

    def finish(self, target: str | None = None) -> None:
        """Walk on until the walker is idle with a gripper screwed into ``target``."""
        self.target = target or self.target
        self._finishing = True
        self.wait(lambda: self.phase is not None and self.phase.phase == StepPhase.IDLE
                  and self.target in self.attached_nodes()
                  and (self._result is None or self._result.done()),
                  f'the walk to {self.target}')

    def alive_pids(self) -> list[int]:
        """Return the processes of the graph seen during the run that still run."""
        alive = []
        for pid in sorted(self.pids_seen):
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.kill(pid, 0)
                alive.append(pid)
        return alive
