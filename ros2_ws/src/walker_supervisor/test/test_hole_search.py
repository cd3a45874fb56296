"""The search pattern: bounded, no gaps in what it covers, inside the approach region."""

import math

import numpy as np
import pytest

from walker_supervisor.core.hole_search import HoleSearch, SearchPattern, hex_pattern

REACH = 0.0015  # [m] the 2 mm insertion tolerance less the 0.5 mm alignment


def _gap(offsets, covered, reach):
    """Largest distance [m] from a point within ``covered`` of the origin to its nearest probe."""
    radius = np.sqrt(np.linspace(0.0, 1.0, 120)) * covered
    angle = np.linspace(0.0, 2 * math.pi, 181)
    points = np.stack([np.outer(radius, np.cos(angle)).ravel(),
                       np.outer(radius, np.sin(angle)).ravel()], axis=1)
    distances = np.linalg.norm(points[:, None, :] - offsets[None, :, :], axis=2)
    return distances.min(axis=1).max()


@pytest.mark.parametrize('std', [0.0003, 0.001, 0.0015, 0.003])
def test_the_pattern_covers_its_disc_without_gaps_and_stays_within_the_radius(std):
    radius = 0.005
    pattern = SearchPattern.around(REACH, std, 3.0, radius)
    assert pattern.covered == pytest.approx(min(max(3.0 * std, REACH), radius - REACH))
    assert _gap(pattern.offsets, pattern.covered, REACH) <= REACH * (1 + 1e-9)
    assert np.linalg.norm(pattern.offsets, axis=1).max() <= radius + 1e-12
    # the estimate first, nearest first after it
    np.testing.assert_array_equal(pattern.offsets[0], [0.0, 0.0])
    distances = np.linalg.norm(pattern.offsets, axis=1)
    assert np.all(np.diff(distances) >= -1e-12)


def test_a_hex_pattern_of_wider_coverage_has_more_probes_and_no_duplicates():
    small, large = hex_pattern(REACH, 0.002), hex_pattern(REACH, 0.0045)
    assert 1 < len(small) < len(large)
    assert len(np.unique(np.round(large, 9), axis=0)) == len(large)
    # neighbouring probes are sqrt(3) * reach apart: no closer (no wasted probes)
    d = np.linalg.norm(large[:, None] - large[None], axis=2) + np.eye(len(large))
    assert d.min() == pytest.approx(math.sqrt(3.0) * REACH)


def test_a_radius_under_the_reach_means_no_search():
    pattern = SearchPattern.around(REACH, 0.002, 3.0, 0.001)
    assert len(pattern) == 1
    search = HoleSearch(pattern)
    assert search.exhausted and search.next_offset() is None


def test_the_search_visits_every_probe_once_then_the_estimate_again_then_stops():
    pattern = SearchPattern.around(REACH, 0.0015, 3.0, 0.005)
    search = HoleSearch(pattern)
    seen = [search.offset]
    while (offset := search.next_offset()) is not None:
        seen.append(offset)
    assert len(seen) == len(pattern) + 1 == len(search)
    np.testing.assert_array_equal(np.array(seen[:-1]), pattern.offsets)
    np.testing.assert_array_equal(seen[-1], [0.0, 0.0])
    assert search.probes_moved == len(pattern) and search.exhausted


def test_a_reach_that_is_not_positive_is_refused():
    with pytest.raises(ValueError, match='reach'):
        hex_pattern(0.0, 0.003)


def test_an_estimate_known_to_less_than_the_reach_is_still_searched_one_ring_around():
    pattern = SearchPattern.around(REACH, 1e-5, 3.0, 0.0075)
    assert len(pattern) == 7 and pattern.covered == pytest.approx(REACH)
    ring = np.linalg.norm(pattern.offsets[1:], axis=1)
    np.testing.assert_allclose(ring, math.sqrt(3.0) * REACH)


@pytest.mark.parametrize('radius', [0.0065, 0.015, 0.029])
def test_an_estimate_known_to_centimetres_is_searched_to_the_radius_with_bounded_probes(radius):
    """The extent follows the estimate up to ``search_radius``: no farther, no more probes.

    Hex cells of area ``3 sqrt(3) / 2 reach^2`` around probes within ``radius`` lie in the
    disc of ``radius + reach``: the count is bounded by the ratio of the two areas.
    """
    pattern = SearchPattern.around(REACH, 0.02, 3.0, radius)
    assert pattern.covered == pytest.approx(radius - REACH)
    assert np.linalg.norm(pattern.offsets, axis=1).max() <= radius + 1e-12
    assert _gap(pattern.offsets, pattern.covered, REACH) <= REACH * (1 + 1e-9)
    cell = 1.5 * math.sqrt(3.0) * REACH ** 2
    assert len(pattern) <= math.pi * (radius + REACH) ** 2 / cell
    # a smaller estimate's pattern is the start of it: nearest first, the same probes
    smaller = SearchPattern.around(REACH, 0.002, 3.0, radius)
    np.testing.assert_allclose(pattern.offsets[:len(smaller)], smaller.offsets, atol=1e-12)
