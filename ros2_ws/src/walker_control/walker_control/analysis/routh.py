"""eq (15) against Routh-Hurwitz and the poles of eq (14), over a grid of (Ka, wc/wf, zc).

``control_analysis routh`` prints the disagreements and draws the stability map.
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from walker_control.core.stability import (
    LoopDesign,
    discrete_closed_loop_poles,
    eq14_poles,
    eq14_transfer_function,
    eq15_margin,
    routh_hurwitz_stable,
)
from walker_control.analysis.plotting import pyplot, save_figure

__all__ = ['RouthGridResult', 'routh_grid', 'run_routh']


@dataclasses.dataclass(frozen=True)
class RouthGridResult:
    """Verdicts over a grid of (Ka, wc/wf, zc).

    Attributes
    ----------
    points : int
        Grid points checked.
    stable : int
        Points where eq (14) is stable by its poles.
    marginal : int
        Points exactly on the eq (15) boundary (poles on the imaginary axis), left out of the
        comparisons: there the verdict is rounding noise.
    eq15_disagreements, routh_disagreements : list of tuple
        ``(Ka, wc/wf, zc)`` where eq (15), or the Routh array, disagrees with the poles.
    sampled_disagreements : list of tuple
        ``(Ka, wc/wf, zc, margin, wc T)`` where the sampled loop (paper's filter, control
        period, no delay) disagrees with eq (15); ``margin`` is the eq (15) margin.
    """

    points: int
    stable: int
    marginal: int
    eq15_disagreements: list
    routh_disagreements: list
    sampled_disagreements: list


def routh_grid(ka_values: Sequence[float], ratios: Sequence[float], dampings: Sequence[float],
               wf: float = 30.0, sample_time: float = 0.002) -> RouthGridResult:
    """Check eq (15) against Routh-Hurwitz and the poles of eq (14) over a grid.

    Parameters
    ----------
    ka_values, ratios, dampings : sequences
        ``Ka``, ``wc / wf`` and ``zc`` values.
    wf : float
        Filter corner [rad/s] for the sampled-loop comparison (the joints 2-3 corner).
    sample_time : float
        Control period [s] of the sampled loop.
    """
    eq15_bad, routh_bad, sampled_bad = [], [], []
    stable = marginal = 0
    cases = list(itertools.product(ka_values, ratios, dampings))
    for ka, ratio, zc in cases:
        wc = ratio * wf
        margin = eq15_margin(wc, zc, wf, ka)
        if abs(margin) < 1e-9:
            marginal += 1
            continue
        by_poles = bool(np.all(eq14_poles(wc, zc, wf, ka).real < 0.0))
        stable += by_poles
        if (margin > 0.0) != by_poles:
            eq15_bad.append((ka, ratio, zc))
        if routh_hurwitz_stable(eq14_transfer_function(wc, zc, wf, ka)[1]) != by_poles:
            routh_bad.append((ka, ratio, zc))
        design = LoopDesign(wc, zc, 0.0, ka, 2, wf, 'critical')
        sampled = bool(np.max(np.abs(discrete_closed_loop_poles(design, sample_time))) < 1.0)
        if sampled != (margin > 0.0):
            sampled_bad.append((ka, ratio, zc, margin, wc * sample_time))
    return RouthGridResult(points=len(cases), stable=stable, marginal=marginal,
                           eq15_disagreements=eq15_bad,
                           routh_disagreements=routh_bad, sampled_disagreements=sampled_bad)


def run_routh(args: argparse.Namespace) -> int:
    """Check eq (15) and Routh-Hurwitz against the poles over a grid; 1 on a disagreement."""
    ka_values = np.round(np.linspace(0.0, 4.0, 21), 6)
    ratios = np.round(np.linspace(0.05, 2.5, 50), 6)
    dampings = (0.5, 1.0, 2.0)
    result = routh_grid(ka_values, ratios, dampings)
    print('Eq (15) against Routh-Hurwitz and the poles of eq (14)')
    print(f'  grid: Ka in [0, 4] ({len(ka_values)}), wc/wf in [0.05, 2.5] ({len(ratios)}), '
          f'zc in {dampings}: {result.points} points, {result.marginal} exactly on the '
          f'boundary left out, {result.stable} stable by the poles')
    print(f'  eq (15) disagrees with the poles at {len(result.eq15_disagreements)} points')
    print(f'  the Routh array disagrees with the poles at {len(result.routh_disagreements)} '
          'points')
    optimistic = [d for d in result.sampled_disagreements if d[3] > 0.0]
    pessimistic = [d for d in result.sampled_disagreements if d[3] <= 0.0]
    print('  the sampled loop (2nd-order critical filter at 30 rad/s, T = 2 ms, no delay) '
          f'disagrees with eq (15) at {len(result.sampled_disagreements)} points:')
    if optimistic:
        print(f'    {len(optimistic)} where eq (15) says stable and the sampled loop is not '
              f'(eq (15) margin up to {max(d[3] for d in optimistic):.3f}, at wc T >= '
              f'{min(d[4] for d in optimistic):.3f}: sampling costs phase that eq (15) does '
              'not see)')
    if pessimistic:
        print(f'    {len(pessimistic)} where eq (15) says unstable and the sampled loop is '
              f'stable (eq (15) margin down to {min(d[3] for d in pessimistic):.3f})')
    _plot_stability_map(args.out / 'routh_hurwitz.png')
    print(f'  figure: {args.out / "routh_hurwitz.png"}')
    return 0 if not (result.eq15_disagreements or result.routh_disagreements) else 1


def _plot_stability_map(path: Path) -> None:
    plt = pyplot()
    ka = np.linspace(0.0, 4.0, 161)
    ratio = np.linspace(0.02, 2.5, 200)
    fig, axes = plt.subplots(1, 3, figsize=(13, 4), sharey=True)
    for ax, zc in zip(axes, (0.5, 1.0, 2.0), strict=True):
        growth = np.array([[max(eq14_poles(r, zc, 1.0, k).real) for k in ka] for r in ratio])
        ax.contourf(ka, ratio, growth < 0.0, levels=[-0.5, 0.5, 1.5],
                    colors=['#f4c7c3', '#c9e7c9'])
        ax.plot(ka, (1.0 + ka) * zc / (1.0 + zc ** 2), 'k-', lw=2, label='eq (15) boundary')
        ax.set_title(f'zc = {zc:g}: green stable by the poles of eq (14)')
        ax.set_xlabel('Ka')
        ax.legend(loc='upper left')
    axes[0].set_ylabel('wc / wf')
    fig.tight_layout()
    save_figure(fig, path)
