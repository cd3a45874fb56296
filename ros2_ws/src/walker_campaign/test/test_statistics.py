"""The campaign's statistics against values worked out by hand and by definition."""

import math

import numpy as np
import pytest

from walker_campaign.core.statistics import (
    ecdf, pareto_front, quantiles, rank_correlations, wilson_interval)


@pytest.mark.parametrize('successes, trials, low, high', [
    (0, 10, 0.0, 0.2775), (10, 10, 0.7225, 1.0), (50, 100, 0.4038, 0.5962),
    (195, 200, 0.9428, 0.9893), (1, 1, 0.2065, 1.0)])
def test_the_wilson_interval_matches_worked_values(successes, trials, low, high):
    got = wilson_interval(successes, trials)
    assert got == pytest.approx((low, high), abs=1e-4)


def test_the_wilson_interval_holds_the_rate_and_narrows_with_trials():
    wide, narrow = wilson_interval(9, 10), wilson_interval(900, 1000)
    assert wide[0] < 0.9 < wide[1] and narrow[0] < 0.9 < narrow[1]
    assert narrow[1] - narrow[0] < (wide[1] - wide[0]) / 5
    assert all(math.isnan(v) for v in wilson_interval(0, 0))
    with pytest.raises(ValueError, match='successes <= trials'):
        wilson_interval(3, 2)


def test_rank_correlation_sees_monotonic_relations_and_nothing_in_constants():
    x = np.linspace(0, 1, 30)
    result = {(s.parameter, s.figure): s for s in rank_correlations(
        {'x': list(x), 'fixed': [1.0] * 30},
        {'up': list(np.exp(x)), 'down': list(-x ** 3), 'gaps': [None] + list(x[1:])})}
    assert result[('x', 'up')].rho == pytest.approx(1.0)
    assert result[('x', 'down')].rho == pytest.approx(-1.0)
    assert result[('x', 'gaps')].count == 29
    assert math.isnan(result[('fixed', 'up')].rho)


def test_the_pareto_front_keeps_the_points_nothing_beats():
    x = [1.0, 2.0, 1.5, 3.0, 1.0, math.nan]
    y = [5.0, 1.0, 2.0, 0.5, 6.0, 0.1]
    assert pareto_front(x, y) == [0, 2, 1, 3]


def test_ecdf_and_quantiles():
    values, fraction = ecdf([3.0, None, 1.0, 2.0, math.nan])
    assert list(values) == [1.0, 2.0, 3.0] and list(fraction) == pytest.approx([1 / 3, 2 / 3, 1])
    assert quantiles([1.0, 2.0, 3.0], (0.5, 1.0)) == {0.5: 2.0, 1.0: 3.0}
    assert math.isnan(quantiles([], (0.5,))[0.5])
