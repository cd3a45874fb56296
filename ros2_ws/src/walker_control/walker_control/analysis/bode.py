"""Figure 5 of the paper: eq (14)'s Bode plots with and without Ka, and their bandwidths.

``control_analysis bode`` prints the table and draws the figure.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from scipy import signal
from scipy.optimize import brentq

from walker_control.core.stability import (
    eq14_transfer_function,
    eq15_margin,
)
from walker_control.analysis.plotting import pyplot, save_figure

__all__ = ['BodeCurve', 'figure5_curves', 'achievable_ratio', 'run_bode', 'FIGURE5_RATIO',
           'FIGURE5_KA', 'PEAK_LIMIT_DB']

FIGURE5_RATIO = 5.0               # wf / wc of the paper's Figure 5
FIGURE5_KA = (0.0, 0.25, 0.5, 1.0, 2.0, 4.0)
PEAK_LIMIT_DB = 3.0               # resonance peak allowed in the "achievable" comparison


@dataclasses.dataclass(frozen=True)
class BodeCurve:
    """One curve of Figure 5: frequency response of eq (14) and its figures of merit.

    Frequencies are in units of wc; ``bandwidth`` is the first -3 dB crossing, solved on the
    transfer function between the grid points that bracket it.
    """

    ka: float
    frequency: np.ndarray
    magnitude_db: np.ndarray
    phase_deg: np.ndarray
    bandwidth: float
    peak_db: float
    peak_frequency: float


def _bandwidth(numerator, denominator, w, magnitude) -> float:
    """Frequency where the gain first falls to -3 dB, solved between the grid points.

    The grid brackets the first crossing; ``brentq`` solves ``20 log10 |H(jw)| = -3`` inside
    the bracket on the transfer function itself. ``inf`` when the gain never falls that low
    on the grid.
    """
    below = np.nonzero(magnitude < -3.0)[0]
    if not len(below):
        return math.inf
    if below[0] == 0:
        return float(w[0])

    def excess(frequency):
        _, value = signal.freqs(numerator, denominator, worN=[frequency])
        return 20.0 * math.log10(abs(value[0])) + 3.0

    return float(brentq(excess, w[below[0] - 1], w[below[0]], xtol=1e-12, rtol=1e-12))


def _curve(numerator, denominator, ka, w) -> BodeCurve:
    _, response = signal.freqs(numerator, denominator, worN=w)
    magnitude = 20.0 * np.log10(np.abs(response))
    bandwidth = _bandwidth(numerator, denominator, w, magnitude)
    peak = int(np.argmax(magnitude))
    return BodeCurve(ka=ka, frequency=w, magnitude_db=magnitude,
                     phase_deg=np.degrees(np.unwrap(np.angle(response))), bandwidth=bandwidth,
                     peak_db=float(max(magnitude[peak], 0.0)),
                     peak_frequency=float(w[peak]) if magnitude[peak] > 0.0 else 0.0)


def figure5_curves(ratio: float = FIGURE5_RATIO, ka_values: Sequence[float] = FIGURE5_KA,
                   zc: float = 1.0, feedforward: bool = True,
                   w: np.ndarray | None = None) -> list[BodeCurve]:
    """Curves of Figure 5: theta / theta_r of eq (14) with ``wc = 1`` and ``wf = ratio``.

    Parameters
    ----------
    feedforward : bool
        True: eq (14) as printed (full feed-forward ``s^2 + 2 zc wc s + wc^2``). False: the
        same loop without the acceleration feed-forward, numerator ``(2 zc wc s + wc^2) wf^2``.
    """
    w = np.logspace(-2, 2, 8000) if w is None else w
    curves = []
    for ka in ka_values:
        numerator, denominator = eq14_transfer_function(1.0, zc, ratio, ka)
        if not feedforward:
            numerator = np.array([0.0, 2.0 * zc, 1.0]) * ratio ** 2
        curves.append(_curve(numerator, denominator, ka, w))
    return curves


def achievable_ratio(ka: float, zc: float = 1.0, peak_limit_db: float = PEAK_LIMIT_DB,
                     feedforward: bool = True) -> tuple[float, float]:
    """Largest ``wc/wf`` of eq (14) whose resonance peak stays within ``peak_limit_db``.

    Returns
    -------
    (float, float)
        That ratio and the -3 dB bandwidth it gives, in units of ``wf``.
    """
    w = np.logspace(-3, 2, 4000)
    best = (0.0, 0.0)
    for ratio in np.linspace(0.01, 2.0, 400):
        if eq15_margin(ratio, zc, 1.0, ka) <= 0.0:
            break
        numerator, denominator = eq14_transfer_function(ratio, zc, 1.0, ka)
        if not feedforward:
            numerator = np.array([0.0, 2.0 * zc * ratio, ratio ** 2])
        curve = _curve(numerator, denominator, ka, w)
        if curve.peak_db <= peak_limit_db:
            best = (float(ratio), curve.bandwidth)
    return best


def run_bode(args: argparse.Namespace) -> int:
    """``control_analysis bode``: print Figure 5's table, draw it into ``args.out``."""
    with_ff = figure5_curves()
    without_ff = figure5_curves(feedforward=False)
    print(f'Figure 5: eq (14) with wf/wc = {FIGURE5_RATIO:g}, zc = 1 (frequencies in units '
          'of wc)')
    print('        |   eq (14) as printed (feed-forward)   |   without acceleration feed-forward')
    print('   Ka   | -3 dB bandwidth | peak [dB] at w/wc  | -3 dB bandwidth | peak [dB] at w/wc')
    for a, b in zip(with_ff, without_ff, strict=True):
        print(f' {a.ka:6.2f} | {a.bandwidth:15.3f} | {a.peak_db:6.2f} at {a.peak_frequency:6.3f}'
              f'  | {b.bandwidth:15.3f} | {b.peak_db:6.2f} at {b.peak_frequency:6.3f}')
    print(f'\nAt a fixed filter (wf = 1): the largest wc/wf whose resonance peak stays within '
          f'{PEAK_LIMIT_DB:g} dB, and the bandwidth it gives (units of wf)')
    print('   Ka   |  feed-forward: wc/wf  bandwidth |  without: wc/wf  bandwidth')
    for ka in FIGURE5_KA:
        cells = []
        for feedforward, width in ((True, 20), (False, 15)):
            ratio, bandwidth = achievable_ratio(ka, feedforward=feedforward)
            cells.append(f'{ratio:{width}.3f} {bandwidth:10.3f}' if ratio > 0.0
                         else f'{"none":>{width}s} {"-":>10s}')
        print(f' {ka:6.2f} | {cells[0]} | {cells[1]}')
    _plot_bode(with_ff, without_ff, args.out / 'figure5_bode.png')
    print(f'\nfigure: {args.out / "figure5_bode.png"}')
    return 0


def _plot_bode(with_ff: list[BodeCurve], without_ff: list[BodeCurve], path: Path) -> None:
    plt = pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(12, 7), sharex=True)
    for column, (curves, title) in enumerate(((with_ff, 'eq (14) as printed'),
                                              (without_ff, 'without acceleration feed-forward'))):
        for curve in curves:
            axes[0, column].semilogx(curve.frequency, curve.magnitude_db,
                                     label=f'Ka = {curve.ka:g}')
            axes[1, column].semilogx(curve.frequency, curve.phase_deg)
        axes[0, column].axhline(-3.0, color='grey', ls=':', lw=1)
        axes[0, column].set_ylim(-40, 10)
        axes[0, column].set_title(f'{title}, wf/wc = {FIGURE5_RATIO:g}, zc = 1')
        axes[0, column].set_ylabel('|theta / theta_r| [dB]')
        axes[1, column].set_ylabel('phase [deg]')
        axes[1, column].set_xlabel('w / wc')
        axes[0, column].legend(fontsize=8)
        for ax in axes[:, column]:
            ax.grid(True, which='both', alpha=0.3)
    fig.tight_layout()
    save_figure(fig, path)
