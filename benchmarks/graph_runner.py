"""Walker graphs brought up for a benchmark: one or several walkers, processes or composed.

:class:`GraphRun` starts a walk session's graph (:mod:`walker_bringup.session`: what
``run_all.py`` starts, under the same supervision, no node started again), in a ROS domain of
its own with discovery on loopback, with each plant run through :mod:`loop_probe` so that the
loop is timed inside the plant, and waits until every graph is ready. :class:`Walking` keeps
every walker walking back and forth while a window is measured.
"""

from __future__ import annotations

import contextlib
import os
import sys
import threading
import time
from pathlib import Path

from bench_support import REPO, load_events

PROBE = Path(__file__).resolve().parent / 'loop_probe.py'
STARTUP_TIMEOUT = 180.0  # [s] several walkers on a loaded 2-core machine start slowly
STOP_TIMEOUT = 20.0  # [s] for the processes to end on their interrupt (the plant then writes
#                       its probe file); dozens of them on two loaded cores take seconds

__all__ = ['GraphRun', 'Walking', 'back_and_forth_targets', 'walk_resuming']

#: Safe holds a walk is resumed from before it counts as failed.
MAX_RESUMES = 3
#: Longest wait for the supervisor to answer a resume [s] (wall clock, loaded machine).
RESUME_TIMEOUT = 20.0


class GraphRun:
    """Bring walker graphs up for a measurement; a context manager.

    Parameters
    ----------
    scratch : Path
        Directory for logs and probe files.
    walkers : int
        Number of walkers (namespaces ``/walker``, ``/walker_2``, ...).
    composed : bool
        Each walker's graph in one process (composition) instead of a process per node.
    sim_time : bool
        Lock-stepped sim time, or real time.
    parameters : tuple of (str, str)
        Overrides for every node (e.g. the control rate).
    record : bool
        Also run each walker's recorder.
    probe : bool
        Time the plant from the inside (:mod:`loop_probe`). Its records grow by about 160
        bytes a control period: a run that measures memory (the soak) goes without.
    grouped : bool
        The five joint controllers as one node (``run_all.py --grouped-controllers``).
    loop : bool
        The plant and the grouped controllers in one process, the other nodes as processes of
        their own (``run_all.py --composed-loop``; implies ``grouped``).
    """

    def __init__(self, scratch: Path, walkers: int = 1, composed: bool = False,
                 sim_time: bool = True, parameters: tuple[tuple[str, str], ...] = (),
                 record: bool = False, probe: bool = True, grouped: bool = False,
                 loop: bool = False) -> None:
        self.probe = probe
        self.loop = loop
        self.grouped = grouped or loop
        self.scratch = Path(scratch)
        self.count = walkers
        self.composed = composed
        self.sim_time = sim_time
        self.parameters = tuple(parameters)
        # in real time, the loop's figures are under SCHED_FIFO, as run_all.py --realtime runs
        # it (the shipped parameter file asks for no priority); with the loop composed in sim
        # time the plant waits for decisions: the session sets both, as run_all.py does
        self.session = None
        self.record = record
        self.graphs = []          # (namespace, start, nodes)
        self.groups = []          # one ProcessGroup per walker
        self.clients = []         # one GraphClient per walker
        self.context = None
        self._stack = contextlib.ExitStack()
        self._events: dict[str, dict] = {}

    # ------------------------------------------------------------------ lifetime
    def __enter__(self) -> 'GraphRun':
        try:
            self._start()
        except BaseException:
            self.__exit__(*sys.exc_info())
            raise
        return self

    def _start(self) -> None:
        sys.path.insert(0, str(REPO / 'tests'))
        from ros_test_support import isolated_domain
        from walker_bringup.core.respawn import RespawnPolicy
        from walker_bringup.domains import domain_environment
        from walker_bringup.run_arguments import REALTIME_PRIORITY
        from walker_bringup.session import Arrangement, SessionOptions, WalkSession
        from walker_config.core.configuration import load_configuration
        from walker_core.progress import ProgressLine

        self.scratch.mkdir(parents=True, exist_ok=True)
        domain = self._stack.enter_context(isolated_domain())
        # A ROS home of the run's own: the supervisor keeps the step under way in it, and a
        # window that ends in the middle of a step must not hand that step to the next graph
        # started in the same domain (it would take a step up from another stance).
        self._stack.enter_context(domain_environment(domain, self.scratch / 'ros_home',
                                                     PYTHONUNBUFFERED='1'))
        arrangement = Arrangement.COMPOSED if self.composed else Arrangement.COMPOSED_LOOP \
            if self.loop else Arrangement.GROUPED if self.grouped else Arrangement.PROCESSES
        options = SessionOptions(
            arrangement=arrangement, sim_time=self.sim_time, record=self.record, report=False,
            out=self.scratch, walkers=self.count, respawn=RespawnPolicy(limit=0),
            startup_timeout=STARTUP_TIMEOUT, quiet=True, overrides=self.parameters,
            realtime=0 if self.sim_time else REALTIME_PRIORITY, stop_timeout=STOP_TIMEOUT)
        self.session = WalkSession(load_configuration(), options,
                                   ProgressLine(True, stream=sys.stderr), wrap=self._probed)
        self.session.start()
        walkers = self.session.backend.walkers
        self.graphs = [(w.namespace, w.stance, w.nodes) for w in walkers]
        self.groups = [w.group for w in walkers]
        self.clients = [w.client for w in walkers]
        self.context = self.session.backend.context

    def _probed(self, spec, command: list[str] | None) -> list[str] | None:
        """Return a process's command, the plant's through :mod:`loop_probe` when probed.

        The probe writes its records to ``events_<walker>.npz`` in the scratch directory.
        """
        if not self.probe or spec.executable not in ('plant_node', 'composed_graph'):
            return command
        label = spec.namespace.strip('/')
        events = f'WALKER_LOOP_EVENTS={self.scratch / f"events_{label}.npz"}'
        if spec.executable == 'plant_node':
            return ['env', events, sys.executable, str(PROBE), 'plant', *spec.ros_arguments()]
        return ['env', events, sys.executable, str(PROBE), 'composed', *command[1:]]

    def died(self) -> bool:
        """Say whether a process of the run has exited (reported on stderr once)."""
        return self.session is not None and self.session.backend.should_stop()

    def __exit__(self, *exc_info) -> None:
        if self.session is not None:
            self.session.stop()
        for namespace, _, _ in self.graphs:
            path = self.scratch / f'events_{namespace.strip("/")}.npz'
            if path.exists():
                self._events[namespace] = load_events(path)
        self._stack.close()

    # ------------------------------------------------------------------ what runs
    def pids(self, index: int | None = None) -> dict[str, int]:
        """Process name -> pid, of one walker (0-based) or of all (names with namespaces)."""
        groups = self.groups if index is None else [self.groups[index]]
        return {process.spec.full_name: process.popen.pid
                for group in groups for process in group.processes}

    def events(self, index: int) -> dict | None:
        """Return the probe arrays of walker ``index`` (after the run has ended).

        None when its plant did not write them: it did not end on its interrupt (a starved
        machine: it was terminated or killed before it could).
        """
        return self._events.get(self.graphs[index][0])

    @property
    def period_ns(self) -> int:
        """The control period [ns] (the parameter file's rate, or the override)."""
        from walker_core.robot_parameters import load_walker_parameters

        rate = dict(self.parameters).get('timing.control_rate')
        rate = float(rate) if rate else load_walker_parameters().timing.control_rate
        return int(round(1e9 / rate))


def back_and_forth_targets(start) -> tuple[str, str]:
    """Two nodes a walker starting at ``start`` walks between: two columns on, and back."""
    column, row = (int(x) for x in start.base_node[1:].split('_'))
    return f'n{column + 2}_{row}', start.base_node


def walk_resuming(client, target: str, timeout: float, should_stop=None,
                  resumes: int = MAX_RESUMES) -> tuple[object, list[str]]:
    """Walk to ``target``; after a safe hold, resume (as an operator would) and walk on.

    The supervisor's watchdogs hold the walker when a source falls silent or a controller
    holds on stale inputs, which a loaded machine can cause in sim time (the plant waits for
    the controllers, not for the planner). Each hold is returned, so that the benchmark
    reports it instead of hiding it; after ``resumes`` holds the walk counts as failed.

    Returns
    -------
    (WalkTo.Result, list of str)
        The last walk's result and the reason of every safe hold met on the way.
    """
    from walker_msgs.msg import StepPhase

    holds: list[str] = []
    while True:
        _, result = client.walk_to(target, timeout, None, should_stop)
        held = 'safe hold' in result.message or 'fault' in result.message
        if result.success or not held or len(holds) >= resumes:
            return result, holds
        holds.append(result.message)
        client.spin_for(1.5)  # let the silent source be heard again before resuming
        reports = len(client.reports)
        try:
            answer = client.call_trigger('resume', RESUME_TIMEOUT)
        except TimeoutError as error:  # a starved supervisor: counted, the walk failed
            holds.append(f'resume unanswered: {error}')
            return result, holds
        if not answer.success:
            holds.append(f'resume refused: {answer.message}')
            return result, holds
        if 'completing' in answer.message:
            # A hold in the middle of a step: the supervisor completes that step first; the
            # walk goes on from where it ends (its report arrives, or it holds again).
            deadline = time.monotonic() + timeout
            busy = False
            while time.monotonic() < deadline and not (should_stop and should_stop()):
                client.spin_for(0.2)
                phase = client.phase.phase if client.phase is not None else None
                if phase not in (StepPhase.IDLE, StepPhase.SAFE_HOLD):
                    busy = True
                elif busy or len(client.reports) > reports:
                    break
            client.spin_for(0.5)


class Walking:
    """Keep every walker of a run walking between two nodes, one thread each.

    Parameters
    ----------
    run : GraphRun
    targets : list of (str, str)
        Each walker's two targets, walked to in turn.
    timeout : float
        Longest a walk may take [s].
    """

    def __init__(self, run: GraphRun, targets: list[tuple[str, str]],
                 timeout: float = 1800.0) -> None:
        self.run = run
        self.targets = targets
        self.timeout = timeout
        self.stop = threading.Event()
        self.results: list[list] = [[] for _ in targets]
        self.holds: list[list[str]] = [[] for _ in targets]
        self.errors: list[str] = []
        self._threads = [threading.Thread(target=self._walk, args=(i,), daemon=True)
                         for i in range(len(targets))]

    def __enter__(self) -> 'Walking':
        for thread in self._threads:
            thread.start()
        return self

    def _walk(self, index: int) -> None:
        from walker_bringup.graph_client import WalkInterruptedError

        client = self.run.clients[index]
        legs = 0
        while not self.stop.is_set():
            target = self.targets[index][legs % 2]
            try:
                result, holds = walk_resuming(client, target, self.timeout, self.stop.is_set)
            except WalkInterruptedError:
                return
            except Exception as error:  # reported with the results
                self.errors.append(f'{client.namespace}: {error}')
                return
            self.results[index].append(result)
            self.holds[index] += holds
            if not result.success:
                self.errors.append(f'{client.namespace}: walk to {target} failed: '
                                   f'{result.message}')
                return
            legs += 1

    def __exit__(self, *exc_info) -> None:
        self.stop.set()
        for thread in self._threads:
            thread.join(timeout=30.0)


def environment_note() -> str:
    """Name the executor in use (``WALKER_EXECUTOR``), for the results."""
    return os.environ.get('WALKER_EXECUTOR', 'events')
