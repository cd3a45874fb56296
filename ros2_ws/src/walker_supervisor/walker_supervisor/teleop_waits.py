"""The waits of the supervisor's teleoperation coroutines (ROS layer).

A jog or gripper command waits for a planner or plant answer, or for a condition of the
measurements (the joints settled, a gripper attached), each with a deadline on the ROS clock.
The waits are released at the supervisor's decision ticks, after its measurements: when the
condition holds, when the deadline passes, or when a hold stops the command.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import rclpy

from walker_supervisor.clocks import Clocks

__all__ = ['TeleopWaits']


@dataclasses.dataclass
class _Wait:
    deadline: float  # [s] ROS clock
    waiter: rclpy.task.Future
    condition: Callable[[float], bool] | None = None


class TeleopWaits:
    """Waits with deadlines, released by :meth:`release` at each decision tick."""

    def __init__(self, clocks: Clocks) -> None:
        self._clocks = clocks
        self._waits: list[_Wait] = []

    def release(self, now: float, stopped: bool) -> None:
        """Release the waits that are over at ``now`` [s] (all of them when ``stopped``)."""
        for wait in list(self._waits):
            if not wait.waiter.done():
                if stopped:
                    wait.waiter.set_result(False)
                elif wait.condition is not None and wait.condition(now):
                    wait.waiter.set_result(True)
                elif now > wait.deadline:
                    wait.waiter.set_result(False)
            if wait.waiter.done():
                self._waits.remove(wait)

    async def result(self, future, timeout: float):
        """Return the future's result, or None after ``timeout`` [s] or when stopped."""
        waiter = rclpy.task.Future()

        def done(_future) -> None:
            if not waiter.done():
                waiter.set_result(True)

        self._waits.append(_Wait(self._clocks.now() + timeout, waiter))
        future.add_done_callback(done)
        finished = await waiter
        return future.result() if finished and future.done() else None

    async def until(self, condition: Callable[[float], bool], timeout: float) -> bool:
        """Wait until ``condition(now)`` holds at a tick; False after ``timeout`` [s] or a stop."""
        waiter = rclpy.task.Future()
        self._waits.append(_Wait(self._clocks.now() + timeout, waiter, condition))
        return bool(await waiter)
