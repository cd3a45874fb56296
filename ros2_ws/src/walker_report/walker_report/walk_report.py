"""``walk_report``: the report of a recorded walk, from its bag.

Usage: ``walk_report <bag> [--out DIR] [--params-file F] [--quiet] [--no-animation] [--fps N]``.
Writes ``report.md`` with its figures (PNG), the numbers (``report.json``) and an animation
(GIF) into ``DIR`` (default ``<bag>_report`` beside the bag), prints the per-step table and a
summary, and the paths written. Exit code 0 when the report was written, 2 when the bag, the
parameter file or an option was refused (with the reason on stderr).
"""

from __future__ import annotations

import argparse
import re
import sys
import time
from pathlib import Path

from walker_report.core.animation import AnimationOptions
from walker_report.core.errors import ReportError
from walker_report.core.report import ReportOptions, ReportResult, make_report
from walker_report.progress import ProgressLine

__all__ = ['main', 'parse_arguments', 'written_text', 'report_after_walk']


def _frame_size(text: str) -> tuple[int, int]:
    match = re.fullmatch(r'(\d+)x(\d+)', text.strip())
    if match is None:
        raise argparse.ArgumentTypeError(f'expected WIDTHxHEIGHT in pixels, e.g. 640x400, '
                                         f'got {text!r}')
    return int(match.group(1)), int(match.group(2))


def _positive(kind):
    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f'expected a positive number, got {text!r}') \
                from None
        if not value > 0 or value != value or value == float('inf'):
            raise argparse.ArgumentTypeError(f'expected a positive number, got {text!r}')
        return value
    return parse


def parse_arguments(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line options of ``walk_report``."""
    parser = argparse.ArgumentParser(
        prog='walk_report', description='Write the report of a recorded walk (Markdown with '
        'figures and an animation) from its rosbag2 bag, and print its summary.')
    parser.add_argument('bag', type=Path, help='the bag directory (or its .mcap file)')
    parser.add_argument('--out', type=Path, default=None,
                        help='output directory (default: <bag>_report beside the bag)')
    parser.add_argument('--params-file', type=Path, default=None,
                        help='the parameter file the walk ran with (default: the installed '
                             'walker.yaml): truss layout, tolerances, settling window')
    parser.add_argument('--quiet', action='store_true',
                        help='no progress; print only the summary and the paths written')
    parser.add_argument('--no-animation', dest='animation', action='store_false',
                        help='skip the animation (the slowest part)')
    parser.add_argument('--fps', type=_positive(float), default=10.0,
                        help='animation frames per second of the walk (default %(default)s)')
    parser.add_argument('--max-frames', type=_positive(int), default=600,
                        help='most animation frames; a longer walk plays faster '
                             '(default %(default)s)')
    parser.add_argument('--frame-size', type=_frame_size, default=(640, 400),
                        metavar='WxH', help='animation frame size in pixels (default 640x400)')
    parser.add_argument('--namespace', default=None,
                        help='the robot namespace in the bag (default: found from the topics)')
    parser.add_argument('--settle-time', type=_positive(float), default=None,
                        help='settling window before insertion for the vibration figures [s] '
                             '(default: supervisor.settle_time of the parameter file)')
    return parser.parse_args(argv)


def written_text(result: ReportResult) -> str:
    """Return the lines naming what a report wrote."""
    lines = [f'report: {result.markdown}',
             f'figures: {", ".join(p.name for p in result.figures.values())} '
             f'(in {result.directory})']
    if result.animation is not None:
        lines.append(f'animation: {result.animation.path} ({result.animation.frames} frames, '
                     f'rendered in {result.animation.seconds:.1f} s)')
    lines.append(f'numbers: {result.json}')
    return '\n'.join(lines)


def report_after_walk(bag: Path, report_dir: Path, params_file: Path | None,
                      quiet: bool) -> bool:
    """Make the walk report of ``bag`` into ``report_dir`` at the end of a walk; say where.

    What ``run_all.py`` does once a walk has ended, on the graph or headless: its lines start
    with ``[walker]``. Returns False (having said why) when the report could not be made; the
    walk's own outcome stands.
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


def main(argv: list[str] | None = None) -> int:
    """Make the report; return the exit code."""
    args = parse_arguments(argv)
    progress = ProgressLine(args.quiet, prefix='[walk_report]')
    started = time.monotonic()
    try:
        animation = AnimationOptions(args.fps, args.max_frames, *args.frame_size)
        options = ReportOptions(args.animation, animation, args.namespace, args.settle_time)
        result = make_report(args.bag, args.out, args.params_file, options, progress)
    except (ReportError, ValueError) as error:
        progress.close()
        print(f'walk_report: error: {error}', file=sys.stderr)
        return 2
    progress.close()
    print(result.summary)
    print(written_text(result))
    if not args.quiet:
        print(f'[walk_report] done in {time.monotonic() - started:.1f} s')
    return 0


if __name__ == '__main__':
    sys.exit(main())
