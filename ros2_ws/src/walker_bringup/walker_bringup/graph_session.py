"""The walk session's graph backend: the ROS graph up, walks sent to it, and everything down.

Every node runs as a separate process (:mod:`walker_bringup.processes`), the five joint
controllers grouped into one, the loop composed into one process, or the whole graph in one
(:mod:`walker_bringup.composition`), under the same supervision; with several walkers, N graphs
side by side in the namespaces ``/walker``, ``/walker_2``, ..., each from its own start on the
same truss layout, each walking the same route moved with its start. A graph counts as up when
every node is in the ROS graph, every server answers and the supervisor has heard from every
source it watches (checked, not after a sleep).

A node process that dies is reported at once with the end of its log and started again after
the respawn policy's delay, as launch's ``respawn`` (:mod:`walker_bringup.respawning`); each
node's deaths and restarts go into the walk summary (``processes``). A node that dies more
than the policy's limit in a row is given up: the walk is stopped safely (the supervisor told
to hold, the walk goal cancelled; :class:`SessionError` code 5). SIGINT and SIGTERM do the same
(code 130). :meth:`GraphBackend.stop` leaves nothing running: each child is interrupted, then
terminated, then killed; the bags a killed recorder left cut are completed; the walk report is
made from the bag (the first walker's, with several). See docs/reliability.md. The walks
themselves are sent, printed and summarised by :mod:`walker_bringup.graph_walk`.
"""

from __future__ import annotations

import os
import signal
import threading
import time
from pathlib import Path

from walker_core.progress import ProgressLine
from walker_core.walk_summary import Runner, WalkSummary
from walker_report.core.steps import rows_from_reports, write_json
from walker_report.walk_report import report_after_walk
from walker_supervisor.core.survey_file import write_survey

from walker_bringup.graph import walker_targets
from walker_bringup.graph_client import (
    GoalRejectedError, GraphClient, GraphNotReadyError, WalkInterruptedError, init_context)
from walker_bringup.graph_walk import SUMMARY_FILE, walk_one, walk_several
from walker_bringup.graph_walkers import (
    GraphWalker, Wrap, bag_paths, describe_walkers, launch, namespaces_in_use, recover_bags,
    survey_files)
from walker_bringup.respawning import RespawningGroup
from walker_bringup.session_options import SessionError, SessionOptions
from walker_bringup.transport import (
    DEFAULT_TRANSPORT, PROFILES_VARIABLE, STATIC_PEERS_VARIABLE, default_transport,
    graph_environment)
from walker_bringup.truss_survey import checked_survey, survey_map

__all__ = ['GraphBackend', 'SERVE_POLL']

SERVE_POLL = 0.2  # [s] longest wait of serve() before it sees Ctrl-C or a dead node
_DEATH_REPORT_LEAD = 0.5  # [s] between a death's report on /diagnostics and the hold it asks


class GraphBackend:
    """Runs the walker's ROS graph (:class:`~walker_bringup.session.WalkSession`'s backend).

    ``wrap`` and ``on_client`` are :class:`~walker_bringup.session.WalkSession`'s. After
    :meth:`stop`, ``exit_codes`` holds the exit code of each node's last process (``walker/node``
    with several walkers; ``None``: still running).
    """

    runner = Runner.GRAPH

    def __init__(self, configuration, options: SessionOptions, out: Path,
                 progress: ProgressLine, wrap: Wrap | None = None, on_client=None) -> None:
        self.configuration = configuration
        self.wrap = wrap
        self.on_client = on_client
        self.exit_codes: dict[str, int | None] = {}
        self._profile_before: tuple[str | None] | None = None  # this process's, to give back
        self.options = options
        self.out = out
        self.progress = progress
        self.walkers: list[GraphWalker] = []
        self.context = None
        self.deaths: list = []
        self.signalled: int | None = None
        self._previous_handlers: dict = {}
        self._lock = threading.Lock()
        self._prepared = False
        self.survey: dict | None = None  # the truss survey the walkers start from

    # ------------------------------------------------------------------ set-up
    def prepare(self) -> None:
        """Check the options against the file and describe every graph; nothing started.

        Raises
        ------
        SessionError
            (code 2) naming what is refused.
        """
        if self._prepared:
            return
        options, say = self.options, self.progress
        base_env = {**os.environ, 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST'}
        transport = options.transport or default_transport(base_env)
        if transport != DEFAULT_TRANSPORT and options.transport is None:
            say.say(f'[walker] {STATIC_PEERS_VARIABLE} names peers on other hosts: the graph '
                    f'runs on {transport} (--transport), reachable from them')
        try:
            self.env = graph_environment(base_env, transport)
        except ValueError as error:
            raise SessionError(f'--transport {transport}: {error} (--transport shm leaves the '
                               'rmw default)') from None
        if options.walkers > 1 and options.namespace != '/walker':
            raise SessionError('--walkers names the namespaces itself (/walker, /walker_2, '
                               '...): leave --namespace out')
        if options.walkers > 1 and options.foxglove_port is not None:
            raise SessionError('--foxglove serves one walker: leave --walkers out')
        if options.truss_survey is not None:  # every walker's supervisor starts from it
            self.survey = checked_survey(self.configuration, options.truss_survey)
        try:
            self.walkers = describe_walkers(options, self.configuration, self.out, self.env)
            timing = self.configuration.walker.timing
            if options.realtime and options.realtime <= timing.decision_priority:
                raise ValueError(f"--realtime {options.realtime} must be above the "
                                 f"supervisor's and planner's timing.decision_priority "
                                 f'({timing.decision_priority}) in the parameter file, which '
                                 'it runs them at')
        except ValueError as error:
            raise SessionError(str(error)) from None
        taken = [bag for bag in bag_paths(self.walkers) if bag.exists()]
        if taken:
            raise SessionError(f'{", ".join(map(str, taken))} already exists and a recording '
                               'never overwrites a bag: choose another --out, or --no-record')
        self._prepared = True

    def targets(self, target: str) -> list[str]:
        """Each walker's target: ``target`` moved with its start (SessionError code 2)."""
        self.prepare()
        if len(self.walkers) == 1:
            return [target]
        try:
            return walker_targets(self.configuration, target,
                                  [w.stance for w in self.walkers])
        except ValueError as error:
            raise SessionError(str(error)) from None

    def start(self) -> None:
        """Bring every graph up and wait until it is ready.

        Raises
        ------
        SessionError
            Code 2: refused, nothing started; 3: a graph did not come up; 5 or 130: a node
            was given up on, or a signal came, while it came up. Call :meth:`stop` after it.
        """
        self.prepare()
        options, progress, out, walkers = self.options, self.progress, self.out, self.walkers
        out.mkdir(parents=True, exist_ok=True)
        for stale in out.glob('plant_state*.json'):  # an earlier run's robot is not this one's
            stale.unlink()
        # this process's own participant (the walk's client) is reached as the nodes are;
        # stop() gives the variable back as it was
        if PROFILES_VARIABLE in self.env and self._profile_before is None:
            self._profile_before = (os.environ.get(PROFILES_VARIABLE),)
            os.environ[PROFILES_VARIABLE] = self.env[PROFILES_VARIABLE]
        for survey_file in survey_files(walkers):  # nor an earlier run's truss survey
            survey_file.unlink(missing_ok=True)
            if self.survey is not None:
                write_survey(survey_file, survey_map(self.configuration, self.survey))
        context = init_context()
        busy = namespaces_in_use(walkers, context)
        if busy:
            context.try_shutdown()
            raise SessionError(busy)
        self.context = context
        count = sum(len(w.nodes) for w in walkers)
        progress.say(f'[walker] output in {out}')
        progress.say(
            f'[walker] starting {count} nodes '
            + (f'in {len(walkers)} composed process{"es" if len(walkers) > 1 else ""}'
               if options.composed else 'with the loop (plant, controllers) in one process'
               if options.composed_loop else 'as separate processes')
            + f' ({"sim time" if options.sim_time else "real time"}'
            + (f', {len(walkers)} walkers' if len(walkers) > 1 else '') + '): '
            + ', '.join(n.name for n in walkers[0].nodes))

        def on_signal(signum, _frame):
            self.signalled = signum

        # a worker's thread cannot take signals; a caller may keep its own (handle_signals)
        if options.handle_signals and threading.current_thread() is threading.main_thread():
            self._previous_handlers = {s: signal.signal(s, on_signal)
                                       for s in (signal.SIGINT, signal.SIGTERM)}
        for walker in walkers:
            walker.respawner = RespawningGroup(
                walker.group, options.respawn, progress.error,
                walker.label if len(walkers) > 1 else '',
                report=lambda node, level, message, w=walker: w.client is not None
                and w.client.report_process(node, level, message))
        try:
            for walker in walkers:
                launch(walker, options, self.configuration.path, self.wrap)
            started = time.monotonic()
            for walker in walkers:
                walker.client = GraphClient(walker.namespace, context)
                if self.on_client is not None:
                    self.on_client(walker.client)
                prefix = f'{walker.label}: ' if len(walkers) > 1 else ''
                walker.client.wait_until_ready(
                    [n.full_name for n in walker.nodes], options.startup_timeout,
                    progress=lambda r, p=prefix: progress.update(
                        f'[walker] {p}bringing the graph up: {len(r.ready)}/'
                        f'{len(r.ready) + len(r.missing)} ready'
                        + (f' (waiting for {", ".join(r.missing[:3])})' if r.missing else ''),
                        key=(p, len(r.ready))),
                    should_stop=self.should_stop)
        except GraphNotReadyError as error:
            raise SessionError(str(error), 3) from None
        except WalkInterruptedError:
            raise SessionError('interrupted', self._report_interruption()) from None
        progress.say(f'[walker] graph{"s" if len(walkers) > 1 else ""} ready in '
                     f'{time.monotonic() - started:.1f} s')
        if options.foxglove_port is not None:
            progress.say(f'[walker] live view: open ws://127.0.0.1:{options.foxglove_port} in '
                         f'Foxglove with the layout {_foxglove_layout()}')

    def should_stop(self) -> bool:
        """Return True once a node was given up on or a signal came (polls the respawners)."""
        with self._lock:
            if not self.deaths:  # a graph given up on is not started again
                for walker in self.walkers:
                    self.deaths.extend(walker.respawner.poll())
        return bool(self.deaths) or self.signalled is not None

    # ------------------------------------------------------------------ verbs
    def walk(self, target: str, goal: str = 'walk_to') -> list[WalkSummary]:
        """Walk every walker to its target at once; return each one's summary.

        Raises
        ------
        SessionError
            Code 1: the supervisor rejected the goal (nothing moved); 5 or 130: stopped.
        """
        walkers = self.walkers
        for walker, moved in zip(walkers, self.targets(target), strict=True):
            walker.target = moved
        try:
            if len(walkers) == 1:
                return [walk_one(self, walkers[0], target, goal, self.should_stop)]
            return walk_several(self, goal)
        except GoalRejectedError as error:  # the supervisor's reason: nothing moved
            raise SessionError(str(error), 1) from None
        except WalkInterruptedError:
            raise SessionError('interrupted', self._report_interruption()) from None

    def serve(self) -> None:
        """Keep the graph running until a signal (returns) or a node is given up (code 5).

        The client keeps spinning: a participant that stops taking its messages would hold up
        the graph's reliable writers. On the way out, the steps taken and each node's deaths
        and restarts go into ``<out>/summary.json``.
        """
        walker = self.walkers[0]
        client = walker.client
        domain = os.environ.get('ROS_DOMAIN_ID', '0')
        print(f'[walker] serving in namespace {self.options.namespace}, ROS_DOMAIN_ID={domain}: '
              'try scripts/walkerctl status; Ctrl-C shuts the graph down', flush=True)
        try:
            while not self.should_stop():
                client.spin_for(SERVE_POLL)
        finally:
            write_json(rows_from_reports(client.reports), self.out / SUMMARY_FILE,
                       {'serve': True, 'processes': walker.processes()})
        if self.deaths:
            raise SessionError('a node died', self._report_interruption())

    def command(self, which: str) -> str:
        """Call the supervisor's ``hold`` or ``resume`` on every walker; return what it says."""
        answers = []
        for walker in self.walkers:
            response = walker.client.call_trigger(which, timeout=5.0)
            if not response.success:
                raise SessionError(f'{which} refused by {walker.namespace}: {response.message}',
                                   1)
            answers.append(response.message)
        return '; '.join(answers)

    def stop(self, make_report: bool) -> int:
        """Shut every graph down, complete cut bags, make the report; return 0, 4 or 6.

        4: a process was still running after the shutdown; 6: the report could not be made.
        Each node's exit code is kept in ``exit_codes``; the profiles variable this process
        was given for its client (:data:`~walker_bringup.transport.PROFILES_VARIABLE`) is
        given back as it was.
        """
        code = 0
        progress, walkers = self.progress, self.walkers
        for walker in walkers:
            if walker.client is not None:
                walker.client.close()
        if self.context is not None:
            self.context.try_shutdown()
            progress.say('[walker] shutting the graph down')
            codes = self.exit_codes = {}
            left = []
            for walker in walkers:
                prefix = f'{walker.label}/' if len(walkers) > 1 else ''
                codes.update({prefix + n: c for n, c in
                              walker.group.stop_all(self.options.stop_timeout).items()})
                left += [prefix + p.spec.name for p in walker.group.processes if p.alive]
            if left:
                progress.error(f'[walker] error: still running after shutdown: '
                               f'{", ".join(left)}')
                code = 4
            elif not self.options.quiet:
                progress.say(f'[walker] all '
                             f'{"processes" if self.options.composed else "node processes"} '
                             'stopped (' + ', '.join(f'{n}: {c}' for n, c in codes.items())
                             + ')')
        for sig, handler in self._previous_handlers.items():
            signal.signal(sig, handler)
        self._previous_handlers = {}
        if self._profile_before is not None:
            (before,), self._profile_before = self._profile_before, None
            if before is None:
                os.environ.pop(PROFILES_VARIABLE, None)
            else:
                os.environ[PROFILES_VARIABLE] = before
        for line in recover_bags(bag_paths(walkers)):
            progress.error(line)
        options = self.options
        if make_report and options.record and options.report and (self.out / 'bag').is_dir():
            if not report_after_walk(self.out / 'bag', self.out / 'report',
                                     self.configuration.path, options.quiet):
                code = code or 6
        return code

    def _report_interruption(self) -> int:
        """Say why the walk stopped, ask every supervisor to hold; return 5 or 130."""
        progress, signum = self.progress, self.signalled
        for process in self.deaths:
            progress.error(f'[walker] error: node {process.spec.full_name} died '
                           f'(exit code {process.popen.returncode}); the end of its log:\n'
                           f'{process.log_tail()}')
        if signum is not None:
            progress.say(f'[walker] interrupted ({signal.Signals(signum).name}): stopping safely')
        elif self.deaths:  # the death was reported on /diagnostics: let it reach the
            time.sleep(_DEATH_REPORT_LEAD)  # supervisor first, which names it in the reason
        for walker in self.walkers:
            client = walker.client
            if client is None:
                continue
            try:
                response = client.call_trigger('hold', timeout=2.0)
                progress.say(f'[walker] supervisor {client.namespace}: {response.message}')
            except Exception as error:  # reporting only: shutting down anyway
                progress.error(f'[walker] could not ask the supervisor {client.namespace} to '
                               f'hold: {error}')
        return 130 if signum is not None and not self.deaths else 5


def _foxglove_layout() -> Path:
    """Return the installed Foxglove layout of walker_viz."""
    from ament_index_python.packages import get_package_share_directory

    return Path(get_package_share_directory('walker_viz')) / 'config' / 'walker.foxglove.json'
