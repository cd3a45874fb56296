"""The supervisor's two clocks, in seconds as the walk runner takes them (ROS layer).

``now``: the ROS clock (simulated time under ``use_sim_time``), what the step's phases run on.
``steady``: a monotonic clock that runs while a simulated clock stands still, what the health
watchdog and the waits for answers run on.
"""

from __future__ import annotations

from rclpy.clock import Clock, ClockType
from rclpy.node import Node

__all__ = ['Clocks']


class Clocks:
    """The ROS clock of a node and a steady clock."""

    def __init__(self, node: Node) -> None:
        self._ros = node.get_clock()
        self.steady_clock = Clock(clock_type=ClockType.STEADY_TIME)

    def now(self) -> float:
        """Return the ROS clock [s]."""
        return self._ros.now().nanoseconds * 1e-9

    def now_ns(self) -> int:
        """Return the ROS clock [ns]."""
        return self._ros.now().nanoseconds

    def stamp(self):
        """Return the ROS clock as a message stamp."""
        return self._ros.now().to_msg()

    def steady(self) -> float:
        """Return the steady clock [s]."""
        return self.steady_clock.now().nanoseconds * 1e-9
