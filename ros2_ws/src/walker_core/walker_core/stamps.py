"""Stamps as integer nanoseconds, read as the nodes read a ``builtin_interfaces/Time``."""

from __future__ import annotations

__all__ = ['NS_PER_S', 'stamp_seconds']

NS_PER_S = 1_000_000_000


def stamp_seconds(stamp: int) -> float:
    """Return a stamp [ns] in seconds, bit for bit as ``sec + nanosec * 1e-9`` of a message.

    A loop that hands stamps over by call (the headless runner, the composed graph's setpoint
    handover) must give the controllers the very float a message would have given them.
    """
    sec, nanosec = divmod(int(stamp), NS_PER_S)
    return sec + nanosec * 1e-9
