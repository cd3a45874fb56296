"""Motions planned ahead of their request, and pairs of them joined ahead (ROS layer).

The sequencer asks for a step's extraction and coarse motion as soon as its targets are final
(:class:`~walker_supervisor.core.sequencer.PrepareTrajectory`), while the gripper still
unscrews, so that they stream the moment it is free. When the sweep streams with the lift
(``sweep_lead``), the two plans are also joined into one trajectory ahead: joining a thousand
samples in Python took 19-54 ms of wall time in a walk, on the way from the gripper coming
free to the stream's start.

The answers are the planner's ``plan_trajectory`` futures; any object with ``done()`` and
``result()`` serves (a result with ``success``, ``duration`` [s] and ``trajectory``).
"""

from __future__ import annotations

from collections.abc import Callable

from walker_planner.core.errors import PlanningError
from walker_supervisor.core.sequencer import TrajectoryRequest

__all__ = ['PreparedMotions', 'plan_answer', 'stream_lead']


def plan_answer(future):
    """Return a done ``plan_trajectory`` future's answer, or None if the call failed."""
    try:
        return future.result()
    except Exception:  # a failed call is a plan that will not come
        return None


def stream_lead(first, second, lead: float) -> float:
    """Return how long [s] before ``first`` ends ``second`` starts: ``lead``, within both."""
    return min(lead, first.duration, second.duration)


class PreparedMotions:
    """The planner's answers to the motions asked for ahead, for the requests that follow.

    Parameters
    ----------
    join : callable
        ``join(first, second, lead) -> trajectory``: two successful answers as one trajectory,
        the second from :func:`stream_lead` [s] before the first ends; raises
        :class:`~walker_planner.core.errors.PlanningError` when they cannot stream as one.
    """

    def __init__(self, join: Callable[[object, object, float], object]) -> None:
        self._join = join
        self._entries: list[tuple[TrajectoryRequest, object]] = []
        # two of the answers joined ahead: (first answer, second answer, lead [s], trajectory)
        self._joined: list[tuple[object, object, float, object]] = []
        #: Counts the clearings: an answer to a request of an older batch is stale.
        self.batch = 0

    def clear(self) -> None:
        """Forget every motion asked ahead (a step starts, or its motion is cancelled)."""
        self._entries.clear()
        self._joined.clear()
        self.batch += 1

    def add(self, request: TrajectoryRequest, future) -> None:
        """Keep the answer (future) to a motion asked for ahead."""
        self._entries.append((request, future))

    def answer(self, request: TrajectoryRequest):
        """Return the successful answer to the same motion asked ahead.

        None if none was asked, or it is not back yet, failed or was refused.
        """
        for prepared, future in self._entries:
            if prepared.same_motion(request) and future.done():
                response = plan_answer(future)
                return response if response is not None and response.success else None
        return None

    def take(self, request: TrajectoryRequest):
        """Return the answer (future) to the same motion asked ahead, once; else None.

        An answer that came back unsuccessful is not taken: the motion is planned afresh.
        """
        for entry in self._entries:
            prepared, future = entry
            if prepared.same_motion(request):
                self._entries.remove(entry)
                if future.done():
                    response = plan_answer(future)
                    if response is None or not response.success:
                        return None
                return future
        return None

    def join_ahead(self) -> None:
        """Join each motion asked ahead with the one it streams with (``then``).

        Only once both answers are back. A pair that cannot be joined is left to fail, with
        its reason, when it is requested (:meth:`joined`).
        """
        for request, _ in self._entries:
            if request.then is None:
                continue
            first, second = self.answer(request), self.answer(request.then)
            if first is None or second is None or any(
                    entry[0] is first and entry[1] is second for entry in self._joined):
                continue
            try:
                trajectory = self._join(first, second, request.lead)
            except PlanningError:
                continue
            self._joined.append((first, second, request.lead, trajectory))

    def joined(self, first, second, lead: float):
        """Return two answers as one trajectory: as joined ahead (once), or joined now.

        Raises
        ------
        PlanningError
            The two cannot stream as one.
        """
        for entry in self._joined:
            if entry[0] is first and entry[1] is second and entry[2] == lead:
                self._joined.remove(entry)
                return entry[3]
        return self._join(first, second, lead)
