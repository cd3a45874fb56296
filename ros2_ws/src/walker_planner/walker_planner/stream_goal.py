"""What the planner node ties to a stream: its action goal, and the future the goal awaits."""

from __future__ import annotations

from rclpy.task import Future

__all__ = ['StreamGoal']


class StreamGoal:
    """A stream's ``follow_trajectory`` goal handle, and the future its execution awaits.

    The goal handle is None for ``plan_trajectory`` with ``execute``. The stream thread (or
    the relay, by the clock) ends the stream; the main thread's relay completes ``done``
    (rclpy futures are completed in the thread of their executor).
    """

    def __init__(self, goal_handle) -> None:
        self.goal_handle = goal_handle
        self.done = Future()
