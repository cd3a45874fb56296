"""The newest messages of latched topics, kept for the viewers that subscribe later.

A ROS subscription with transient-local durability receives a latched topic's newest messages
(the publishers' history depth) whenever it joins; a Foxglove WebSocket server passes on only
what arrives while a client is subscribed. :class:`LatchedMessages` keeps, for each latched
topic the bridge serves, the newest ``depth`` messages it passed on, so that a client that
subscribes at any time is sent them again (:mod:`walker_viz.foxglove_bridge`).
"""

from __future__ import annotations

from collections import deque

__all__ = ['LatchedMessages', 'MAX_DEPTH']

#: Most messages kept of one topic, whatever depth its publishers offer.
MAX_DEPTH = 100


class LatchedMessages:
    """Per latched topic, its newest messages as passed on: ``(data, log_time [ns])``."""

    def __init__(self) -> None:
        self._kept: dict[str, deque] = {}

    def latch(self, topic: str, depth: int) -> None:
        """Keep the newest ``depth`` messages of ``topic`` from now on (1 to MAX_DEPTH)."""
        depth = max(1, min(int(depth), MAX_DEPTH))
        self._kept[topic] = deque(self._kept.get(topic, ()), maxlen=depth)

    def latched(self, topic: str) -> bool:
        """Return True if ``topic`` is kept."""
        return topic in self._kept

    def passed_on(self, topic: str, data: bytes, log_time: int) -> None:
        """Note a message passed on (kept only if ``topic`` is latched)."""
        kept = self._kept.get(topic)
        if kept is not None:
            kept.append((bytes(data), int(log_time)))

    def newest(self, topic: str) -> list[tuple[bytes, int]]:
        """Return the kept messages of ``topic``, oldest first (empty if none)."""
        return list(self._kept.get(topic, ()))
