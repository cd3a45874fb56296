"""The supervisor's commands carried out on the cores of the lock-step loop, and their answers.

The step sequencer (and the walk runner around it) gives commands out: the controllers' mode,
a gripper to screw in or out, a motion to plan and stream, a motion to plan ahead, a stream to
stop (:mod:`walker_supervisor.core.sequencer`). The supervisor node carries them out over ROS
(``control_mode``, ``gripper_command``, ``plan_trajectory`` and ``follow_trajectory``);
:class:`CommandExecutor` carries them out on the same cores the nodes around them use, and
answers with the events the node would hear back:

* a mode goes to the five controllers and the planner's hold (:meth:`RobotLoop.command_mode`);
* a gripper command goes to the plant core (its screw time, its jams, its refusal to release
  the only attached gripper: :meth:`~walker_sim.core.plant.WalkerPlant.command_gripper`),
  answered at once (:class:`GripperAnswered`);
* a motion is planned by the planner core (:func:`~walker_planner.core.planning.plan`, the
  request of :func:`~walker_supervisor.core.planner_calls.planner_call`; a motion planned
  ahead is taken from :class:`~walker_supervisor.core.prepared_motions.PreparedMotions`), joined
  with the one it streams with (:func:`~walker_planner.core.chaining.chain`), checked against
  the joint limits and streamed by the planner's streamer: :class:`StreamStarted`, then
  :class:`StreamEnded` at the state where the stream ends (:meth:`take_stream_end`), or
  :class:`StreamFailed` when it cannot be planned or streamed;
* a motion planned ahead answers :class:`MotionPlanned` or :class:`MotionNotPlanned`;
* a cancel ends the stream at once, where its sent setpoints end.

Planning takes no simulated time: in the graph the supervisor holds the simulated clock while
it waits for the planner (``supervisor/decided_until``). A trajectory goes through the form
``trajectory_msgs/JointTrajectory`` gives it on the way (its times rounded to the nanosecond),
so the planner streams exactly what its node would.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_core.kinematics import WalkerKinematics
from walker_planner.core.chaining import chain
from walker_planner.core.errors import PlanningError
from walker_planner.core.planning import PlanningContext, plan
from walker_planner.core.streamer import ActiveStream
from walker_planner.core.streaming import SampledTrajectory
from walker_supervisor.core.commands import (
    CancelTrajectory, GripperRequest, Notice, PrepareTrajectory, SetControlMode,
    TrajectoryRequest)
from walker_supervisor.core.planner_calls import planner_call
from walker_supervisor.core.prepared_motions import PreparedMotions, stream_lead

from walker_headless.loop import RobotLoop

__all__ = ['CommandExecutor', 'PlanAnswer', 'GripperAnswered', 'StreamStarted', 'StreamEnded',
           'StreamFailed', 'MotionPlanned', 'MotionNotPlanned', 'Said', 'message_time']

_NS_PER_S = 1_000_000_000


def message_time(seconds: float) -> float:
    """Return a time [s] as ``builtin_interfaces/Duration`` carries it: to the nanosecond."""
    total = int(round(seconds * _NS_PER_S))
    return total // _NS_PER_S + (total % _NS_PER_S) / _NS_PER_S


def as_sent(times, positions, velocities, accelerations, robot=None) -> SampledTrajectory:
    """Return the trajectory of these samples as a ``JointTrajectory`` message carries it.

    With ``robot`` (``WalkerParameters``), checked against the joint limits as the planner
    checks a ``follow_trajectory`` goal.

    Raises
    ------
    PlanningError
        Naming what is wrong (:meth:`SampledTrajectory.from_points`).
    """
    times = [message_time(float(t)) for t in times]
    if robot is None:  # the planner core's own samples: in order, finite, only rounded
        return SampledTrajectory(np.array(times), np.asarray(positions, dtype=float),
                                 np.asarray(velocities, dtype=float),
                                 np.asarray(accelerations, dtype=float))
    return SampledTrajectory.from_points(PHYSICAL_JOINT_NAMES, times, positions, velocities,
                                         accelerations, robot)


@dataclasses.dataclass(frozen=True)
class PlanAnswer:
    """The planner's answer to a motion (what ``plan_trajectory`` answers).

    It is also its own completed future (``done()``, ``result()``), the form
    :class:`~walker_supervisor.core.prepared_motions.PreparedMotions` keeps answers in.
    """

    success: bool
    message: str = ''
    duration: float = 0.0  # [s]
    time_optimal_bound: float = 0.0  # [s], 0 when there is none
    trajectory: SampledTrajectory | None = None

    def done(self) -> bool:
        """Planned already: always True."""
        return True

    def result(self) -> 'PlanAnswer':
        """Return the answer itself."""
        return self


@dataclasses.dataclass(frozen=True)
class GripperAnswered:
    """The plant's answer to a gripper command (``success`` False: refused, or jammed)."""

    success: bool
    message: str


@dataclasses.dataclass(frozen=True)
class StreamStarted:
    """The requested motion streams and should take ``duration`` [s].

    ``first_duration`` [s]: with a motion streamed with it, when the first ends (else None).
    ``bounds``: the time-optimal bound [s] of each motion of the stream, by purpose.
    """

    purpose: str
    duration: float
    first_duration: float | None
    bounds: dict


@dataclasses.dataclass(frozen=True)
class StreamEnded:
    """The motion's stream ended: complete, or (``success`` False) stopped or refused."""

    success: bool
    message: str


@dataclasses.dataclass(frozen=True)
class StreamFailed:
    """The requested motion cannot be planned or streamed (nothing streams)."""

    message: str


@dataclasses.dataclass(frozen=True)
class MotionPlanned:
    """A motion asked for ahead is planned and will take ``duration`` [s]."""

    purpose: str
    duration: float


@dataclasses.dataclass(frozen=True)
class MotionNotPlanned:
    """A motion asked for ahead could not be planned."""

    purpose: str


@dataclasses.dataclass(frozen=True)
class Said:
    """Something to tell the operator (a ``Notice``, a refusal)."""

    level: str
    message: str


class CommandExecutor:
    """Carry out the supervisor's commands on the loop's cores (see the module docstring).

    Parameters
    ----------
    loop : RobotLoop
        The plant, the controllers and the planner's streamer.
    kinematics : WalkerKinematics
        For the planner requests of Cartesian motions.
    """

    def __init__(self, loop: RobotLoop, kinematics: WalkerKinematics) -> None:
        self.loop = loop
        self.kinematics = kinematics
        sections = loop.sections
        self._robot = sections.walker
        self._planning = PlanningContext.from_parameters(sections.walker, sections.planner)
        self._prepared = PreparedMotions(self._join)
        self._stream: ActiveStream | None = None  # the stream of the motion requested last

    # ------------------------------------------------------------------ commands
    def execute(self, command) -> list:
        """Carry out one command; return the events it answers with at once."""
        if isinstance(command, SetControlMode):
            self.loop.command_mode(command.mode, command.base_gripper)
            return []
        if isinstance(command, GripperRequest):
            return [GripperAnswered(*self.loop.plant.command_gripper(command.gripper,
                                                                      command.action))]
        if isinstance(command, TrajectoryRequest):
            return self._stream_motion(command)
        if isinstance(command, PrepareTrajectory):
            return self._prepare(command.request)
        if isinstance(command, CancelTrajectory):
            self.cancel()
            return []
        if isinstance(command, Notice):
            return [Said('warning', command.message)]
        raise TypeError(f'not a supervisor command: {command!r}')

    def forget_prepared(self) -> None:
        """Forget the motions planned ahead (a step starts)."""
        self._prepared.clear()

    def cancel(self) -> None:
        """Stop the motion's stream now (it holds where its sent setpoints end)."""
        self._prepared.clear()
        stream, self._stream = self._stream, None
        if stream is not None and not stream.ended:
            self.loop.streamer.end_now(stream, 'cancelled')

    def take_stream_end(self) -> StreamEnded | None:
        """Return the end of the requested motion's stream, once, if it ended at this state."""
        ended = self.loop.streamer.take_ended()
        stream = self._stream
        if stream is None or stream not in ended:
            return None
        self._stream = None
        return StreamEnded(not stream.cancelled, stream.message)

    # ------------------------------------------------------------------ planning
    def plan_now(self, request: TrajectoryRequest) -> PlanAnswer:
        """Plan one motion (not its ``then``) as the planner node's service does."""
        try:
            result = plan(planner_call(request, self.kinematics), self._planning)
        except PlanningError as error:
            return PlanAnswer(False, str(error))
        trajectory = as_sent(result.times, *result.samples)
        if self.loop.recording is not None:  # the node publishes every plan it answers
            self.loop.recording.planned_trajectory(self.loop.stamp, trajectory)
        return PlanAnswer(True, '', result.duration, result.time_optimal_bound or 0.0,
                          trajectory)

    def _prepare(self, request: TrajectoryRequest) -> list:
        answer = self.plan_now(request)
        self._prepared.add(request, answer)
        if not answer.success:
            return [MotionNotPlanned(request.purpose)]
        self._prepared.join_ahead()
        return [MotionPlanned(request.purpose, answer.duration)]

    def _answer(self, request: TrajectoryRequest) -> PlanAnswer:
        taken = self._prepared.take(request)
        return taken.result() if taken is not None else self.plan_now(request)

    def _join(self, first: PlanAnswer, second: PlanAnswer, lead: float) -> SampledTrajectory:
        joined = chain(first.trajectory, second.trajectory, stream_lead(first, second, lead))
        return as_sent(joined.times, joined.positions, joined.velocities,
                       joined.accelerations)

    def _stream_motion(self, request: TrajectoryRequest) -> list:
        motions = [request] if request.then is None else [request, request.then]
        answers = [self._answer(motion) for motion in motions]
        for motion, answer in zip(motions, answers, strict=True):
            if not answer.success:
                return [StreamFailed(f'planning the {motion.purpose} motion failed: '
                                     f'{answer.message}')]
        bounds = {motion.purpose: answer.time_optimal_bound
                  for motion, answer in zip(motions, answers, strict=True)}
        first = answers[0]
        trajectory, duration, first_duration = first.trajectory, first.duration, None
        if request.then is not None:
            following = answers[1]
            try:
                trajectory = self._prepared.joined(first, following, request.lead)
            except PlanningError as error:
                return [StreamFailed(f'planning the {request.purpose} motion failed: it cannot '
                                     f'stream with the {request.then.purpose} motion: {error}')]
            first_duration = first.duration
            duration = first.duration + following.duration - stream_lead(
                first, following, request.lead)
        self.loop.command_mode(request.mode, request.base_gripper)  # clears a latched hold
        streamer = self.loop.streamer
        if streamer.active is not None:  # the planner rejects the goal
            return [StreamFailed('the planner refused to stream the trajectory')]
        started = StreamStarted(request.purpose, duration, first_duration, bounds)
        try:
            goal = as_sent(trajectory.times, trajectory.positions, trajectory.velocities,
                           trajectory.accelerations, self._robot)
            self._stream = streamer.start(goal)
        except PlanningError as error:  # the goal is accepted, then aborted
            return [started, StreamEnded(False, str(error))]
        if self.loop.recording is not None:
            self.loop.recording.planned_trajectory(self.loop.stamp, goal,
                                                   self._stream.stream.origin)
        return [started]
