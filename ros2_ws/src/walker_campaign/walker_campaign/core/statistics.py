"""The campaign's statistics: a success rate's confidence interval, rank correlations, Pareto.

Plain functions of arrays, with scipy.stats where it has the estimator.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence

import numpy as np
from scipy import stats

__all__ = ['wilson_interval', 'Sensitivity', 'rank_correlations', 'pareto_front', 'ecdf',
           'quantiles']


def wilson_interval(successes: int, trials: int, confidence: float = 0.95
                    ) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion.

    Parameters
    ----------
    successes, trials : int
        Successes among independent trials (``0 <= successes <= trials``).
    confidence : float
        Coverage of the interval, in (0, 1).

    Returns
    -------
    (low, high) : tuple of float
        With ``z`` the two-sided normal quantile, ``p = s / n``::

            centre = (p + z^2 / 2n) / (1 + z^2 / n)
            half   = z sqrt(p (1 - p) / n + z^2 / 4n^2) / (1 + z^2 / n)

        ``(nan, nan)`` without trials.

    Notes
    -----
    Unlike the normal (Wald) interval it stays inside [0, 1] and keeps its coverage near 0 and
    1, where a walker's success rate lives.

    References
    ----------
    E. B. Wilson, "Probable inference, the law of succession, and statistical inference",
    J. Am. Stat. Assoc. 22 (1927) 209-212.
    """
    if isinstance(trials, bool) or not 0 <= successes <= trials:
        raise ValueError(f'need 0 <= successes <= trials, got {successes} of {trials}')
    if not 0.0 < confidence < 1.0:
        raise ValueError(f'confidence must be in (0, 1), got {confidence}')
    if trials == 0:
        return (math.nan, math.nan)
    z = float(stats.norm.ppf(0.5 + confidence / 2.0))
    p = successes / trials
    denominator = 1.0 + z * z / trials
    centre = (p + z * z / (2.0 * trials)) / denominator
    half = z * math.sqrt(p * (1.0 - p) / trials + z * z / (4.0 * trials * trials)) / denominator
    return (max(0.0, centre - half), min(1.0, centre + half))


@dataclasses.dataclass(frozen=True)
class Sensitivity:
    """Spearman's rank correlation of a figure with a dispersed parameter over the runs.

    Attributes
    ----------
    parameter, figure : str
    rho : float
        In [-1, 1]; NaN when either varies not at all.
    p_value : float
        Of the null hypothesis of no monotonic relation.
    count : int
        Runs with both values.
    """

    parameter: str
    figure: str
    rho: float
    p_value: float
    count: int


def rank_correlations(parameters: Mapping[str, Sequence[float | None]],
                      figures: Mapping[str, Sequence[float | None]]) -> list[Sensitivity]:
    """Spearman's rho of every figure with every parameter (``None`` values left out pairwise).

    Parameters
    ----------
    parameters, figures : mapping of str to sequence
        Columns of equal length (one value per run).
    """
    results = []
    for figure, y_values in figures.items():
        y = np.array([math.nan if v is None else float(v) for v in y_values])
        for parameter, x_values in parameters.items():
            x = np.array([math.nan if v is None else float(v) for v in x_values])
            keep = np.isfinite(x) & np.isfinite(y)
            count = int(keep.sum())
            if count < 3 or np.ptp(x[keep]) == 0.0 or np.ptp(y[keep]) == 0.0:
                results.append(Sensitivity(parameter, figure, math.nan, math.nan, count))
                continue
            rho, p_value = stats.spearmanr(x[keep], y[keep])
            results.append(Sensitivity(parameter, figure, float(rho), float(p_value), count))
    return results


def pareto_front(x: Sequence[float], y: Sequence[float]) -> list[int]:
    """Return the indices of the points no other point beats in both (smaller is better in each).

    A point is dominated when another is at most as large in both and smaller in one. Points
    with a NaN are never on the front. The front is returned sorted by ``x``.
    """
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    front = []
    for i in range(len(x)):
        if not (math.isfinite(x[i]) and math.isfinite(y[i])):
            continue
        beaten = ((x <= x[i]) & (y <= y[i]) & ((x < x[i]) | (y < y[i])))
        if not beaten.any():
            front.append(i)
    return sorted(front, key=lambda i: (x[i], y[i]))


def ecdf(values: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
    """Empirical distribution: sorted values and the fraction of values at or below each."""
    ordered = np.sort(np.asarray([v for v in values if v is not None and math.isfinite(v)],
                                 dtype=float))
    return ordered, np.arange(1, len(ordered) + 1) / max(len(ordered), 1)


def quantiles(values: Sequence[float], levels: Sequence[float] = (0.5, 0.9, 0.99)
              ) -> dict[float, float]:
    """Quantiles of the finite values (``{level: value}``; NaN without values)."""
    finite = [v for v in values if v is not None and math.isfinite(v)]
    if not finite:
        return dict.fromkeys(levels, math.nan)
    return {level: float(np.quantile(finite, level)) for level in levels}
