"""What the supervisor's cores ask of the world, and the records they publish (free of ROS).

A core never acts itself: each event it takes returns a list of these, which its shell (the ROS
node, or a headless loop) carries out in order. Units are SI (rad, m, s).

Commands of a step (:class:`~walker_supervisor.core.sequencer.StepSequencer`):
:class:`SetControlMode`, :class:`GripperRequest`, :class:`TrajectoryRequest`,
:class:`PrepareTrajectory`, :class:`CancelTrajectory`, :class:`LookRequest`, :class:`Notice`.

Commands of the walk (:class:`~walker_supervisor.core.runner.WalkRunner`, which turns the
step's trajectory commands into planner requests): :class:`SetControlMode`,
:class:`GripperRequest`, :class:`LookRequest`, :class:`PlanMotion`, :class:`FollowMotion`,
:class:`CancelFollow`, :class:`RenewPlannerClient`, :class:`StopOrphanStream`, :class:`RecordStep`,
:class:`ForgetRecordedStep`, :class:`StopJog`, :class:`RenewModePublisher`,
:class:`DecideNow`, :class:`Notice`; and the records to publish: :class:`PhaseRecord`,
:class:`StepRecord`, :class:`HoleSighted`, :class:`Feedback`, :class:`GoalEnded`.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from walker_supervisor.core.phases import Phase, StepOutcome
from walker_supervisor.core.route import PlannedStep

__all__ = [
    'SetControlMode', 'GripperRequest', 'TrajectoryRequest', 'PrepareTrajectory',
    'CancelTrajectory', 'LookRequest', 'Notice', 'PlanMotion', 'FollowMotion', 'CancelFollow',
    'RenewPlannerClient', 'StopOrphanStream', 'RecordStep', 'ForgetRecordedStep', 'StopJog',
    'RenewModePublisher', 'DecideNow', 'PhaseRecord', 'StepRecord', 'HoleSighted', 'Feedback',
    'GoalEnded', 'LEVELS',
]

#: Levels of a :class:`Notice`, as a logger's.
LEVELS = ('info', 'warning', 'error')


# ---------------------------------------------------------------------- a step's commands
@dataclasses.dataclass(frozen=True)
class SetControlMode:
    """Put all five controllers in ``mode`` ('off', 'hold', 'coarse', 'fine') for a base."""

    mode: str
    base_gripper: str


@dataclasses.dataclass(frozen=True)
class GripperRequest:
    """Screw a gripper in (``'screw_in'``) or out (``'unscrew'``)."""

    gripper: str
    action: str


@dataclasses.dataclass(frozen=True)
class LookRequest:
    """Take one frame of a gripper's wrist camera, exposed no earlier than ``since`` [s].

    Answer :meth:`~walker_supervisor.core.runner.WalkRunner.frame_seen` with the image and
    the instant it shows (the graph's clock), once it is ready.
    """

    gripper: str
    since: float


@dataclasses.dataclass(frozen=True)
class TrajectoryRequest:
    """Plan and stream a trajectory.

    Attributes
    ----------
    purpose : str
        What the motion is for: 'extraction', 'coarse', 'fine', 'look_lift', 'insertion' or
        'retry_lift'
        (a step's), 'jog_joint' or 'jog_tip' (an operator's, :mod:`.teleop`).
    start, goal : ndarray, shape (5,)
        Joint angles J1..J5 [rad] (role order of ``base_gripper``).
    start_point, goal_point : ndarray, shape (3,)
        The same tip positions [m] in the base frame, for Cartesian trajectory types.
    sweep : float
        Signed base yaw sweep [rad] (coarse motion only, else 0).
    base_gripper : str
        The base during the motion.
    mode : str
        Controller mode for the motion ('coarse' or 'fine'), commanded again just before it
        streams: a controller that latched a hold (a stale input) tracks again. Not part of
        :meth:`same_motion`: the plan does not depend on it.
    then : TrajectoryRequest or None
        A motion streamed with this one, as one trajectory: it starts ``lead`` [s] before
        this one ends, and over the overlap the two motions add (the lift and the sweep,
        ``sweep_lead``). Not part of :meth:`same_motion`: each is planned on its own.
    lead : float
        See ``then`` [s].
    """

    purpose: str
    start: np.ndarray
    goal: np.ndarray
    start_point: np.ndarray
    goal_point: np.ndarray
    sweep: float
    base_gripper: str
    mode: str = 'fine'
    then: 'TrajectoryRequest | None' = None
    lead: float = 0.0

    def same_motion(self, other: 'TrajectoryRequest') -> bool:
        """Return True if ``other`` asks for exactly this motion (a plan of one serves both).

        The mode it streams in and what streams with it do not change the plan.
        """
        return (self.purpose == other.purpose and self.base_gripper == other.base_gripper
                and self.sweep == other.sweep
                and all(np.array_equal(getattr(self, name), getattr(other, name))
                        for name in ('start', 'goal', 'start_point', 'goal_point')))


@dataclasses.dataclass(frozen=True)
class PrepareTrajectory:
    """Plan a trajectory that will be requested later, unchanged, so it can stream at once.

    Nothing streams: a later :class:`TrajectoryRequest` equal to ``request``
    (:meth:`TrajectoryRequest.same_motion`) may use the plan; any other plans afresh. With
    ``request.then`` (prepared too, on its own), the two plans may also be joined ahead, for
    a later request that streams them together with the same ``lead``.
    """

    request: TrajectoryRequest


@dataclasses.dataclass(frozen=True)
class CancelTrajectory:
    """Stop any trajectory being streamed (the controllers hold the last setpoint)."""


@dataclasses.dataclass(frozen=True)
class Notice:
    """Something to log: it changes nothing by itself.

    Attributes
    ----------
    message : str
    level : str
        One of :data:`LEVELS` ('warning' by default: something the operator should know).
    """

    message: str
    level: str = 'warning'


# ---------------------------------------------------------------------- the walk's commands
@dataclasses.dataclass(frozen=True)
class PlanMotion:
    """Ask the planner to plan a motion (``plan_trajectory``).

    Answer with :meth:`WalkRunner.plan_answered` (same ``ticket``); tell
    :meth:`WalkRunner.request_sent` when the request leaves (a shell that waits for its
    server to be discovered first), or :meth:`WalkRunner.request_failed` when it cannot.

    Attributes
    ----------
    ticket : int
        Names the request in the answers.
    purpose : str
        The motion's purpose (:class:`TrajectoryRequest`).
    call : walker_planner.core.planning.PlanRequest
        The planner's request (:func:`walker_supervisor.core.planner_calls.planner_call`).
    ahead : bool
        Planned ahead of its request (:class:`PrepareTrajectory`): a shell whose planner is
        not reachable now answers :meth:`WalkRunner.request_failed` at once, without waiting.
    """

    ticket: int
    purpose: str
    call: object
    ahead: bool = False


@dataclasses.dataclass(frozen=True)
class FollowMotion:
    """Stream a planned trajectory to the controllers (``follow_trajectory``).

    Answer with :meth:`WalkRunner.follow_accepted`, then :meth:`WalkRunner.follow_done`.

    Attributes
    ----------
    ticket : int
    purpose : str
    trajectory : object
        As the planner answered it (:class:`~walker_supervisor.core.motion_requests.PlanAnswer`),
        or two such answers joined (the lift and the sweep).
    duration : float
        Its duration [s].
    """

    ticket: int
    purpose: str
    trajectory: object
    duration: float


@dataclasses.dataclass(frozen=True)
class CancelFollow:
    """Cancel the stream of :class:`FollowMotion` ``ticket`` (the controllers hold)."""

    ticket: int


@dataclasses.dataclass(frozen=True)
class RenewPlannerClient:
    """Make the client of the planner's ``service`` anew before the requests that follow.

    ``service`` is 'plan_trajectory' or 'follow_trajectory'. A restarted planner was seen
    never to answer an old client while a new one was answered at once. A shell without
    clients (a headless loop) ignores it.
    """

    service: str


@dataclasses.dataclass(frozen=True)
class StopOrphanStream:
    """Stop any stream an earlier incarnation of the supervisor left running (safe hold)."""


@dataclasses.dataclass(frozen=True)
class RecordStep:
    """Keep the step under way where a restarted supervisor finds it (the step-state file).

    Attributes
    ----------
    step : PlannedStep
    heading : float
        Heading [rad] of the base frame in the truss frame.
    survey : dict or None
        The truss map the step was planned on (:meth:`~walker_supervisor.core.truss_map.
        TrussMap.to_dict`): a supervisor started again aims where this one did.
    """

    step: PlannedStep
    heading: float
    survey: dict | None = None


@dataclasses.dataclass(frozen=True)
class ForgetRecordedStep:
    """Remove the recorded step: it completed, or no longer describes the walker."""


@dataclasses.dataclass(frozen=True)
class StopJog:
    """Stop an operator's jog under way, if any, with this reason (a hold or a fault)."""

    reason: str


@dataclasses.dataclass(frozen=True)
class RenewModePublisher:
    """Make the ``control_mode`` publisher anew: controllers told the mode again in vain.

    Seen with Fast DDS's shared-memory transport after a process of the graph was killed and
    started again. The :class:`SetControlMode` that follows goes out on the new publisher.
    """


@dataclasses.dataclass(frozen=True)
class DecideNow:
    """Something a step waits for happened: call :meth:`WalkRunner.tick` now.

    A shell that ticks every control period may ignore it; the graph, which decides every
    ``TICK_PERIOD``, saves up to a period per step with it.
    """


# ---------------------------------------------------------------------- records
@dataclasses.dataclass(frozen=True)
class PhaseRecord:
    """The phase to publish now (``walker_msgs/StepPhase``).

    Attributes
    ----------
    phase : Phase
    base_gripper, reason : str
    phase_progress : float
        Fraction of the phase done, in [0, 1].
    step_index, step_count : int
        The step within the walk under way (0, 0 without a walk).
    from_node, to_node, base_node : str
        The step under way, or held with its gripper free ('' otherwise).
    base_heading : float
        Heading [rad] of its base frame in the truss frame (0 without a step).
    """

    phase: Phase
    base_gripper: str
    reason: str
    phase_progress: float
    step_index: int = 0
    step_count: int = 0
    from_node: str = ''
    to_node: str = ''
    base_node: str = ''
    base_heading: float = 0.0


@dataclasses.dataclass(frozen=True)
class StepRecord:
    """A step that ended, with its figures (``walker_msgs/StepReport``).

    Attributes
    ----------
    step_index, step_count : int
    step : PlannedStep
    outcome : StepOutcome
    time_optimal_bound : float
        [s] the step's extraction, coarse motion and insertion at their limits, plus the two
        screw actions.
    insertion_error : float
        [m] the tip's measured distance from the hole's axis as the screw-in started.
    residual_vibration : float
        [m] the tip's largest deviation from its mean over the settle window then.
    """

    step_index: int
    step_count: int
    step: PlannedStep
    outcome: StepOutcome
    time_optimal_bound: float
    insertion_error: float
    residual_vibration: float

    @property
    def bound_ratio(self) -> float:
        """Step time over its time-optimal bound (0 without a bound)."""
        return (self.outcome.duration / self.time_optimal_bound
                if self.time_optimal_bound > 0 else 0.0)


@dataclasses.dataclass(frozen=True)
class HoleSighted:
    """The hole one frame of a look showed (``geometry_msgs/PointStamped``, ``camera_<g>/hole``).

    Only a frame that showed the hole gives one.

    Attributes
    ----------
    gripper : str
        Whose camera.
    exposure_time : float
        [s] The frame's instant (its image's stamp).
    point : ndarray, shape (3,)
        [m] The hole's mouth in the gripper's frame at that instant: x, y the hole's axis
        from the gripper's axis as this frame alone measured it, z the face's height the step
        assumed (negative: below the gripper).
    """

    gripper: str
    exposure_time: float
    point: np.ndarray


@dataclasses.dataclass(frozen=True)
class Feedback:
    """Progress of the goal under way (``walker_msgs/action/WalkTo`` or ``Step`` feedback).

    Attributes
    ----------
    goal : str
        'walk_to' or 'step'.
    step_index, step_count : int
    phase : Phase
    phase_progress : float
        As on ``phase``, in [0, 1].
    from_node, to_node : str
        The step under way ('' between steps).
    tip_position_error : float
        [m] distance of the tip from its target now (0 between steps).
    """

    goal: str
    step_index: int
    step_count: int
    phase: Phase
    phase_progress: float
    from_node: str
    to_node: str
    tip_position_error: float


@dataclasses.dataclass(frozen=True)
class GoalEnded:
    """The goal under way ended: its result.

    Attributes
    ----------
    goal : str
        'walk_to' or 'step'.
    status : str
        'succeeded', 'canceled' or 'aborted'.
    message : str
        Why it did not succeed ('' when it did).
    steps_taken : int
        Steps that succeeded.
    duration : float
        [s] walking time: the steps' times added.
    path : list of str
        Nodes the moving grippers were screwed into, in order.
    base_gripper, base_node : str
        The base after the goal, and its node.
    step_duration, insertion_error, time_optimal_bound : float
        Of the last step taken (all 0 when none was): its time [s], the tip's measured
        distance from the hole's axis at its screw-in [m] (NaN if it never screwed in), its
        time-optimal bound [s].
    """

    goal: str
    status: str
    message: str
    steps_taken: int
    duration: float
    path: list[str]
    base_gripper: str
    base_node: str
    step_duration: float = 0.0
    insertion_error: float = 0.0
    time_optimal_bound: float = 0.0

    @property
    def success(self) -> bool:
        """True when every planned step succeeded."""
        return self.status == 'succeeded'
