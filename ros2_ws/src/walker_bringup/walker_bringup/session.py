"""One way to run a walk: a :class:`WalkSession`, the ROS graph or the headless runner behind it.

``run_all.py``, campaigns, the benchmarks and the fault tests all run walks through it; so can
a script or a notebook::

    from walker_bringup.session import Arrangement, SessionOptions, WalkSession
    from walker_config.core.configuration import load_configuration

    configuration = load_configuration()  # the installed walker.yaml, every rule checked
    options = SessionOptions(arrangement=Arrangement.HEADLESS, out='runs/notebook')
    with WalkSession(configuration, options) as session:
        summary = session.walk('n4_3')
    print(summary.reached, summary.steps_taken, f'{summary.duration:.1f} s')

The verbs: :meth:`~WalkSession.start` (bring the graph up; the context manager does it),
:meth:`~WalkSession.walk` (to any node), :meth:`~WalkSession.step` (to a neighbouring node),
:meth:`~WalkSession.hold` and :meth:`~WalkSession.resume` (the supervisor's), :meth:`~WalkSession.
serve` (keep the graph up for an operator until Ctrl-C) and :meth:`~WalkSession.stop` (shut
down, complete the bags, make the report). Every walk returns a
:class:`~walker_core.walk_summary.WalkSummary`, from either backend
(:mod:`walker_bringup.graph_session`, :mod:`walker_bringup.headless_session`), and writes
``<out>/summary.json``. What cannot be done raises
:class:`~walker_bringup.session_options.SessionError`, whose ``code`` is ``run_all.py``'s exit
code for it.
"""

from __future__ import annotations

import datetime
import sys
from pathlib import Path

from walker_core.progress import ProgressLine

from walker_bringup.session_options import (
    Arrangement, SessionError, SessionOptions, WalkSummary)

__all__ = ['WalkSession', 'Arrangement', 'SessionOptions', 'WalkSummary', 'SessionError',
           'output_directory']


def output_directory(out: str | Path | None) -> Path:
    """Return the session's output directory, resolved (``None``: ``runs/<date-time>``)."""
    stamp = datetime.datetime.now().strftime('%Y%m%d-%H%M%S')
    return Path(out or Path('runs') / stamp).resolve()


class WalkSession:
    """The walker running, as the options say, with a few verbs (see the module's docstring).

    Parameters
    ----------
    configuration : WalkerConfiguration
        The walker's configuration (:func:`walker_config.core.configuration.load_configuration`).
    options : SessionOptions
        The arrangement and everything else run_all.py's options say.
    progress : ProgressLine, optional
        Where progress and errors are said (default: standard output, quiet as the options).
    wrap : callable, optional
        The graph's: ``wrap(spec, command)`` returns the command a process starts with instead
        (:func:`walker_bringup.graph_walkers.launch`; a benchmark's loop probe).
    on_client : callable, optional
        The graph's: ``on_client(client)`` is called with each walker's
        :class:`~walker_bringup.graph_client.GraphClient` as soon as it exists, before the
        graph is waited for, e.g. to subscribe to more of the walker's topics from the start
        (a test's checks).
    """

    def __init__(self, configuration, options: SessionOptions | None = None,
                 progress: ProgressLine | None = None, wrap=None, on_client=None) -> None:
        self.configuration = configuration
        options = options or SessionOptions()
        self.options = options
        self.out = output_directory(options.out)
        self.progress = progress or ProgressLine(options.quiet, stream=sys.stdout)
        if options.arrangement is Arrangement.HEADLESS:
            from walker_bringup.headless_session import HeadlessBackend

            self.backend = HeadlessBackend(configuration, options, self.out, self.progress)
        else:
            from walker_bringup.graph_session import GraphBackend

            self.backend = GraphBackend(configuration, options, self.out, self.progress, wrap,
                                        on_client)
        self.started = False
        self._ran = False  # a walk was sent or the graph served: the bag holds one
        self._interrupted = False  # stopped by a signal: no report

    def check_target(self, target: str) -> list[str]:
        """Check ``target`` (each walker's, moved with its start) before anything starts.

        Raises
        ------
        SessionError
            (code 2) if it is not a node of the truss, or a walker's moved target is off it.
        """
        from walker_core.truss import Truss

        try:
            Truss.from_parameters(self.configuration.walker).index(target)
        except ValueError as error:
            raise SessionError(f'--target {target!r}: {error}') from None
        if self.options.arrangement.graph:
            return self.backend.targets(target)
        return [target]

    def start(self) -> WalkSession:
        """Bring the walker up (the graph ready; the headless output directory made)."""
        if not self.started:
            self.started = True
            self.backend.start()
        return self

    def walk(self, target: str) -> WalkSummary | list[WalkSummary]:
        """Walk to ``target``; return the summary (one per walker with several walkers)."""
        return self._goal(target, 'walk_to')

    def step(self, target: str) -> WalkSummary | list[WalkSummary]:
        """Take one step to ``target``, a node next to the base gripper's."""
        return self._goal(target, 'step')

    def hold(self) -> str:
        """Ask the supervisor to hold (SAFE_HOLD); return what it says."""
        return self.backend.command('hold')

    def resume(self) -> str:
        """Ask the supervisor to leave SAFE_HOLD (completing a step cut short)."""
        return self.backend.command('resume')

    def serve(self) -> None:
        """Keep the graph up for an operator (walkerctl, the ros2 tools) until Ctrl-C."""
        if not self.options.arrangement.graph:
            raise SessionError('the headless runner has no graph to serve')
        self.start()
        self._ran = True
        self.backend.serve()

    def stop(self) -> int:
        """Shut down and make the report; return 0, or 4 (left running) or 6 (no report)."""
        if not self.started:
            return 0
        self.started = False
        return self.backend.stop(self._ran and not self._interrupted)

    @property
    def exit_codes(self) -> dict[str, int | None]:
        """Each node's exit code after :meth:`stop` (the graph's; headless: none).

        The code of the node's last process, by node name (``walker_2/node`` with several
        walkers); ``None``: still running after the shutdown.
        """
        return dict(self.backend.exit_codes)

    def __enter__(self) -> WalkSession:
        try:
            return self.start()
        except BaseException:
            self.stop()
            raise

    def __exit__(self, *_exc) -> None:
        self.stop()

    def _goal(self, target: str, goal: str):
        self.start()
        self._ran = True
        try:
            summaries = self.backend.walk(target, goal)
        except SessionError as error:
            self._interrupted = error.code == 130
            raise
        if isinstance(summaries, WalkSummary):
            return summaries
        return summaries[0] if len(summaries) == 1 else summaries
