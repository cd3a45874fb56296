"""Which camera frame answers which look's request (ROS-free).

A look asks for its frames ``frame_interval`` apart, and a frame can take longer than that to
render and arrive: the next request then comes before the last frame. :class:`AwaitedFrames`
queues each gripper's requests in the order they were asked for; a frame answers the oldest
request it was exposed at or after. A request older than
:data:`~walker_supervisor.core.looking.LOOK_WAIT` is dropped (the walk runner went on blind).
"""

from __future__ import annotations

from collections import deque

from walker_supervisor.core.looking import LOOK_WAIT

__all__ = ['AwaitedFrames']


class AwaitedFrames:
    """The frames each gripper's looks await.

    Parameters
    ----------
    grippers : iterable of str
        The grippers that carry cameras.
    """

    def __init__(self, grippers) -> None:
        self._pending: dict[str, deque[int]] = {g: deque() for g in grippers}

    def asked(self, gripper: str, since_ns: int) -> None:
        """Note a request for a frame of ``gripper`` exposed at or after ``since_ns`` [ns]."""
        self._pending[gripper].append(int(since_ns))

    def answers(self, gripper: str, stamp_ns: int, now: float) -> bool:
        """Return True if a frame exposed at ``stamp_ns`` [ns] answers a request (taken then).

        ``now`` [s] is the graph's time: requests older than ``LOOK_WAIT`` are dropped first. A
        frame exposed before the oldest request answers none.
        """
        pending = self._pending.get(gripper)
        if pending is None:
            return False
        while pending and now - pending[0] * 1e-9 > LOOK_WAIT:
            pending.popleft()
        if not pending or stamp_ns < pending[0]:
            return False
        pending.popleft()
        return True
