"""A walk's outcome as result rows: one per step, one for the run, each with its parameters.

A walk (headless or the graph) ends in the summary ``run_all.py`` writes (``summary.json``:
the per-step table of :mod:`walker_report.core.steps` and the walk's end). Every row carries the
run's identity and parameters (``sweep.<key>``, ``draw.<column>``), so a step row alone says
under which truth and settings it was walked. Figures are SI (s, m); a figure that does not
exist (no step taken, an unknown bound) is ``None``.

The run row's ``outcome`` is ``reached`` (the walk got to its target), ``failed`` (it ended in
a safe hold, ``cause`` saying why), ``timeout`` (it ran out of wall-clock time), or ``error``
(the run could not be carried out: a parameter refused, a crash; ``message`` says what). Only
``exec.*`` fields (wall time, host, process) differ when a run is repeated; the rest of a row is
reproduced exactly (:func:`deterministic_part`).

A run that walks its route several times on the same truss (a spec's ``route.walks``) gives
one summary of its walks (:func:`combined_summary`): its step rows carry ``walk`` (1, 2, ...),
its run row is reached when every walk reached, and adds ``walk<k>.<figure>`` for each walk
(:data:`WALK_FIGURES`: reached, steps, probes, jams, walk time and its ratio to the bound).

The run row carries the wrist camera's figures when the walk looked (``looks``,
``looks_unseen``, ``vision_errors``: :func:`_look_figures`), and the grip monitor's count
from the summary's ``grip_monitor``:
``grip_states`` (the plant's gripper-state messages) and ``grip_losses`` (those with no
gripper attached: the walker let go of the truss); both ``None`` for a summary without one
(the graph's, or results written before the count existed).
"""

from __future__ import annotations

import math
import re
import statistics
from collections.abc import Mapping
from typing import Any

from walker_campaign.core.plan import RunPlan

__all__ = ['OUTCOMES', 'RUN', 'STEP', 'cause_of', 'run_rows', 'error_rows', 'deterministic_part',
           'EXEC_PREFIX', 'combined_summary', 'WALK_FIGURES']

OUTCOMES = ('reached', 'failed', 'timeout', 'error')
RUN, STEP = 'run', 'step'
#: Fields that describe how a run was executed, not what it gave.
EXEC_PREFIX = 'exec.'
#: The figures of each walk of a repeated route in the run row, as ``walk<k>.<figure>``.
WALK_FIGURES = ('steps', 'steps_ok', 'probes', 'jams', 'walk_time', 'bound', 'bound_ratio')
_NUMBER = re.compile(r'[-+]?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?')


def cause_of(message: str) -> str:
    """Return the cause of a failure, for counting: the message's first clause, numbers as ``#``.

    ``'insertion jammed 3 times: tip 2.31 mm off'`` -> ``'insertion jammed # times'``.
    """
    head = re.split(r'[:;(]', message or '', maxsplit=1)[0].strip()
    return _NUMBER.sub('#', head) or 'unknown'


def _finite(value: Any) -> float | None:
    if value is None or isinstance(value, bool):
        return None
    value = float(value)
    return value if math.isfinite(value) else None


def _identity(campaign: str, plan: RunPlan) -> dict[str, Any]:
    row: dict[str, Any] = {'campaign': campaign, 'index': plan.index,
                           'replicate': plan.replicate, 'point': plan.point,
                           'seed': plan.imperfection_seed}
    row.update({f'sweep.{k}': (list(v) if isinstance(v, tuple) else v)
                for k, v in plan.sweep.items()})
    row.update({f'draw.{k}': v for k, v in plan.draws.items()})
    return row


def _step_row(identity: Mapping[str, Any], step: Mapping[str, Any]) -> dict[str, Any]:
    success = bool(step.get('success'))
    attempts = int(step.get('attempts') or 0)
    duration, bound = _finite(step.get('duration')), _finite(step.get('bound'))
    row = {'kind': STEP, **identity, 'step': int(step['index']),
           'gripper': step.get('gripper', ''), 'from_node': step.get('from_node', ''),
           'to_node': step.get('to_node', ''), 'sweep_angle': _finite(step.get('sweep')),
           'success': success, 'duration': duration, 'bound': bound,
           'bound_ratio': duration / bound if duration is not None and bound else None,
           'tip_error': _finite(step.get('insertion_error')),
           'tip_error_estimated': _finite(step.get('insertion_error_estimated')),
           'residual_vibration': _finite(step.get('residual_vibration')),
           'attempts': attempts,
           # a step that ended attached screwed in once more than it jammed; one aborted
           # counts its jammed screw-ins as its attempts
           'jams': attempts - 1 if success else attempts,
           'probes': int(step.get('search_probes') or 0),
           'hole_offset': _finite(step.get('hole_offset')),
           'message': step.get('message', '') or '',
           'cause': '' if success else cause_of(step.get('message', ''))}
    if 'walk' in step:
        row['walk'] = int(step['walk'])
    for phase, seconds in (step.get('phase_durations') or {}).items():
        row[f'phase.{phase}'] = _finite(seconds)
    return row


def _summary_figures(steps: list[dict[str, Any]]) -> dict[str, Any]:
    def values(key: str) -> list[float]:
        return [s[key] for s in steps if s[key] is not None]

    ratios, errors = values('bound_ratio'), values('tip_error')
    walked, bound = sum(values('duration')), sum(values('bound'))
    return {
        'steps': len(steps), 'steps_ok': sum(s['success'] for s in steps),
        'jams': sum(s['jams'] for s in steps),
        'probes': sum(s['probes'] for s in steps),
        'walk_time': walked if steps else None,
        'bound': bound if steps else None,
        'bound_ratio': walked / bound if bound > 0 else None,
        'step_ratio_median': statistics.median(ratios) if ratios else None,
        'step_ratio_max': max(ratios) if ratios else None,
        'tip_error_mean': statistics.fmean(errors) if errors else None,
        'tip_error_max': max(errors) if errors else None,
        'vibration_max': max(values('residual_vibration'), default=None)}


def _grip_monitor(summary: Mapping[str, Any]) -> dict[str, int | None]:
    """Return the run row's ``grip_states`` and ``grip_losses`` (None without a monitor)."""
    monitor = summary.get('grip_monitor')
    if not isinstance(monitor, Mapping):
        return {'grip_states': None, 'grip_losses': None}
    return {'grip_states': int(monitor.get('states') or 0),
            'grip_losses': int(monitor.get('no_gripper_attached') or 0)}


def _look_figures(looks: list[Mapping[str, Any]]) -> dict[str, Any]:
    """Return the run row's wrist camera figures (all None for a walk that never looked).

    ``looks`` and ``looks_unseen`` (frames that did not show the hole), and ``vision_errors``
    [m]: for each approach's last look, how far the hole the looks located was from the
    truth (the summary's ``looks``, :func:`walker_headless.shell.look_record`).
    """
    if not looks:
        return {'looks': None, 'looks_unseen': None, 'vision_errors': None}
    return {'looks': len(looks), 'looks_unseen': sum(not look.get('seen') for look in looks),
            'vision_errors': [float(look['error']) for look in looks
                              if look.get('final') and look.get('error') is not None]}


def run_rows(campaign: str, plan: RunPlan, summary: Mapping[str, Any],
             execution: Mapping[str, Any] | None = None) -> list[dict[str, Any]]:
    """Return the rows of a walk: one per step, then the run's (which marks the run as done).

    Parameters
    ----------
    campaign : str
        The campaign's name.
    plan : RunPlan
        The run.
    summary : mapping
        The walk's summary (``summary.json``): ``steps``, ``reached``, ``message``, and
        ``timed_out`` when the walk ran out of time.
    execution : mapping, optional
        How the run was executed (wall time, host, ...): stored as ``exec.<key>``.
    """
    identity = _identity(campaign, plan)
    steps = [_step_row(identity, s) for s in summary.get('steps') or []]
    reached = bool(summary.get('reached'))
    message = str(summary.get('message') or '')
    failed_step = next((s for s in steps if not s['success']), None)
    if reached:
        outcome, cause = 'reached', ''
    elif summary.get('timed_out'):
        outcome, cause = 'timeout', 'the walk ran out of wall-clock time'
    else:
        outcome = 'failed'
        cause = failed_step['cause'] if failed_step else cause_of(message)
    run = {'kind': RUN, **identity, 'outcome': outcome, 'reached': reached, 'cause': cause,
           'message': message, **_summary_figures(steps), **_grip_monitor(summary),
           **_look_figures(summary.get('looks') or [])}
    for number, walk in enumerate(summary.get('walks') or [], start=1):
        figures = _summary_figures([s for s in steps if s.get('walk') == number])
        run[f'walk{number}.reached'] = bool(walk.get('reached'))
        run.update({f'walk{number}.{k}': figures[k] for k in WALK_FIGURES})
    run.update({f'{EXEC_PREFIX}{k}': v for k, v in (execution or {}).items()})
    return steps + [run]


def combined_summary(summaries: list[Mapping[str, Any]]) -> dict[str, Any]:
    """Return one summary of walks of the same route on the same truss, in order.

    Its ``steps`` are every walk's, each with ``walk`` (1, 2, ...); ``reached`` when every walk
    reached; ``grip_monitor`` the walks' counts summed (when every walk has one); ``message``
    the first walk's that did not reach (else the last's); ``timed_out`` when one ran out of
    time; ``walks`` each walk's ``reached``, ``timed_out`` and ``message``.
    """
    if not summaries:
        raise ValueError('a combined summary needs at least one walk')
    steps = [{**step, 'walk': number} for number, summary in enumerate(summaries, start=1)
             for step in summary.get('steps') or []]
    short = next((s for s in summaries if not s.get('reached')), summaries[-1])
    monitors = [s.get('grip_monitor') for s in summaries]
    monitor = ({'states': sum(int(m.get('states') or 0) for m in monitors),
                'no_gripper_attached': sum(int(m.get('no_gripper_attached') or 0)
                                           for m in monitors)}
               if all(isinstance(m, Mapping) for m in monitors) else None)
    looks = [look for summary in summaries for look in summary.get('looks') or []]
    return {'steps': steps, 'reached': all(bool(s.get('reached')) for s in summaries),
            **({'looks': looks} if looks else {}),
            **({'grip_monitor': monitor} if monitor is not None else {}),
            'message': str(short.get('message') or ''),
            'timed_out': any(bool(s.get('timed_out')) for s in summaries),
            'walks': [{'reached': bool(s.get('reached')), 'timed_out': bool(s.get('timed_out')),
                       'message': str(s.get('message') or '')} for s in summaries]}


def error_rows(campaign: str, plan: RunPlan, message: str,
               execution: Mapping[str, Any] | None = None) -> list[dict[str, Any]]:
    """Return the row of a run that could not be carried out (``outcome`` ``error``)."""
    run = {'kind': RUN, **_identity(campaign, plan), 'outcome': 'error', 'reached': False,
           'cause': cause_of(message), 'message': message, **_summary_figures([])}
    run.update({f'{EXEC_PREFIX}{k}': v for k, v in (execution or {}).items()})
    return [run]


def deterministic_part(row: Mapping[str, Any]) -> dict[str, Any]:
    """Return a row without its ``exec.*`` fields: what a repeated run reproduces exactly."""
    return {k: v for k, v in row.items() if not k.startswith(EXEC_PREFIX)}
