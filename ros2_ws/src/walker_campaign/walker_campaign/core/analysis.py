"""What a campaign's results say, and over a sweep's grid, each point's figures.

Success with its interval, distributions, causes, sensitivities, the Pareto front, and for a
route walked more than once on the same truss (``route.walks``) each walk's figures side by
side (:class:`WalkFigures`).

Input: :class:`~walker_campaign.core.results.Results`; output: plain dataclasses the figures and
the Markdown draw from, and that :func:`as_json` writes. Figures of steps are over every step
taken (a failed step included: its time and error are what the walk did); the success of a
run is reaching its target.
"""

from __future__ import annotations

import collections
import dataclasses
import math
import re
import statistics as pystats
from typing import Any

from walker_campaign.core.results import Results
from walker_campaign.core.statistics import (
    Sensitivity, pareto_front, quantiles, rank_correlations, wilson_interval)

__all__ = ['CONFIDENCE', 'RUN_FIGURES', 'Rate', 'PointSummary', 'CauseCount', 'WalkFigures',
           'Analysis', 'analyse', 'compare_walks', 'as_json']

CONFIDENCE = 0.95
#: Run figures whose sensitivity to each dispersed parameter is reported (name: label).
RUN_FIGURES = {'reached': 'reached (1) or not (0)', 'bound_ratio': 'walk time / bound',
               'step_ratio_max': 'slowest step / its bound', 'tip_error_max': 'largest tip error',
               'tip_error_mean': 'mean tip error', 'jams': 'jammed screw-ins'}
_WALK_REACHED = re.compile(r'walk(\d+)\.reached')


@dataclasses.dataclass(frozen=True)
class Rate:
    """A success rate: successes of trials and its Wilson interval at :data:`CONFIDENCE`."""

    successes: int
    trials: int
    low: float
    high: float

    @property
    def value(self) -> float:
        """The observed rate (NaN without trials)."""
        return self.successes / self.trials if self.trials else math.nan

    @classmethod
    def of(cls, successes: int, trials: int) -> 'Rate':
        """Return the rate and its interval."""
        return cls(successes, trials, *wilson_interval(successes, trials, CONFIDENCE))


@dataclasses.dataclass(frozen=True)
class PointSummary:
    """One grid point's figures (over its runs and their steps)."""

    point: int
    setting: dict[str, Any]
    rate: Rate
    step_ratio_median: float
    step_ratio_p90: float
    tip_error_median: float
    tip_error_p90: float
    jams: int
    pareto: bool = False


@dataclasses.dataclass(frozen=True)
class WalkFigures:
    """The ``k``-th walk of a route walked several times on the same truss, over the runs.

    Attributes
    ----------
    walk : int
        ``k`` (1: the first walk, from the spec's survey or the nominal truss).
    rate : Rate
        Runs whose ``k``-th walk reached the target, of the runs walked.
    steps, probes, jams : int
        Steps taken, search probes and jammed screw-ins of the ``k``-th walks, in all.
    bound_ratio_median : float
        Median over the runs of the walk's time over its time-optimal bound.
    """

    walk: int
    rate: Rate
    steps: int
    probes: int
    jams: int
    bound_ratio_median: float


@dataclasses.dataclass(frozen=True)
class CauseCount:
    """How often something went wrong, and the first runs it did so in."""

    cause: str
    count: int
    runs: tuple[int, ...]


@dataclasses.dataclass(frozen=True)
class Analysis:
    """Everything the report shows."""

    header: dict[str, Any]
    rate: Rate
    outcomes: dict[str, int]
    step_ratios: list[float]
    tip_errors: list[float]
    step_quantiles: dict[str, dict[float, float]]
    safe_holds: list[CauseCount]
    errors: list[CauseCount]
    jams: dict[str, int]
    sensitivities: list[Sensitivity]
    points: list[PointSummary]
    failed_runs: list[dict[str, Any]]
    walks: list[WalkFigures] = dataclasses.field(default_factory=list)

    @property
    def draw_columns(self) -> list[str]:
        """The dispersed parameters' columns, in spec order."""
        return [c for d in self.header.get('dispersions', []) for c in d['columns']]

    @property
    def sweep_keys(self) -> list[str]:
        """The swept settings, in spec order."""
        return [s['key'] for s in self.header.get('sweeps', [])]


def _values(rows: list[dict[str, Any]], key: str) -> list[float]:
    return [float(r[key]) for r in rows if r.get(key) is not None]


def _causes(runs: list[dict[str, Any]], outcome: str, shown: int = 5) -> list[CauseCount]:
    grouped: dict[str, list[int]] = collections.defaultdict(list)
    for row in runs:
        if row['outcome'] == outcome:
            grouped[row['cause'] or 'unknown'].append(row['index'])
    return sorted((CauseCount(c, len(i), tuple(i[:shown])) for c, i in grouped.items()),
                  key=lambda c: (-c.count, c.cause))


def _median(values: list[float]) -> float:
    return pystats.median(values) if values else math.nan


def _points(results: Results) -> list[PointSummary]:
    sweeps = results.header.get('sweeps', [])
    runs_by_point: dict[int, list[dict[str, Any]]] = collections.defaultdict(list)
    for row in results.run_rows:
        runs_by_point[row['point']].append(row)
    steps_by_point: dict[int, list[dict[str, Any]]] = collections.defaultdict(list)
    for row in results.step_rows:
        steps_by_point[row['point']].append(row)
    summaries = []
    for point in sorted(runs_by_point):
        runs, steps = runs_by_point[point], steps_by_point[point]
        ratios, errors = _values(steps, 'bound_ratio'), _values(steps, 'tip_error')
        setting = {s['key']: runs[0].get(f'sweep.{s["key"]}') for s in sweeps}
        summaries.append(PointSummary(
            point, setting, Rate.of(sum(r['reached'] for r in runs), len(runs)),
            _median(ratios), quantiles(ratios, (0.9,))[0.9], _median(errors),
            quantiles(errors, (0.9,))[0.9], sum(r['jams'] or 0 for r in runs)))
    if len(summaries) > 1:
        front = set(pareto_front([p.step_ratio_median for p in summaries],
                                 [p.tip_error_p90 for p in summaries]))
        summaries = [dataclasses.replace(p, pareto=i in front) for i, p in enumerate(summaries)]
    return summaries


def compare_walks(runs: list[dict[str, Any]]) -> list[WalkFigures]:
    """Return each walk's figures of runs that walked their route several times (else none).

    ``runs``: the run rows; those of runs that could not be carried out are left out.
    """
    walked = [r for r in runs if r['outcome'] != 'error']
    numbers = sorted({int(m.group(1)) for r in walked for m in map(_WALK_REACHED.fullmatch, r)
                      if m})
    figures = []
    for k in numbers:
        rows = [r for r in walked if f'walk{k}.reached' in r]
        figures.append(WalkFigures(
            k, Rate.of(sum(bool(r[f'walk{k}.reached']) for r in rows), len(rows)),
            sum(r[f'walk{k}.steps'] or 0 for r in rows),
            sum(r[f'walk{k}.probes'] or 0 for r in rows),
            sum(r[f'walk{k}.jams'] or 0 for r in rows),
            _median(_values(rows, f'walk{k}.bound_ratio'))))
    return figures


def _looks(runs: list[dict[str, Any]]) -> dict[str, int]:
    """Return the wrist cameras' counts over the runs that looked (none: nothing to say)."""
    looked = [r for r in runs if r.get('looks')]
    if not looked:
        return {}
    return {'looks through the wrist camera': sum(r['looks'] for r in looked),
            'looks that did not see the hole': sum(r.get('looks_unseen') or 0 for r in looked)}


def _grip_losses(runs: list[dict[str, Any]]) -> dict[str, int]:
    """Return the grip monitor's counts over the runs that carry them (none: nothing to say)."""
    monitored = [r for r in runs if r.get('grip_losses') is not None]
    if not monitored:
        return {}
    return {'grip losses (gripper states with no gripper attached)':
            sum(r['grip_losses'] for r in monitored),
            'runs with a grip loss': sum(1 for r in monitored if r['grip_losses'] > 0),
            'runs with the grip monitor': len(monitored)}


def analyse(results: Results) -> Analysis:
    """Compute what the report shows from a campaign's results."""
    runs, steps = results.run_rows, results.step_rows
    walked = [r for r in runs if r['outcome'] != 'error']
    outcomes = collections.Counter(r['outcome'] for r in runs)
    ratios, errors = _values(steps, 'bound_ratio'), _values(steps, 'tip_error')
    vision = [e for r in walked for e in r.get('vision_errors') or []]
    jam_steps = [s for s in steps if s.get('jams')]
    draw_columns = [c for d in results.header.get('dispersions', []) for c in d['columns']]
    sensitivities = rank_correlations(
        {c: [r.get(f'draw.{c}') for r in walked] for c in draw_columns},
        {f: [float(r[f]) if r.get(f) is not None else None for r in walked]
         for f in RUN_FIGURES}) if draw_columns and walked else []
    failed = [{k: r.get(k) for k in ('index', 'replicate', 'point', 'outcome', 'cause',
                                     'message')}
              for r in runs if r['outcome'] != 'reached']
    return Analysis(
        header=results.header,
        # a run that could not be carried out says nothing of the walker: not a trial
        rate=Rate.of(sum(r['reached'] for r in walked), len(walked)),
        outcomes=dict(outcomes), step_ratios=ratios, tip_errors=errors,
        step_quantiles={'bound_ratio': quantiles(ratios, (0.5, 0.9, 0.99, 1.0)),
                        'tip_error': quantiles(errors, (0.5, 0.9, 0.99, 1.0)),
                        **({'vision_error': quantiles(vision, (0.5, 0.9, 0.95, 0.99, 1.0))}
                           if vision else {})},
        safe_holds=_causes(runs, 'failed'), errors=_causes(runs, 'error'),
        jams={'jammed screw-ins': sum(s['jams'] for s in jam_steps),
              'steps with a jam': len(jam_steps),
              'runs with a jam': len({s['index'] for s in jam_steps}),
              'steps': len(steps),
              **_looks(runs),
              **_grip_losses(runs)},
        sensitivities=sensitivities, points=_points(results), failed_runs=failed,
        walks=compare_walks(runs))


def _clean(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {str(k): _clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value]
    return value


def as_json(analysis: Analysis) -> dict[str, Any]:
    """Return the analysis as JSON-ready data (NaN as ``None``), for ``report.json``."""
    rate = analysis.rate
    return _clean({
        'campaign': analysis.header.get('name'), 'digest': analysis.header.get('digest'),
        'success': {'reached': rate.successes, 'walks': rate.trials, 'rate': rate.value,
                    'confidence': CONFIDENCE, 'wilson_low': rate.low, 'wilson_high': rate.high},
        'outcomes': analysis.outcomes, 'step_quantiles': analysis.step_quantiles,
        'jams': analysis.jams,
        'safe_holds': [dataclasses.asdict(c) for c in analysis.safe_holds],
        'errors': [dataclasses.asdict(c) for c in analysis.errors],
        'sensitivity': [dataclasses.asdict(s) for s in analysis.sensitivities],
        'points': [{**dataclasses.asdict(p), 'rate': p.rate.value, 'wilson_low': p.rate.low,
                    'wilson_high': p.rate.high, 'reached': p.rate.successes,
                    'walks': p.rate.trials} for p in analysis.points],
        'not_reached': analysis.failed_runs,
        'walks': [{**dataclasses.asdict(w), 'rate': w.rate.value, 'wilson_low': w.rate.low,
                   'wilson_high': w.rate.high, 'reached': w.rate.successes,
                   'runs': w.rate.trials} for w in analysis.walks]})
