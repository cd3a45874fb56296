"""Sim time: the planner's setpoints handed by call to controllers in the same process.

With the whole graph in one process and the plant handing each state to the planner's stream
and to the grouped controllers by call (:mod:`walker_sim.state_handover`), the setpoints the
stream sends for the coming states reach the controllers by a call too, not through DDS: the
planner still publishes each on ``controllers/<joint>/setpoint`` for every other subscriber
(the recorder, ``ros2 topic echo``), and the controllers' own subscriptions to those topics
are gone, as their ``joint_states`` subscription is when the plant hands them the states.

The stream sends from whichever thread moves it (the loop's, handing a state over; the
planner's action thread, starting or cancelling a stream): :meth:`SetpointHandover.push` only
queues, and the controllers take the queue in the loop's thread
(:meth:`SetpointHandover.take_into`), each setpoint exactly as its message would have given it.
A push from another thread also calls ``wake`` (the controllers' guard condition, which
wakes the loop's executor: a state may be waiting for those setpoints); the loop's own pushes,
one a period, are taken before the next state without waking anything.
"""

from __future__ import annotations

import collections
import threading
from collections.abc import Callable, Sequence

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_core.stamps import stamp_seconds

__all__ = ['SetpointHandover', 'stamp_seconds']


class SetpointHandover:
    """Setpoints queued by the planner's stream, taken by the controllers' channels.

    Parameters
    ----------
    joints : sequence of str
        The controllers' joints, in their channels' order (each a physical joint).
    wake : callable
        Called after a push from a thread other than the one that takes.
    """

    def __init__(self, joints: Sequence[str], wake: Callable[[], None]) -> None:
        self._indices = [PHYSICAL_JOINT_NAMES.index(joint) for joint in joints]
        self._queue: collections.deque = collections.deque()
        self._wake = wake
        self._taker: int | None = None  # the thread that takes (the loop's), once known

    def push(self, stamp: int, positions: Sequence[float], velocities: Sequence[float],
             accelerations: Sequence[float]) -> None:
        """Queue the five setpoints of one stamp [ns] (physical order; rad, rad/s, rad/s^2).

        The stream's ``send``: safe from any thread; the sequences are not changed later.
        """
        self._queue.append((stamp, positions, velocities, accelerations))
        if threading.get_ident() != self._taker:
            self._wake()

    def take_into(self, take: Callable[[int, float, float, float, float], None]) -> int:
        """Hand every queued setpoint to ``take(channel_index, stamp_s, p, v, a)``; count them.

        Oldest first, channel by channel, as the five messages of a stamp arrive.
        """
        self._taker = threading.get_ident()
        taken = 0
        while self._queue:
            stamp, positions, velocities, accelerations = self._queue.popleft()
            seconds = stamp_seconds(stamp)
            for k, j in enumerate(self._indices):
                take(k, seconds, positions[j], velocities[j], accelerations[j])
            taken += 1
        return taken
