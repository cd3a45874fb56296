"""The main job: bring the graph up, walk to a target node, record, summarise, shut down, report.

Every node runs as a separate process (:mod:`walker_bringup.processes`); the graph counts as up
when every node is in the ROS graph and every server answers (not after a sleep). A child that
dies is reported at once with the end of its log, the walk is stopped safely (the supervisor is
told to hold, the walk goal cancelled), and everything is shut down. Ctrl-C does the same.
Nothing is left running: each child is interrupted, then terminated, then killed.

Once the graph is down (and with it the recorder, which closes the bag), the walk report is
made from the bag (:mod:`walker_report`) into ``<out>/report``, unless ``--no-report``; it is
made after a failed walk too, not after Ctrl-C.
"""

from __future__ import annotations

import argparse
import datetime
import os
import signal
import sys
import time
from pathlib import Path

from walker_bringup.graph import walker_graph
from walker_bringup.graph_client import (
    GraphClient, GraphNotReadyError, WalkInterruptedError, init_context)
from walker_bringup.processes import ProcessGroup
from walker_bringup.summary import format_table, rows_from_reports, write_json
from walker_report.core.errors import ReportError
from walker_report.core.report import make_report
from walker_report.progress import ProgressLine
from walker_report.walk_report import written_text

__all__ = ['main', 'parse_arguments', 'write_report']

PHASE_NAMES = ('idle', 'extraction', 'coarse', 'fine', 'insertion', 'safe hold')
SERVE_POLL = 0.2  # [s] longest wait of --serve before it sees Ctrl-C or a dead node


def parse_arguments(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line options of ``run_all.py``."""
    parser = argparse.ArgumentParser(
        prog='run_all.py',
        description='Bring the walker graph up on the pybullet plant, walk to a target node, '
                    'record the walk and print a per-step summary.')
    parser.add_argument('--target', default='n4_3',
                        help='truss node to walk to (default: %(default)s)')
    parser.add_argument('--params-file', default=None,
                        help='parameter file (default: the installed walker.yaml)')
    parser.add_argument('--sim-time', action='store_true',
                        help='run on the plant clock, lock-stepped, as fast as the graph allows '
                             '(default: real time, like hardware)')
    parser.add_argument('--no-record', dest='record', action='store_false',
                        help='do not record a rosbag2 bag of the walk (and so no report)')
    parser.add_argument('--no-report', dest='report', action='store_false',
                        help='do not write the walk report (figures, animation) from the bag')
    parser.add_argument('--out', default=None,
                        help='output directory (default: runs/<date-time>)')
    parser.add_argument('--namespace', default='/walker', help='robot namespace')
    parser.add_argument('--startup-timeout', type=float, default=120.0,
                        help='seconds to wait for the graph to come up')
    parser.add_argument('--walk-timeout', type=float, default=600.0,
                        help='seconds the walk may take (wall clock)')
    parser.add_argument('--no-walk', dest='walk', action='store_false',
                        help='bring the graph up, report it ready, and shut it down')
    parser.add_argument('--serve', action='store_true',
                        help='bring the graph up and keep it running, without walking, until '
                             'Ctrl-C: for an operator with walkerctl or the ros2 tools')
    parser.add_argument('--quiet', action='store_true', help='print only the summary')
    return parser.parse_args(argv)


class _Progress:
    """One status line, rewritten in place on a terminal.

    Without a terminal (a log file, CI) a line is printed only when ``key`` changes (a new step
    or phase) or every ``LOG_PERIOD`` seconds, so a long walk does not flood the log.
    """

    LOG_PERIOD = 5.0  # [s]

    def __init__(self, quiet: bool) -> None:
        self.quiet = quiet
        self.tty = sys.stdout.isatty()
        self.last = ''
        self._key = None
        self._printed = -float('inf')

    def update(self, text: str, key=None) -> None:
        if self.quiet or text == self.last:
            return
        if self.tty:
            self.last = text
            print(f'\r\033[K{text}', end='', flush=True)
            return
        now = time.monotonic()
        if key != self._key or now - self._printed >= self.LOG_PERIOD:
            self._key, self._printed, self.last = key, now, text
            print(text, flush=True)

    def say(self, text: str) -> None:
        if self.tty and self.last:
            print()
        self.last = ''
        if not self.quiet:
            print(text, flush=True)


def main(argv: list[str] | None = None) -> int:
    """Run the main job; return the exit code (0 when the walk reached its target)."""
    args = parse_arguments(argv)
    from walker_core.robot_parameters import default_parameter_file

    params_file = Path(args.params_file or default_parameter_file()).resolve()
    stamp = datetime.datetime.now().strftime('%Y%m%d-%H%M%S')
    out = Path(args.out or Path('runs') / stamp).resolve()
    out.mkdir(parents=True, exist_ok=True)
    progress = _Progress(args.quiet)
    env = dict(os.environ)
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    graph = walker_graph(params_file, args.namespace, sim_time=args.sim_time,
                         record=args.record, bag_path=out / 'bag')
    progress.say(f'[walker] output in {out}')
    progress.say(f'[walker] starting {len(graph)} node processes '
                 f'({"sim time" if args.sim_time else "real time"}): '
                 + ', '.join(n.name for n in graph))

    interrupted = {'signal': None}

    def on_signal(signum, _frame):
        interrupted['signal'] = signum

    previous = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    group = ProcessGroup(out / 'logs', env)
    context = client = None
    deaths: list = []

    def should_stop() -> bool:
        deaths.extend(group.poll_deaths())
        return bool(deaths) or interrupted['signal'] is not None

    code = 1
    try:
        for spec in graph:
            group.start(spec)
        context = init_context()
        client = GraphClient(args.namespace, context)
        started = time.monotonic()
        client.wait_until_ready(
            [n.full_name for n in graph], args.startup_timeout,
            progress=lambda r: progress.update(
                f'[walker] bringing the graph up: {len(r.ready)}/{len(r.ready) + len(r.missing)}'
                f' ready' + (f' (waiting for {", ".join(r.missing[:3])})' if r.missing else ''),
                key=len(r.ready)),
            should_stop=should_stop)
        progress.say(f'[walker] graph ready in {time.monotonic() - started:.1f} s')
        if args.serve:
            return _serve(client, args, should_stop, deaths)
        if not args.walk:
            return 0
        code = _walk(client, args, progress, should_stop, out)
    except GraphNotReadyError as error:
        progress.say(f'[walker] error: {error}')
        code = 3
    except WalkInterruptedError:
        code = _report_interruption(client, deaths, interrupted['signal'], progress)
    finally:
        if client is not None:
            client.close()
        if context is not None:
            context.try_shutdown()
        progress.say('[walker] shutting the graph down')
        codes = group.stop_all()
        left = [p.spec.name for p in group.processes if p.alive]
        if left:
            progress.say(f'[walker] error: still running after shutdown: {", ".join(left)}')
            code = code or 4
        elif not args.quiet:
            progress.say('[walker] all node processes stopped ('
                         + ', '.join(f'{n}: {c}' for n, c in codes.items()) + ')')
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    walked = args.walk and code not in (3, 130)  # the graph came up and nobody hit Ctrl-C
    if args.record and args.report and walked and (out / 'bag').is_dir():
        if not write_report(out / 'bag', out / 'report', params_file, args.quiet):
            code = code or 6
    return code


def _serve(client: GraphClient, args, should_stop, deaths: list) -> int:
    """Keep the graph running until Ctrl-C (exit code 0) or a node dies.

    The client keeps spinning: a participant that stops taking its messages would hold up the
    graph's reliable writers.
    """
    domain = os.environ.get('ROS_DOMAIN_ID', '0')
    print(f'[walker] serving in namespace {args.namespace}, ROS_DOMAIN_ID={domain}: try '
          f'scripts/walkerctl status; Ctrl-C shuts the graph down', flush=True)
    while not should_stop():
        client.spin_for(SERVE_POLL)
    if deaths:
        raise WalkInterruptedError('a node died')
    return 0


def write_report(bag: Path, report_dir: Path, params_file: Path, quiet: bool) -> bool:
    """Make the walk report of ``bag`` into ``report_dir`` and say where it is.

    Returns False (having said why) when the report could not be made; the walk's own
    outcome stands.
    """
    progress = ProgressLine(quiet, prefix='[walker] report:')
    try:
        result = make_report(bag, report_dir, params_file, progress=progress)
    except (ReportError, ValueError) as error:
        progress.close()
        print(f'[walker] error: no walk report: {error}', flush=True)
        return False
    progress.close()
    if quiet:
        print(f'[walker] report: {result.markdown}', flush=True)
    else:
        for line in written_text(result).splitlines():
            print(f'[walker] {line}', flush=True)
        print(f'[walker] report made in {result.seconds:.1f} s', flush=True)
    return True


def _walk(client: GraphClient, args, progress: _Progress, should_stop, out: Path) -> int:
    started = time.monotonic()

    def on_feedback(feedback) -> None:
        progress.update(
            f'[walker] step {feedback.step_index + 1}/{feedback.step_count} '
            f'{feedback.from_node} -> {feedback.to_node}: '
            f'{PHASE_NAMES[feedback.phase] if feedback.phase < len(PHASE_NAMES) else "?"}, '
            f'tip error {feedback.tip_position_error * 1e3:.1f} mm '
            f'({time.monotonic() - started:.0f} s)', key=(feedback.step_index, feedback.phase))

    progress.say(f'[walker] walking to {args.target}')
    status, result = client.walk_to(args.target, args.walk_timeout, on_feedback, should_stop)
    client.spin_for(0.5)  # the last step report
    rows = rows_from_reports(client.reports)
    progress.say('')
    print(format_table(rows) if rows else '[walker] no step was taken')
    write_json(rows, out / 'summary.json',
               {'target': args.target, 'reached': bool(result.success),
                'message': result.message, 'path': list(result.path),
                'wall_time': time.monotonic() - started})
    if result.success:
        print(f'[walker] reached {args.target} in {result.steps_taken} steps, '
              f'{result.duration:.1f} s of walking; summary in {out / "summary.json"}')
        return 0
    print(f'[walker] the walk to {args.target} did not reach it: {result.message}')
    return 1


def _report_interruption(client, deaths, signum, progress: _Progress) -> int:
    for process in deaths:
        progress.say(f'[walker] error: node {process.spec.full_name} died '
                     f'(exit code {process.popen.returncode}); the end of its log:\n'
                     f'{process.log_tail()}')
    if signum is not None:
        progress.say(f'[walker] interrupted ({signal.Signals(signum).name}): stopping safely')
    if client is not None:
        try:
            response = client.call_trigger('hold', timeout=2.0)
            progress.say(f'[walker] supervisor: {response.message}')
        except Exception as error:  # reporting only: shutting down anyway
            progress.say(f'[walker] could not ask the supervisor to hold: {error}')
    return 130 if signum is not None and not deaths else 5
