"""A walk sent to running graphs: the goal, its progress line, the table and ``summary.json``.

The graph backend of the walk session (:class:`~walker_bringup.graph_session.GraphBackend`)
brings the graphs up and down; this module walks them once they are up: one walker
(:func:`walk_one`), or several at once, one thread each (:func:`walk_several`). Each walk's
outcome is printed (the per-step table, the loop's record, what the bag lacks) and written to
``summary.json`` (``summary_<walker>.json`` for the second walker on), and returned as a
:class:`~walker_core.walk_summary.WalkSummary`.
"""

from __future__ import annotations

import threading
import time

from walker_bag.core.losses import loss_lines
from walker_core.progress import step_progress, walk_progress
from walker_core.walk_summary import Runner, WalkSummary
from walker_report.core.steps import format_table, rows_from_reports, write_json

from walker_bringup.graph_client import WalkInterruptedError
from walker_bringup.graph_walkers import GraphWalker

__all__ = ['walk_one', 'walk_several', 'SUMMARY_FILE']

#: The first walker's summary in the output directory.
SUMMARY_FILE = 'summary.json'
#: How long the client listens for the last step report after the goal's result [s].
_LAST_REPORT_WAIT = 0.5
_OUTPUT = threading.Lock()  # the walkers' tables and lines are printed whole, one at a time


def walk_one(backend, walker: GraphWalker, target: str, goal: str, should_stop,
             label: str = '', summary_name: str = SUMMARY_FILE) -> WalkSummary:
    """Send ``walker`` a ``walk_to`` (or ``step``) goal to ``target``; print, write, return.

    Parameters
    ----------
    backend : GraphBackend
        The session's backend: its options, configuration, output directory and progress line.
    walker : GraphWalker
        The walker whose graph is up.
    target : str
        The node walked to (this walker's own).
    goal : str
        ``'walk_to'`` or ``'step'``.
    should_stop : callable
        Polled while the goal runs: True stops it safely (:class:`WalkInterruptedError`).
    label, summary_name : str
        The walker's name in the output ('' for a single walker), and its summary file.
    """
    client, progress, out = walker.client, backend.progress, backend.out
    started = time.monotonic()
    prefix = f'{label}: ' if label else ''

    def on_feedback(feedback) -> None:
        elapsed = time.monotonic() - started
        text = walk_progress(feedback.step_index, feedback.step_count, feedback.phase,
                             feedback.from_node, feedback.to_node,
                             feedback.tip_position_error, elapsed) \
            if goal == 'walk_to' else step_progress(target, feedback.phase,
                                                    feedback.tip_position_error, elapsed)
        progress.update(f'[walker] {prefix}{text}',
                        key=(label, getattr(feedback, 'step_index', 0), feedback.phase))

    progress.say(f'[walker] {prefix}walking to {target}')
    send = client.walk_to if goal == 'walk_to' else client.step
    _status, result = send(target, backend.options.walk_timeout, on_feedback, should_stop)
    client.spin_for(_LAST_REPORT_WAIT)
    rows = rows_from_reports(client.reports)
    summary = WalkSummary(
        target, bool(result.success), result.message,
        tuple(result.path) if goal == 'walk_to' else
        ((result.base_node,) if result.success else ()),
        getattr(result, 'steps_taken', int(bool(result.success))),
        getattr(result, 'duration', 0.0), tuple(rows), time.monotonic() - started,
        Runner.GRAPH, None if client.loop is None else client.loop.as_dict(),
        walker.processes(), False, walker.namespace)
    with _OUTPUT:
        progress.say('')
        if label:
            print(f'[walker] {label}:')
        print(format_table(rows) if rows else '[walker] no step was taken')
        if client.loop is not None:
            print(f'[walker] {prefix}'
                  f'{client.loop.summary(backend.configuration.walker.timing.control_rate)}')
        recording = walker.recording()
        for line in loss_lines(recording) if recording else []:
            print(f'[walker] {prefix}the bag lacks messages: {line}')
        write_json(rows, out / summary_name,
                   {**summary.json_fields('target', 'reached', 'message', 'path', 'wall_time',
                                          'loop', 'processes'),
                    'recording': recording,
                    **(summary.json_fields('namespace') if label else {})})
        if summary.reached:
            print(f'[walker] {prefix}reached {target} in {summary.steps_taken} steps, '
                  f'{summary.duration:.1f} s of walking; summary in {out / summary_name}')
        else:
            print(f'[walker] {prefix}the walk to {target} did not reach it: {result.message}')
    return summary


def walk_several(backend, goal: str) -> list[WalkSummary]:
    """Walk every walker to its target at once, one thread each; the first error stops all.

    Returns the summaries in the walkers' order; re-raises the first error that is not an
    interruption caused by another walker's.
    """
    errors: list[BaseException] = []
    summaries: dict[str, WalkSummary] = {}

    def walk(walker: GraphWalker) -> None:
        name = SUMMARY_FILE if walker.namespace == '/walker' else \
            f'summary_{walker.label}.json'
        try:
            summaries[walker.namespace] = walk_one(
                backend, walker, walker.target, goal,
                lambda: bool(errors) or backend.should_stop(), walker.label, name)
        except BaseException as error:  # re-raised in the main thread
            errors.append(error)

    threads = [threading.Thread(target=walk, args=(w,), name=w.label) for w in backend.walkers]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    if errors:
        raise next((e for e in errors if not isinstance(e, WalkInterruptedError)), errors[0])
    return [summaries[w.namespace] for w in backend.walkers]
