"""The campaign report: Markdown with its PNG figures and a JSON of its numbers.

What :func:`make_campaign_report` writes into its output directory:

=====================  ==================================================================
``report.md``          the report: the campaign, its success rate (Wilson interval), the
                       dispersions, the step figures' quantiles, jams and safe holds by
                       cause, sensitivities, the sweep's grid and Pareto front, the runs
                       that did not reach their target (and how to see one's walk)
``report.json``        its numbers
``outcomes.png``       success rate with its interval (per grid point), causes
``distributions.png``  histograms and CDFs of step time / bound and tip error
``sensitivity.png``    Spearman's rho of each run figure with each dispersed parameter
``grid.png``           the figures over the sweep's grid (with sweeps)
``pareto.png``         speed against precision over the grid points (with sweeps)
=====================  ==================================================================
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

from walker_campaign.core import figures
from walker_campaign.core.analysis import CONFIDENCE, RUN_FIGURES, Analysis, analyse, as_json
from walker_campaign.core.results import read_results

__all__ = ['CampaignReport', 'make_campaign_report', 'markdown']

_SHOWN_FAILURES = 20
_STRONG = 0.3  # |rho| from which a sensitivity is listed in the text


@dataclasses.dataclass(frozen=True)
class CampaignReport:
    """What was written."""

    markdown: Path
    json: Path
    figures: dict[str, Path]
    analysis: Analysis


def _pct(value: float) -> str:
    return '-' if not math.isfinite(value) else f'{100 * value:.1f} %'


def _num(value: float, scale: float = 1.0, digits: int = 2) -> str:
    return '-' if value is None or not math.isfinite(value) else f'{value * scale:.{digits}f}'


def _table(header: list[str], rows: list[list[str]]) -> list[str]:
    return (['| ' + ' | '.join(header) + ' |', '|' + '---|' * len(header)]
            + ['| ' + ' | '.join(str(c).replace('|', '\\|') for c in row) + ' |'
               for row in rows] + [''])


def markdown(analysis: Analysis, figure_names: dict[str, str], results_path: Path,
             spec_hint: str) -> str:
    """Return the report's Markdown text."""
    header, rate = analysis.header, analysis.rate
    lines = [f'# Campaign report: {header["name"]}', '']
    lines += [f'- results: `{results_path}` (campaign digest `{header["digest"]}`)',
              f'- seed {header["seed"]}, {header["runs"]} runs per grid point, '
              f'{header["points"]} grid point{"s" if header["points"] > 1 else ""}: '
              f'{header["total_runs"]} walks to `{header["target"]}`; nominal file '
              f'`{header["params_file"]}`',
              f'- finished: {sum(analysis.outcomes.values())} of {header["total_runs"]} '
              '(' + ', '.join(f'{n} {k}' for k, n in sorted(analysis.outcomes.items())) + ')',
              '']
    lines += ['## Success', '',
              f'**{_pct(rate.value)}** of the walks reached their target ({rate.successes} of '
              f'{rate.trials}); {100 * CONFIDENCE:.0f} % Wilson interval '
              f'**[{_pct(rate.low)}, {_pct(rate.high)}]**. Runs that could not be carried out '
              '(outcome `error`) are not counted as walks.', '',
              f'![outcomes]({figure_names["outcomes"]})', '']
    if header.get('dispersions'):
        lines += ['## Dispersions (the truth against the model)', '']
        lines += _table(['name', 'drawn as'], [[d['name'], d['describe']]
                                               for d in header['dispersions']])
    quant = analysis.step_quantiles
    lines += ['## Steps', '', f'Over every step taken ({len(analysis.step_ratios)} with a '
              'bound, '
              f'{len(analysis.tip_errors)} with a tip error):', '']
    lines += _table(['figure', 'median', 'p90', 'p99', 'max'], [
        ['step time / bound'] + [_num(quant['bound_ratio'][q]) for q in (0.5, 0.9, 0.99, 1.0)],
        ['tip error [mm]'] + [_num(quant['tip_error'][q], 1e3) for q in (0.5, 0.9, 0.99, 1.0)]])
    if 'vision_error' in quant:
        vision = quant['vision_error']
        lines += ['Vision error: where the looks located each hole before the descent, against '
                  "the plant's truth, in the gripper's frame:", '']
        lines += _table(['figure', 'median', 'p90', 'p95', 'p99', 'max'], [
            ['vision error [mm]'] + [_num(vision[q], 1e3) for q in (0.5, 0.9, 0.95, 0.99, 1.0)]])
    lines += [f'![distributions]({figure_names["distributions"]})', '']
    lines += ['## Jams and safe holds', '']
    lines += _table(['', 'count'], [[k, str(v)] for k, v in analysis.jams.items()])
    causes = ([['safe hold', c.cause, str(c.count), ', '.join(map(str, c.runs))]
               for c in analysis.safe_holds]
              + [['error', c.cause, str(c.count), ', '.join(map(str, c.runs))]
                 for c in analysis.errors])
    lines += _table(['ended in', 'cause', 'runs', 'first runs'], causes) if causes else \
        ['No walk ended in a safe hold or an error.', '']
    if analysis.sensitivities:
        lines += ['## Sensitivity', '',
                  "Spearman's rank correlation of each run figure with each dispersed "
                  'parameter (rho in [-1, 1]; p: the chance of a correlation this strong '
                  'without any relation).', '']
        strong = sorted((s for s in analysis.sensitivities
                         if math.isfinite(s.rho) and abs(s.rho) >= _STRONG),
                        key=lambda s: -abs(s.rho))
        lines += _table(['figure', 'parameter', 'rho', 'p', 'runs'], [
            [RUN_FIGURES[s.figure], s.parameter, f'{s.rho:+.2f}', f'{s.p_value:.1e}',
             str(s.count)] for s in strong]) if strong else \
            [f'No figure correlates with a dispersed parameter beyond |rho| = {_STRONG}.', '']
        lines += [f'![sensitivity]({figure_names["sensitivity"]})', '']
    if 'grid' in figure_names:
        keys = analysis.sweep_keys
        lines += ['## Sweep', '', 'Each grid point over the same dispersed truths (common '
                  'random numbers). Pareto front: no other point has both a smaller median '
                  'step time / bound and a smaller 90th percentile tip error.', '']
        lines += _table(['point'] + keys + ['reached', 'rate [95 % interval]',
                                            'step/bound median', 'tip p90 mm', 'jams',
                                            'Pareto'], [
            [str(p.point)] + [figures.setting_label(p.setting[k]) for k in keys]
            + [f'{p.rate.successes}/{p.rate.trials}',
               f'{_pct(p.rate.value)} [{_pct(p.rate.low)}, {_pct(p.rate.high)}]',
               _num(p.step_ratio_median), _num(p.tip_error_p90, 1e3), str(p.jams),
               'yes' if p.pareto else ''] for p in analysis.points])
        lines += [f'![grid]({figure_names["grid"]})', '',
                  f'![pareto]({figure_names["pareto"]})', '']
    if analysis.walks:
        lines += ['## The same truss, walk after walk', '',
                  'Each run walked its route several times on one drawn truss, each walk after '
                  'the first from the truss survey the one before it wrote: a row per walk.',
                  '']
        lines += _table(['walk', 'reached', 'rate [95 % interval]', 'steps', 'search probes',
                         'jams', 'walk time / bound, median'], [
            [str(w.walk), f'{w.rate.successes}/{w.rate.trials}',
             f'{_pct(w.rate.value)} [{_pct(w.rate.low)}, {_pct(w.rate.high)}]', str(w.steps),
             str(w.probes), str(w.jams), _num(w.bound_ratio_median)] for w in analysis.walks])
    if analysis.failed_runs:
        lines += ['## Runs that did not reach their target', '']
        lines += _table(['run', 'point', 'outcome', 'cause', 'message'], [
            [str(r['index']), str(r['point']), r['outcome'], r['cause'],
             (r['message'] or '')[:160]] for r in analysis.failed_runs[:_SHOWN_FAILURES]])
        if len(analysis.failed_runs) > _SHOWN_FAILURES:
            lines += [f'... and {len(analysis.failed_runs) - _SHOWN_FAILURES} more '
                      '(report.json lists them all).', '']
        lines += ['To see one of these walks (its bag and walk report), run it again alone: '
                  f'`{spec_hint} --run-index K --bag`.', '']
    return '\n'.join(lines)


def make_campaign_report(results_path: str | Path, out_dir: str | Path,
                         tolerance: float | None = None,
                         spec_hint: str = 'python3 scripts/campaign.py SPEC'
                         ) -> CampaignReport:
    """Write the report of a campaign's results file into ``out_dir``.

    Parameters
    ----------
    results_path : str or Path
        The campaign's results file.
    out_dir : str or Path
        Where to write (created).
    tolerance : float, optional
        The insertion tolerance [m], drawn on the tip error figures.
    spec_hint : str
        How the report tells the reader to re-run a walk.

    Raises
    ------
    ResultsError
        The results file cannot be read.
    """
    results_path = Path(results_path)
    analysis = analyse(read_results(results_path))
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = {'outcomes': figures.outcome_figure(analysis, out / 'outcomes.png'),
               'distributions': figures.distribution_figure(analysis, out / 'distributions.png',
                                                            tolerance)}
    if analysis.sensitivities:
        written['sensitivity'] = figures.sensitivity_figure(analysis, out / 'sensitivity.png')
    if len(analysis.points) > 1:
        written['grid'] = figures.grid_figure(analysis, out / 'grid.png')
        written['pareto'] = figures.pareto_figure(analysis, out / 'pareto.png')
    text = markdown(analysis, {k: p.name for k, p in written.items()}, results_path, spec_hint)
    markdown_path = out / 'report.md'
    markdown_path.write_text(text)
    json_path = out / 'report.json'
    json_path.write_text(json.dumps(as_json(analysis), indent=1))
    return CampaignReport(markdown_path, json_path, written, analysis)
