"""A lossy, late link between a publisher and its subscribers, for fault injection.

The decisions of the ``lossy_link`` operator tool, documented in docs/ground_station.md
("Operator tools: the lossy link and the transport probe").

ROS-free: :class:`LossyLink` decides, message by message, whether a message is dropped and when
a kept one is delivered. The ``lossy_link`` node (:mod:`walker_bringup.lossy_link_node`) puts it
between a topic and a renamed copy of it that the node under test is remapped to read, so that
the rest of the graph is untouched.

The decisions are reproducible: drops come from a seeded generator, in the order the messages
arrive, and a kept message is delivered ``delay`` seconds after it arrived (plus a uniform jitter
drawn from the same generator), never before a message that arrived earlier (a link that delays
does not reorder).
"""

from __future__ import annotations

import collections
import dataclasses
import math
from typing import Any

import numpy as np

__all__ = ['LossyLink', 'LinkCounts']


@dataclasses.dataclass
class LinkCounts:
    """What the link has done so far."""

    received: int = 0
    dropped: int = 0
    delivered: int = 0
    longest_run_dropped: int = 0  # most messages dropped in a row


class LossyLink:
    """Drop and delay messages, reproducibly.

    Parameters
    ----------
    drop_probability : float
        Chance in [0, 1] that a message is dropped.
    delay : float
        Delay [s] of every kept message (0: delivered at once).
    jitter : float
        Extra delay [s], uniform in [0, jitter], per message.
    seed : int
        Seed of the generator that decides the drops and the jitter.

    Raises
    ------
    ValueError
        A probability outside [0, 1], or a negative or non-finite delay or jitter.
    """

    def __init__(self, drop_probability: float, delay: float = 0.0, jitter: float = 0.0,
                 seed: int = 0) -> None:
        self.configure(drop_probability, delay, jitter)
        self._random = np.random.default_rng(seed)
        self._queue: collections.deque[tuple[float, Any]] = collections.deque()
        self._run = 0
        self.counts = LinkCounts()

    def configure(self, drop_probability: float, delay: float, jitter: float) -> None:
        """Change the link's settings (for messages offered from now on).

        Raises
        ------
        ValueError
            A probability outside [0, 1], or a negative or non-finite delay or jitter
            (nothing changes).
        """
        if not 0.0 <= drop_probability <= 1.0:
            raise ValueError(f'drop_probability must be in [0, 1], got {drop_probability}')
        for name, value in (('delay', delay), ('jitter', jitter)):
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f'{name} must be a finite number of seconds >= 0, got {value}')
        self.drop_probability = float(drop_probability)
        self.delay = float(delay)
        self.jitter = float(jitter)

    def offer(self, message: Any, now: float) -> bool:
        """Take a message that arrived at ``now`` [s]; return False if it is dropped."""
        self.counts.received += 1
        if self._random.random() < self.drop_probability:
            self.counts.dropped += 1
            self._run += 1
            self.counts.longest_run_dropped = max(self.counts.longest_run_dropped, self._run)
            return False
        self._run = 0
        release = now + self.delay + (self._random.uniform(0.0, self.jitter)
                                      if self.jitter > 0.0 else 0.0)
        if self._queue:  # no overtaking: a link that delays does not reorder
            release = max(release, self._queue[-1][0])
        self._queue.append((release, message))
        return True

    def due(self, now: float) -> list:
        """Return the kept messages whose delivery time has come, in arrival order."""
        out = []
        while self._queue and self._queue[0][0] <= now:
            out.append(self._queue.popleft()[1])
        self.counts.delivered += len(out)
        return out

    @property
    def pending(self) -> int:
        """Messages kept and not yet delivered."""
        return len(self._queue)
