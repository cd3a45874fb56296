"""The campaign report's figures, drawn with matplotlib's Agg canvas (no display, no pyplot).

Each function draws one PNG from an :class:`~walker_campaign.core.analysis.Analysis`: lengths
in mm, times as ratios to the step's time-optimal bound. The walk report's resolution and
phase colours are kept (:mod:`walker_report.core.figures`).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from walker_campaign.core.analysis import RUN_FIGURES, Analysis, PointSummary
from walker_campaign.core.statistics import ecdf
from walker_report.core.figures import DPI

__all__ = ['outcome_figure', 'distribution_figure', 'sensitivity_figure', 'grid_figure',
           'setting_label',
           'pareto_figure', 'BOUND_TARGET', 'TIP_TARGETS']

#: The walking issue's step time target (times the bound) and the tip error targets [m].
BOUND_TARGET = 1.5
TIP_TARGETS = (0.0005, 0.001)
_OK, _BAD, _NEUTRAL = '#31a354', '#d62728', '#3182bd'


def _save(figure: Figure, path: Path) -> Path:
    figure.savefig(path, dpi=DPI, facecolor='white')
    return Path(path)


def setting_label(value) -> str:
    """Return a swept value as a short label (``5``, ``[4, 2, 2, 0, 0]``)."""
    if isinstance(value, float):
        return f'{value:g}'
    if isinstance(value, (list, tuple)):
        return '[' + ', '.join(setting_label(v) for v in value) + ']'
    return str(value)


def outcome_figure(analysis: Analysis, path: Path) -> Path:
    """Success rate with its interval (per grid point too), and what went wrong, by cause."""
    figure = Figure(figsize=(11, 4.2))
    left, right = figure.subplots(1, 2, gridspec_kw={'width_ratios': [1, 1.4]})
    rates = [('all', analysis.rate)] + ([(str(p.point), p.rate) for p in analysis.points]
                                        if 1 < len(analysis.points) <= 30 else [])
    for i, (_name, rate) in enumerate(rates):
        if rate.trials:
            left.bar(i, rate.value, color=_OK if i == 0 else _NEUTRAL, alpha=0.8)
            left.errorbar(i, rate.value, yerr=[[rate.value - rate.low], [rate.high - rate.value]],
                          color='black', capsize=4)
    left.set_xticks(range(len(rates)), [n for n, _ in rates])
    left.set_xlabel('grid point' if len(rates) > 1 else '')
    left.set_ylim(0, 1.05)
    left.set_ylabel('runs that reached the target')
    left.set_title(f'success rate, {analysis.rate.successes} of {analysis.rate.trials} walks '
                   f'(bars: 95 % Wilson)', fontsize=10)
    causes = ([(f'safe hold: {c.cause}', c.count, _BAD) for c in analysis.safe_holds]
              + [(f'error: {c.cause}', c.count, '#969696') for c in analysis.errors]
              + [('steps with a jammed screw-in', analysis.jams['steps with a jam'], '#fd8d3c')])
    causes = [c for c in causes if c[1]] or [('nothing went wrong', 0, _OK)]
    labels = [c[0] if len(c[0]) <= 60 else c[0][:57] + '...' for c in causes]
    right.barh(range(len(causes)), [c[1] for c in causes], color=[c[2] for c in causes])
    right.set_yticks(range(len(causes)), labels, fontsize=8)
    right.invert_yaxis()
    right.set_xlabel('count')
    right.set_title('jams and safe holds by cause', fontsize=10)
    figure.tight_layout()
    return _save(figure, path)


def distribution_figure(analysis: Analysis, path: Path, tolerance: float | None = None) -> Path:
    """Histograms and empirical CDFs of every step's time over its bound and tip error."""
    figure = Figure(figsize=(11, 7))
    axes = figure.subplots(2, 2)
    series = [(analysis.step_ratios, 1.0, 'step time / time-optimal bound', [BOUND_TARGET]),
              (analysis.tip_errors, 1e3, 'tip error as the screw-in starts [mm]',
               [1e3 * t for t in TIP_TARGETS] + ([1e3 * tolerance] if tolerance else []))]
    for column, (values, scale, label, marks) in enumerate(series):
        scaled = np.asarray(values, dtype=float) * scale
        histogram, cdf = axes[0, column], axes[1, column]
        if scaled.size:
            histogram.hist(scaled, bins=min(40, max(5, scaled.size // 5)), color=_NEUTRAL,
                           alpha=0.8)
            x, fraction = ecdf(scaled)
            cdf.step(x, fraction, where='post', color=_NEUTRAL)
        for mark in marks:
            for ax in (histogram, cdf):
                ax.axvline(mark, color=_BAD, linestyle='--', linewidth=1)
        histogram.set_title(f'{label}: {scaled.size} steps', fontsize=10)
        histogram.set_ylabel('steps')
        cdf.set_xlabel(label)
        cdf.set_ylabel('fraction of steps at or below')
        cdf.set_ylim(0, 1.02)
        cdf.grid(alpha=0.3)
    figure.tight_layout()
    return _save(figure, path)


def sensitivity_figure(analysis: Analysis, path: Path) -> Path:
    """Spearman's rho of each run figure with each dispersed parameter, as a heat map."""
    parameters = analysis.draw_columns
    figures = list(RUN_FIGURES)
    rho = np.full((len(figures), len(parameters)), np.nan)
    for s in analysis.sensitivities:
        rho[figures.index(s.figure), parameters.index(s.parameter)] = s.rho
    figure = Figure(figsize=(max(6.0, 1.1 * len(parameters) + 3.5), 4.2))
    ax = figure.subplots()
    image = ax.imshow(np.ma.masked_invalid(rho), cmap='RdBu_r', vmin=-1, vmax=1, aspect='auto')
    for (i, j), value in np.ndenumerate(rho):
        ax.text(j, i, '-' if math.isnan(value) else f'{value:+.2f}', ha='center', va='center',
                fontsize=8)
    ax.set_xticks(range(len(parameters)), parameters, rotation=30, ha='right', fontsize=8)
    ax.set_yticks(range(len(figures)), [RUN_FIGURES[f] for f in figures], fontsize=8)
    ax.set_title('sensitivity: Spearman rank correlation over the runs', fontsize=10)
    figure.colorbar(image, ax=ax, label='rho')
    figure.tight_layout()
    return _save(figure, path)


_GRID_FIGURES = (('rate', 'success rate', 'RdYlGn'),
                 ('step_ratio_median', 'median step time / bound', 'viridis_r'),
                 ('tip_error_p90', '90th percentile tip error [mm]', 'viridis_r'))


def _point_value(point: PointSummary, name: str) -> float:
    if name == 'rate':
        return point.rate.value
    value = getattr(point, name)
    return value * 1e3 if name.startswith('tip_error') else value


def grid_figure(analysis: Analysis, path: Path) -> Path:
    """Draw the figures over the sweep's grid.

    Lines for one swept setting, heat maps for two (further settings averaged over, as the
    caption says).
    """
    keys, points = analysis.sweep_keys, analysis.points
    figure = Figure(figsize=(13, 4.2))
    axes = figure.subplots(1, len(_GRID_FIGURES))
    if len(keys) == 1:
        labels = [setting_label(p.setting[keys[0]]) for p in points]
        for ax, (name, title, _) in zip(axes, _GRID_FIGURES, strict=True):
            values = [_point_value(p, name) for p in points]
            ax.plot(range(len(points)), values, 'o-', color=_NEUTRAL)
            if name == 'rate':
                ax.errorbar(range(len(points)), values, fmt='none', ecolor='black', capsize=3,
                            yerr=[[p.rate.value - p.rate.low for p in points],
                                  [p.rate.high - p.rate.value for p in points]])
            ax.set_xticks(range(len(points)), labels, fontsize=8)
            ax.set_xlabel(keys[0], fontsize=8)
            ax.set_title(title, fontsize=10)
            ax.grid(alpha=0.3)
    else:
        rows = sorted({setting_label(p.setting[keys[0]]) for p in points},
                      key=lambda t: [setting_label(p.setting[keys[0]]) for p in points].index(t))
        cols = sorted({setting_label(p.setting[keys[1]]) for p in points},
                      key=lambda t: [setting_label(p.setting[keys[1]]) for p in points].index(t))
        for ax, (name, title, cmap) in zip(axes, _GRID_FIGURES, strict=True):
            cells: dict[tuple[int, int], list[float]] = {}
            for p in points:
                cell = (rows.index(setting_label(p.setting[keys[0]])),
                        cols.index(setting_label(p.setting[keys[1]])))
                cells.setdefault(cell, []).append(_point_value(p, name))
            grid = np.full((len(rows), len(cols)), np.nan)
            for (i, j), values in cells.items():
                grid[i, j] = float(np.nanmean(values)) if np.isfinite(values).any() else np.nan
            image = ax.imshow(np.ma.masked_invalid(grid), cmap=cmap, aspect='auto',
                              origin='lower')
            for (i, j), value in np.ndenumerate(grid):
                ax.text(j, i, '-' if math.isnan(value) else f'{value:.2f}', ha='center',
                        va='center', fontsize=8)
            ax.set_xticks(range(len(cols)), cols, fontsize=8)
            ax.set_yticks(range(len(rows)), rows, fontsize=8)
            ax.set_xlabel(keys[1], fontsize=8)
            ax.set_ylabel(keys[0], fontsize=8)
            ax.set_title(title + (' (mean over the other settings)' if len(keys) > 2 else ''),
                         fontsize=9)
            figure.colorbar(image, ax=ax)
    figure.tight_layout()
    return _save(figure, path)


def pareto_figure(analysis: Analysis, path: Path) -> Path:
    """Draw each grid point's median step time / bound against its p90 tip error.

    The Pareto front (no point both faster and more precise) is joined.
    """
    points = analysis.points
    figure = Figure(figsize=(7.5, 5.5))
    ax = figure.subplots()
    for p in points:
        ax.plot(p.step_ratio_median, 1e3 * p.tip_error_p90, 'o',
                color=_OK if p.pareto else '#969696', markersize=8 if p.pareto else 6)
        ax.annotate(str(p.point), (p.step_ratio_median, 1e3 * p.tip_error_p90), fontsize=8,
                    xytext=(4, 4), textcoords='offset points')
    front = sorted((p for p in points if p.pareto), key=lambda p: p.step_ratio_median)
    ax.plot([p.step_ratio_median for p in front], [1e3 * p.tip_error_p90 for p in front],
            color=_OK, linewidth=1.5, label='Pareto front')
    ax.set_xlabel('median step time / time-optimal bound')
    ax.set_ylabel('90th percentile tip error [mm]')
    ax.set_title('grid points: speed against precision (labels: grid point)', fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend()
    figure.tight_layout()
    return _save(figure, path)
