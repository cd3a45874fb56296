"""The search for a hole that is not where the map says: a hex grid of insertion attempts.

A jammed screw-in says the hole is not within the gripper's insertion tolerance of the tip. The
walker then searches: it lifts back to the approach height, moves over the next point of a
bounded pattern around the map's estimate, and descends and screws in again, each probe an
ordinary insertion attempt through the step's interlocks (the base gripper stays attached;
nothing is released).

The pattern is a hexagonal grid. A tip screws in where it is within ``reach`` of the hole's
axis: the gripper's insertion tolerance less the walker's own alignment error at the mouth
(``insertion_alignment``). Discs of radius ``reach`` centred on a hex grid of spacing
``sqrt(3) * reach`` cover the plane without gaps, so a hole anywhere within ``covered`` of the
estimate lies within ``reach`` of some probe. ``covered`` follows the map's uncertainty
(``search_sigmas`` standard deviations of the node's estimate, along its worst horizontal
direction), bounded so that no probe is farther than ``search_radius`` from the estimate. The
probes are taken nearest first (the estimate itself is probe 0, the attempt before any jam).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

__all__ = ['SearchPattern', 'HoleSearch', 'hex_pattern']


def hex_pattern(reach: float, covered: float) -> np.ndarray:
    """Probe offsets [m] (x, y), nearest first, whose ``reach`` discs cover the ``covered`` disc.

    The hex grid of spacing ``sqrt(3) * reach`` through the origin; every point within
    ``covered`` [m] of the origin is within ``reach`` [m] of a grid point no farther than
    ``covered + reach`` from it, so those points are the pattern (the origin first).
    """
    if not reach > 0.0:
        raise ValueError(f'the probe reach must be positive, got {reach} m')
    covered = max(float(covered), 0.0)
    spacing = math.sqrt(3.0) * reach
    limit = covered + reach
    count = int(math.ceil(limit / spacing)) + 2
    points = []
    for i in range(-2 * count, 2 * count + 1):
        for j in range(-2 * count, 2 * count + 1):
            x = spacing * (i + 0.5 * j)
            y = spacing * (math.sqrt(3.0) / 2.0) * j
            if math.hypot(x, y) <= limit + 1e-12:
                points.append((x, y))
    points.sort(key=lambda p: (round(math.hypot(*p), 12), math.atan2(p[1], p[0])))
    return np.array(points)


@dataclasses.dataclass(frozen=True)
class SearchPattern:
    """The probes of one search and what they cover.

    Attributes
    ----------
    offsets : ndarray, shape (n, 2)
        [m] probe points relative to the estimate, in the truss frame's x and y, nearest first;
        ``offsets[0]`` is the estimate.
    reach : float
        [m] a probe screws in on a hole within this of it.
    covered : float
        [m] every hole within this of the estimate is within ``reach`` of a probe.
    """

    offsets: np.ndarray
    reach: float
    covered: float

    @classmethod
    def around(cls, reach: float, horizontal_std: float, sigmas: float,
               radius: float) -> 'SearchPattern':
        """Return the pattern for an estimate of ``horizontal_std`` [m], no probe past ``radius``.

        Covers ``sigmas * horizontal_std`` but at least ``reach`` (the estimate's first ring of
        six probes: the uncertainty of a surveyed node comes from its joint readings alone and
        can be far under the reach, while the hole may lie farther), at most ``radius - reach``
        (so its outer probes stay within ``radius``); a ``radius`` under ``reach`` gives the
        estimate alone (no search).
        """
        if radius < reach:
            return cls(np.zeros((1, 2)), float(reach), 0.0)
        covered = min(max(sigmas * max(horizontal_std, 0.0), reach), radius - reach)
        return cls(hex_pattern(reach, covered), float(reach), float(covered))

    def __len__(self) -> int:
        return len(self.offsets)


class HoleSearch:
    """The search of one step: which probe is next, which one screwed in.

    The probes are the pattern's, nearest first, and then the estimate once more: a jam there
    need not have been the hole's place (a thread that did not catch), and a hole that no probe
    found is likeliest there.

    Parameters
    ----------
    pattern : SearchPattern
    """

    def __init__(self, pattern: SearchPattern) -> None:
        self.pattern = pattern
        offsets = pattern.offsets
        self._sequence = np.vstack([offsets, offsets[:1]]) if len(offsets) > 1 else offsets
        self.probe = 0  # index of the probe being tried (0: the estimate)

    def __len__(self) -> int:
        """Return the insertion attempts the search makes at most (the estimate twice)."""
        return len(self._sequence)

    @property
    def probes_moved(self) -> int:
        """How many times the search moved to another probe."""
        return self.probe

    @property
    def exhausted(self) -> bool:
        """True when the last probe has been tried."""
        return self.probe >= len(self._sequence) - 1

    def next_offset(self) -> np.ndarray | None:
        """Move to the next probe: its offset [m] (x, y, truss frame), or None if none is left."""
        if self.exhausted:
            return None
        self.probe += 1
        return self._sequence[self.probe].copy()

    @property
    def offset(self) -> np.ndarray:
        """[m] the offset of the probe being tried."""
        return self._sequence[self.probe].copy()
