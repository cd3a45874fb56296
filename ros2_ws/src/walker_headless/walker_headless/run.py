"""``run_all.py --headless``: walk to a target in the lock-step loop; summary, bag and report.

What ``run_all.py`` does with the graph, without it: the same parameter file, the same
progress line, the same per-step table and ``summary.json``, a rosbag2 bag of the same topics
(``<out>/bag``) and the walk report made from it (``<out>/report``), from the same cores in
one process (:func:`walker_headless.runner.walk`). The options are ``run_all.py``'s
(:func:`walker_bringup.run.parse_arguments`): ``--target``, ``--params-file``, ``--out``,
``--namespace`` (of the bag's topics), ``--no-record``, ``--no-report``, ``--quiet``,
``--walk-timeout`` (wall clock) and ``--plant-params-file`` (the plant's own file) apply;
the graph's own are refused there.

``summary.json`` holds what the graph's does, with ``wall_time`` the loop's wall time and
``runner`` ``"headless"``; everything in it but ``wall_time`` is the same, bit for bit, for
the same parameter file and target.
"""

from __future__ import annotations

import datetime
import sys
from pathlib import Path

from walker_bag.core.errors import BagError
from walker_config.core.configuration import load_configuration
from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_core.parameter_schema import ParameterError
from walker_report.core.steps import format_table, rows_from_reports, write_json
from walker_report.walk_report import report_after_walk
from walker_core.progress import ProgressLine, walk_progress

from walker_headless.recording import WalkRecording
from walker_headless.runner import WalkResult, walk

__all__ = ['run_headless', 'loop_record']


def run_headless(args) -> int:
    """Walk headless with ``run_all.py``'s options ``args``; return its exit code.

    0: the target was reached; 1: it was not; 2: the options or the parameter file were
    refused (nothing ran); 6: walked, but the report could not be made.
    """
    try:
        configuration = load_configuration(args.params_file,
                                 plant_path=getattr(args, 'plant_params_file', None))
    except (ParameterError, ValueError) as error:
        print(f'[walker] error: {error}', flush=True)
        return 2
    stamp = datetime.datetime.now().strftime('%Y%m%d-%H%M%S')
    out = Path(args.out or Path('runs') / stamp).resolve()
    bag = out / 'bag'
    if args.record and bag.exists():
        print(f'[walker] error: {bag} already exists and a recording never overwrites a bag: '
              'choose another --out, or --no-record', flush=True)
        return 2
    out.mkdir(parents=True, exist_ok=True)
    progress = ProgressLine(args.quiet, stream=sys.stdout)
    if not args.quiet:
        print(f'[walker] output in {out}', flush=True)
        print(f'[walker] headless: plant, five controllers, planner and supervisor in one '
              f'lock-step loop, no DDS; walking to {args.target}', flush=True)
    try:
        recording = WalkRecording(bag, args.namespace) if args.record else None
    except BagError as error:
        print(f'[walker] error: {error}', flush=True)
        return 2
    rate = configuration.walker.timing.control_rate

    def on_feedback(feedback, time: float) -> None:
        text = walk_progress(feedback.step_index, feedback.step_count, int(feedback.phase),
                             feedback.from_node, feedback.to_node, feedback.tip_position_error,
                             time)
        progress.update(f'[walker] {text}', key=(feedback.step_index, int(feedback.phase)))

    try:
        result = walk(configuration, args.target, recording, on_feedback,
                      wall_timeout=args.walk_timeout)
    except ParameterError as error:
        progress.end()
        print(f'[walker] error: {error}', flush=True)
        return 2
    finally:
        if recording is not None:
            recording.close()
    progress.end()
    code = _summarise(result, out, rate)
    if args.record and args.report:
        if not report_after_walk(bag, out / 'report', configuration.path, args.quiet):
            code = code or 6
    return code


def loop_record(result: WalkResult) -> dict:
    """Return the ``loop`` entry of ``summary.json``: lock-stepped by calls, never late."""
    return {'clock_mode': 'sim_time', 'plant_time': result.sim_time, 'late_periods': 0,
            'late_efforts': dict.fromkeys(PHYSICAL_JOINT_NAMES, 0), 'lockstep_timeouts': 0,
            'longest_tick_interval': None, 'decision_timeouts': None}


def _summarise(result: WalkResult, out: Path, rate: float) -> int:
    """Print the per-step table and the outcome, write ``summary.json``; return the code."""
    rows = rows_from_reports(result.reports)
    print(format_table(rows) if rows else '[walker] no step was taken')
    def speed(seconds: float) -> float:
        return result.sim_time / seconds if seconds > 0 else float('nan')
    print(f'[walker] loop: headless, lock-stepped by calls, {result.periods} periods of '
          f'{1e3 / rate:g} ms; {result.sim_time:.1f} s simulated in {result.wall_time:.1f} s '
          f'of wall time ({speed(result.wall_time):.1f} x real time), the loop '
          f'{result.cpu_time:.1f} s of CPU ({speed(result.cpu_time):.1f} x real time on one '
          'core)')
    write_json(rows, out / 'summary.json',
               {'target': result.target, 'reached': result.reached,
                'message': result.message, 'path': list(result.path),
                'timed_out': result.timed_out,
                'wall_time': result.wall_time, 'loop': loop_record(result),
                'runner': 'headless'})
    if result.reached:
        print(f'[walker] reached {result.target} in {result.steps_taken} steps, '
              f'{result.duration:.1f} s of walking; summary in {out / "summary.json"}')
        return 0
    print(f'[walker] the walk to {result.target} did not reach it: {result.message}')
    return 1
