"""The planner requests of a step's motions, and the policy for one left unanswered (no ROS).

The sequencer asks for a motion (:class:`~walker_supervisor.core.commands.TrajectoryRequest`);
:class:`MotionRequests` turns it into planner requests and follows their answers:

1. the plan (``plan_trajectory``): the one asked ahead for the same motion if there is one
   (:mod:`walker_supervisor.core.prepared_motions`), else a new request
   (:class:`~walker_supervisor.core.commands.PlanMotion`); a motion streamed with another
   (``then``) needs both plans, joined into one trajectory;
2. the stream (``follow_trajectory``): the controllers' mode for the motion, commanded again
   just before it, then :class:`~walker_supervisor.core.commands.FollowMotion`;
3. its end.

What it says back to the step is a :class:`MotionStarted` or a :class:`MotionEnded` (the
sequencer's ``trajectory_started`` and ``trajectory_done``), and for motions asked ahead a
:class:`PlannedAhead`. A plan or stream request not answered within ``answer_wait`` [s] of
the steady clock is sent again over a new client (:mod:`walker_supervisor.core.unanswered`);
unanswered ``give_up_after`` after its first sending, its motion fails. Answers to requests
of a motion since replaced or cancelled are stale: ignored (a stream accepted that late is
cancelled).

A motion whose end the planner has not reported ``end_margin`` [s] after its planned end fails
as *unreported* (:attr:`MotionEnded.unreported`): the step holds at once. The margin must pass
on both clocks: on the graph's from the planned end, and on the steady clock from the first
check that found the graph's clock past that end (a simulation running faster than the wall
clock does not outrun a planner that is only slow, and a clock held still faults nothing).
The controllers hold a whole trajectory and execute it to its end without the planner, so a
planner that died (or lost its goal) mid-motion is noticed by this deadline, not by setpoints
going stale; the cancel sent with it has a living planner send the controllers a hold.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Callable

from walker_core.kinematics import WalkerKinematics
from walker_planner.core.errors import PlanningError
from walker_supervisor.core.commands import (
    CancelFollow, FollowMotion, Notice, PlanMotion, RenewPlannerClient, SetControlMode,
    TrajectoryRequest)
from walker_supervisor.core.planner_calls import planner_call
from walker_supervisor.core.prepared_motions import (
    PENDING, PlanAnswer, PreparedMotions, stream_lead)
from walker_supervisor.core.unanswered import GIVE_UP, WAIT, UnansweredRequest

__all__ = ['MotionRequests', 'MotionStarted', 'MotionEnded', 'PlannedAhead', 'MotionPlanned']

_PLAN, _FOLLOW = 'plan_trajectory', 'follow_trajectory'


@dataclasses.dataclass(frozen=True)
class MotionStarted:
    """The motion streams: it lasts ``duration`` [s]; its first part ``first_duration``."""

    duration: float
    first_duration: float | None = None


@dataclasses.dataclass(frozen=True)
class MotionEnded:
    """The motion ended (``success``), or was refused, failed or could not be asked for.

    ``unreported``: the planner never reported its end (the message says how long it was
    waited for); the step holds rather than plan a way on with that planner.
    """

    success: bool
    message: str
    unreported: bool = False


@dataclasses.dataclass(frozen=True)
class PlannedAhead:
    """A motion asked ahead is planned to last ``duration`` [s] (None: it will not be)."""

    purpose: str
    duration: float | None


@dataclasses.dataclass(frozen=True)
class MotionPlanned:
    """A motion is planned, with its time-optimal bound [s] (what a step's bound adds)."""

    purpose: str
    time_optimal_bound: float


@dataclasses.dataclass
class _Motion:
    """The requested motion: its plans, then its stream."""

    request: TrajectoryRequest
    plans: list[int]  # tickets of its plans (the motion, then the one streamed with it)
    answers: dict[int, object]  # ticket -> PlanAnswer, None (failed call) or PENDING
    following: int | None = None  # ticket of its stream request, once planned
    trajectory: object = None
    duration: float = 0.0
    first_duration: float | None = None
    streaming: bool = False
    end: float = math.inf  # [s] graph clock: the planned end, once streaming
    past_end_since: float | None = None  # [s] steady clock: the graph's clock first seen past it
    # the request waited for: its sendings (None: not sent yet), and the sendings a request
    # sent again goes on counting from
    sendings: UnansweredRequest | None = None
    sent_again_from: UnansweredRequest | None = None
    new_plans: bool = True  # some plan is asked now (not all asked ahead)

    @property
    def parts(self) -> list[TrajectoryRequest]:
        return [self.request] + ([self.request.then] if self.request.then is not None else [])

    @property
    def service(self) -> str:
        return _FOLLOW if self.following is not None else _PLAN


class MotionRequests:
    """The planner requests of the step's motions.

    Parameters
    ----------
    kinematics : WalkerKinematics
        For the planner's requests (:func:`~walker_supervisor.core.planner_calls.planner_call`).
    join : callable
        ``join(first, second, lead) -> trajectory`` (:class:`PreparedMotions`).
    answer_wait : float
        [s] steady clock: a request unanswered this long is sent again over a new client.
    give_up_after : float
        [s] steady clock: unanswered this long after its first sending, its motion fails.
    end_margin : float
        [s] graph clock: a motion whose end is not reported this long after its planned end
        fails as unreported (``supervisor.motion_end_margin``; > 0).

    Raises
    ------
    ValueError
        Waits not positive and ordered, or a margin not positive (nothing is made).
    """

    def __init__(self, kinematics: WalkerKinematics,
                 join: Callable[[PlanAnswer, PlanAnswer, float], object],
                 answer_wait: float, give_up_after: float, end_margin: float) -> None:
        UnansweredRequest(0.0, 0.0, answer_wait, give_up_after)  # refuses bad waits
        self.end_margin = end_margin
        self._kinematics = kinematics
        self._answer_wait = float(answer_wait)
        self._give_up_after = float(give_up_after)
        self._tickets = itertools.count(1)
        self.prepared = PreparedMotions(join)
        self._motion: _Motion | None = None
        self._stream: int | None = None  # the ticket of the stream accepted last

    @property
    def end_margin(self) -> float:
        """[s] graph clock: how long after its planned end a motion's end is waited for."""
        return self._end_margin

    @end_margin.setter
    def end_margin(self, value: float) -> None:
        if not (math.isfinite(value) and value > 0.0):
            raise ValueError(f'end_margin must be a positive number of seconds, got {value!r}')
        self._end_margin = float(value)

    @property
    def awaiting_answer(self) -> bool:
        """True while a plan or stream request of the motion is sent and unanswered."""
        motion = self._motion
        return motion is not None and not motion.streaming and motion.sendings is not None

    # ------------------------------------------------------------------ the step's commands
    def request(self, request: TrajectoryRequest) -> list:
        """Plan the motion (or take its plans asked ahead), then stream it."""
        motion = _Motion(request, [], {})
        self._motion = motion
        out = []
        for part in motion.parts:
            taken = self.prepared.take(part)
            if taken is None:
                ticket = next(self._tickets)
                motion.answers[ticket] = PENDING
                out.append(PlanMotion(ticket, part.purpose,
                                      planner_call(part, self._kinematics)))
            else:
                ticket, motion.answers[ticket] = taken
            motion.plans.append(ticket)
        motion.new_plans = bool(out)
        return out + self._when_planned(motion)

    def prepare(self, request: TrajectoryRequest) -> list:
        """Ask the planner now for a motion the sequencer will request later."""
        ticket = next(self._tickets)
        self.prepared.add(request, ticket)
        return [PlanMotion(ticket, request.purpose, planner_call(request, self._kinematics),
                           ahead=True)]

    def cancel(self) -> list:
        """Drop the motion and every plan asked ahead; stop the stream accepted last."""
        self._motion = None
        self.prepared.clear()
        stream, self._stream = self._stream, None
        return [] if stream is None else [CancelFollow(stream)]

    # ------------------------------------------------------------------ the planner's answers
    def sent(self, ticket: int, steady: float) -> None:
        """Note that a request left at steady time ``steady`` [s]: it is waited for."""
        motion = self._motion
        if motion is None or motion.streaming or motion.sendings is not None \
                or ticket not in (*motion.plans, motion.following):
            return
        motion.sendings = (motion.sent_again_from.sent_again(steady)
                           if motion.sent_again_from is not None
                           else UnansweredRequest(steady, steady, self._answer_wait,
                                                  self._give_up_after))

    def failed(self, ticket: int) -> list:
        """Take a request that could not be sent (its server was not found in time)."""
        out = self._ahead(ticket, None)
        motion = self._motion
        if motion is not None and ticket in (*motion.plans, motion.following):
            self._motion = None
            service = motion.service
            out.append(MotionEnded(False, 'the planner is not available'
                                   if motion.sent_again_from is None
                                   else f'the planner {service} is not available'))
        return out

    def planned(self, ticket: int, answer: PlanAnswer | None) -> list:
        """Take the answer to a ``plan_trajectory`` request (None: the call failed)."""
        out = self._ahead(ticket, answer)
        motion = self._motion
        if motion is None or motion.following is not None or ticket not in motion.plans:
            return out  # stale: its motion was replaced, cancelled or asked for again
        motion.answers[ticket] = answer
        return out + self._when_planned(motion)

    def accepted(self, ticket: int, accepted: bool, now: float) -> list:
        """Take the planner's acceptance (or refusal) to stream ``ticket`` at ``now`` [s].

        ``now`` is on the graph's clock: the motion's end is due its duration after it.
        """
        motion = self._motion
        if motion is None or motion.streaming or ticket != motion.following:
            # a late answer to a request sent again, or a stream of a motion since dropped
            return [CancelFollow(ticket)] if accepted else []
        if not accepted:
            self._motion = None
            return [MotionEnded(False, 'the planner refused to stream the trajectory')]
        motion.streaming = True
        motion.end = now + motion.duration
        self._stream = ticket
        request = motion.request
        first = '' if motion.first_duration is None else (
            f' (the first {motion.first_duration:.2f} s, the {request.then.purpose} motion '
            f'streaming with their end)')
        return [Notice(f'{request.purpose} motion: {motion.duration:.2f} s{first}', 'info'),
                MotionStarted(motion.duration, motion.first_duration)]

    def ended(self, ticket: int, success: bool, message: str) -> list:
        """Take the end of the stream of ``ticket`` (``success``), or its refusal or stop."""
        motion = self._motion
        if motion is None or not motion.streaming or ticket != motion.following:
            return []
        self._motion, self._stream = None, None
        return [MotionEnded(success, message)]

    def check(self, steady: float, now: float) -> list:
        """Send a request unanswered too long again, or give its motion up.

        ``steady`` [s] times the requests' answers; ``now`` [s], on the graph's clock, the end
        of a motion under way (:attr:`end_margin` after its planned end on both clocks, it
        fails as unreported, and its goal is cancelled).
        """
        motion = self._motion
        if motion is None:
            return []
        if motion.streaming:
            return self._end_overdue(motion, steady, now)
        if motion.sendings is None:
            if motion.following is None and not motion.new_plans:
                # its plans were all asked ahead: waited for from now
                motion.sendings = UnansweredRequest(steady, steady, self._answer_wait,
                                                    self._give_up_after)
            return []
        action = motion.sendings.action(steady)
        if action == WAIT:
            return []
        service = motion.service
        if action == GIVE_UP:
            self._motion = None
            reason = (f'the planner answered no {service} request in '
                      f'{steady - motion.sendings.first_sent:.0f} s, asked again every '
                      f'{self._answer_wait:g} s over a new connection')
            return [Notice(reason, 'error'), MotionEnded(False, reason)]
        motion.sent_again_from, motion.sendings = motion.sendings, None
        out = [Notice(f'no answer from the planner to {service} within '
                      f'{self._answer_wait:g} s: asking again over a new connection'),
               RenewPlannerClient(service)]
        if motion.following is not None:
            motion.following = next(self._tickets)
            return out + [FollowMotion(motion.following, motion.request.purpose,
                                       motion.trajectory, motion.duration)]
        motion.plans, motion.answers, motion.new_plans = [], {}, True
        for part in motion.parts:
            ticket = next(self._tickets)
            motion.plans.append(ticket)
            motion.answers[ticket] = PENDING
            out.append(PlanMotion(ticket, part.purpose, planner_call(part, self._kinematics)))
        return out

    # ------------------------------------------------------------------ internals
    def _end_overdue(self, motion: _Motion, steady: float, now: float) -> list:
        """Fail a motion whose end is overdue (``steady``, ``now`` [s]); cancel its goal."""
        if not now > motion.end:
            return []
        if motion.past_end_since is None:
            motion.past_end_since = steady
        margin = self._end_margin
        if not (now > motion.end + margin and steady > motion.past_end_since + margin):
            return []
        ticket = motion.following
        self._motion, self._stream = None, None
        reason = (f'the planner did not report the end of the {motion.request.purpose} motion '
                  f'({motion.duration:.2f} s planned) within {self._end_margin:g} s of its '
                  f'planned end: the planner may have died or lost its goal')
        return [Notice(reason, 'error'), CancelFollow(ticket),
                MotionEnded(False, reason, unreported=True)]

    def _ahead(self, ticket: int, answer: PlanAnswer | None) -> list:
        answered = self.prepared.answered(ticket, answer)
        if answered is None:
            return []
        purpose, answer = answered
        return [PlannedAhead(purpose, answer.duration if answer is not None
                             and answer.success else None)]

    def _when_planned(self, motion: _Motion) -> list:
        """Once every plan of the motion is back: the mode, then its stream."""
        answers = [motion.answers[ticket] for ticket in motion.plans]
        if any(answer is PENDING for answer in answers):
            return []
        for part, answer in zip(motion.parts, answers, strict=True):
            if answer is None or not answer.success:
                return self._failed(part, 'no response' if answer is None else answer.message)
        out = [MotionPlanned(part.purpose, answer.time_optimal_bound)
               for part, answer in zip(motion.parts, answers, strict=True)]
        request, first = motion.request, answers[0]
        motion.trajectory, motion.duration = first.trajectory, first.duration
        if request.then is not None:
            second = answers[1]
            try:
                motion.trajectory = self.prepared.joined(first, second, request.lead)
            except PlanningError as error:
                return out + self._failed(
                    request, f'it cannot stream with the {request.then.purpose} motion: {error}')
            motion.first_duration = first.duration
            motion.duration = first.duration + second.duration - stream_lead(first, second,
                                                                             request.lead)
        motion.following = next(self._tickets)
        motion.sendings = motion.sent_again_from = None
        # the mode again just before the stream: it clears a hold a controller latched
        return out + [SetControlMode(request.mode, request.base_gripper),
                      FollowMotion(motion.following, request.purpose, motion.trajectory,
                                   motion.duration)]

    def _failed(self, request: TrajectoryRequest, reason: str) -> list:
        self._motion = None
        message = f'planning the {request.purpose} motion failed: {reason}'
        return [Notice(message, 'error'), MotionEnded(False, message)]
