"""What the planner node ties to a stream: its action goal, and how the goal ends."""

from __future__ import annotations

from rclpy.task import Future

__all__ = ['StreamGoal', 'goal_result']


class StreamGoal:
    """A stream's ``follow_trajectory`` goal handle, and the future its execution awaits.

    The goal handle is None for ``plan_trajectory`` with ``execute``, and until the goal
    executes for a trajectory started when the goal came. The stream thread (or the relay, by
    the clock) ends the stream; the main thread's relay completes ``done`` (rclpy futures are
    completed in the thread of their executor).
    """

    def __init__(self, goal_handle) -> None:
        self.goal_handle = goal_handle
        self.done = Future()


async def goal_result(goal_handle, result, active, lock, streamer):
    """Wait for the stream ``active`` to end, then end its goal and return its ``result``.

    Succeeded when complete; cancelled when it ended on the goal's cancel; aborted when it was
    stopped otherwise or the planner shuts down. ``lock`` guards ``streamer`` (the
    :class:`~walker_planner.core.streamer.TrajectoryStreamer`), which gives the tracking error.
    """
    await active.owner.done
    if not active.owner.done.done():
        result.message = 'the planner is shutting down'
        goal_handle.abort()
        return result
    with lock:
        result.duration = active.duration
        result.final_position_error = streamer.tracking_error(active.stream)
    result.message = active.message
    result.success = not active.cancelled
    if active.cancelled and goal_handle.is_cancel_requested:
        goal_handle.canceled()
    elif active.cancelled:
        goal_handle.abort()
    else:
        goal_handle.succeed()
    return result
