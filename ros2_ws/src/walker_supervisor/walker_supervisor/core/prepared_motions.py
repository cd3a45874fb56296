"""Motions planned ahead of their request, and pairs of them joined ahead (free of ROS).

The sequencer asks for a step's extraction and coarse motion as soon as its targets are final
(:class:`~walker_supervisor.core.commands.PrepareTrajectory`), while the gripper still
unscrews, so that they stream the moment it is free. When the sweep streams with the lift
(``sweep_lead``), the two plans are also joined into one trajectory ahead: joining a thousand
samples in Python took 19-54 ms of wall time in a walk, on the way from the gripper coming
free to the stream's start.

Each request asked ahead is named by a ticket (the planner request's); its answer is a
:class:`PlanAnswer`, or None for a call that failed.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

from walker_planner.core.errors import PlanningError
from walker_supervisor.core.commands import TrajectoryRequest

__all__ = ['PlanAnswer', 'PreparedMotions', 'stream_lead', 'PENDING']


@dataclasses.dataclass(frozen=True)
class PlanAnswer:
    """The planner's answer to a motion (``walker_msgs/srv/PlanTrajectory``'s response).

    Attributes
    ----------
    success : bool
    message : str
        Why it was refused ('' on success).
    duration : float
        [s] of the planned trajectory.
    time_optimal_bound : float
        [s] lower bound of the motion's time under the robot's limits (0: none).
    trajectory : object
        The planned trajectory, as the shell streams it (a ``JointTrajectory`` message, or the
        planner core's trajectory in a headless loop).
    """

    success: bool
    message: str = ''
    duration: float = 0.0
    time_optimal_bound: float = 0.0
    trajectory: object = None


#: The answer of a request asked ahead that is not back yet.
PENDING = object()


def stream_lead(first: PlanAnswer, second: PlanAnswer, lead: float) -> float:
    """Return how long [s] before ``first`` ends ``second`` starts: ``lead``, within both."""
    return min(lead, first.duration, second.duration)


@dataclasses.dataclass
class _Entry:
    request: TrajectoryRequest
    ticket: int
    answer: object = PENDING  # PlanAnswer, None (the call failed) or PENDING


class PreparedMotions:
    """The planner's answers to the motions asked for ahead, for the requests that follow.

    Parameters
    ----------
    join : callable
        ``join(first, second, lead) -> trajectory``: two successful :class:`PlanAnswer` as one
        trajectory, the second from :func:`stream_lead` [s] before the first ends; raises
        :class:`~walker_planner.core.errors.PlanningError` when they cannot stream as one.
    """

    def __init__(self, join: Callable[[PlanAnswer, PlanAnswer, float], object]) -> None:
        self._join = join
        self._entries: list[_Entry] = []
        # every ticket asked ahead of the current batch: its purpose (taken or not)
        self._asked: dict[int, str] = {}
        # two of the answers joined ahead: (first answer, second answer, lead [s], trajectory)
        self._joined: list[tuple[PlanAnswer, PlanAnswer, float, object]] = []

    def clear(self) -> None:
        """Forget every motion asked ahead (a step starts, or its motion is cancelled).

        Answers still to come for them are stale (:meth:`answered` returns None).
        """
        self._entries.clear()
        self._asked.clear()
        self._joined.clear()

    def add(self, request: TrajectoryRequest, ticket: int) -> None:
        """Keep a motion asked for ahead under the ticket of its planner request."""
        self._entries.append(_Entry(request, ticket))
        self._asked[ticket] = request.purpose

    def answered(self, ticket: int, answer: PlanAnswer | None) -> tuple[str, PlanAnswer | None] \
            | None:
        """Take the answer to a request asked ahead; join the pairs it completes.

        Returns
        -------
        tuple or None
            ``(purpose, answer)`` when ``ticket`` was asked ahead for the current step (answer
            None when the call failed), whether or not a request has taken it since; None for
            any other ticket.
        """
        purpose = self._asked.pop(ticket, None)
        if purpose is None:
            return None
        for entry in self._entries:
            if entry.ticket == ticket:
                entry.answer = answer
        if answer is not None and answer.success:
            self.join_ahead()
        return purpose, answer

    def answer(self, request: TrajectoryRequest) -> PlanAnswer | None:
        """Return the successful answer to the same motion asked ahead.

        None if none was asked, or it is not back yet, failed or was refused.
        """
        for entry in self._entries:
            if entry.request.same_motion(request) and entry.answer is not PENDING:
                answer = entry.answer
                return answer if answer is not None and answer.success else None
        return None

    def take(self, request: TrajectoryRequest) -> tuple[int, object] | None:
        """Return the ticket and answer of the same motion asked ahead, once; else None.

        The answer is :data:`PENDING` while it is not back. An answer that came back
        unsuccessful is not taken: the motion is planned afresh.
        """
        for index, entry in enumerate(self._entries):
            if entry.request.same_motion(request):
                del self._entries[index]  # by place: entries holding arrays do not compare
                if entry.answer is not PENDING and (entry.answer is None
                                                    or not entry.answer.success):
                    return None
                return entry.ticket, entry.answer
        return None

    def join_ahead(self) -> None:
        """Join each motion asked ahead with the one it streams with (``then``).

        Only once both answers are back. A pair that cannot be joined is left to fail, with
        its reason, when it is requested (:meth:`joined`).
        """
        for entry in self._entries:
            request = entry.request
            if request.then is None:
                continue
            first, second = self.answer(request), self.answer(request.then)
            if first is None or second is None or any(
                    joined[0] is first and joined[1] is second for joined in self._joined):
                continue
            try:
                trajectory = self._join(first, second, request.lead)
            except PlanningError:
                continue
            self._joined.append((first, second, request.lead, trajectory))

    def joined(self, first: PlanAnswer, second: PlanAnswer, lead: float) -> object:
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
