"""The step-phase state machine (paper section 2, Figure 2), free of ROS.

A step runs EXTRACTION -> COARSE -> FINE -> INSERTION. The sequencer takes events (a gripper
command finished, a trajectory started or finished, a periodic tick with the measured joints and
gripper states) and returns the commands the node must carry out (set the controllers' mode,
screw a gripper in or out, run or cancel a trajectory). It never blocks and never talks to ROS,
so every path through a step, faults included, is tested with plain pytest.

Rules it enforces:

* a step starts only with both grippers attached, and the moving gripper is unscrewed only while
  the base gripper is verified attached;
* the step's targets rest on the base frame measured from the stance; a screw-in bends the closed
  chain, which the controllers' relaxation dither frees after it (``relaxation_wait``), so the
  frame is measured again once the relaxation is over, while the gripper is still unscrewing
  and the chain still closed; the extraction and coarse motions are then planned at once
  (:class:`PrepareTrajectory`), so that they stream the moment they are due; so is the descent,
  on entering FINE; the sweep streams with the lift, from ``sweep_lead`` before its end, once
  its plan is back: the freed gripper waits at most ``sweep_lead`` for it, then lifts alone;
* coarse motion (controllers in COARSE mode: low gains, acceleration feedback) ends when the tip
  error, from the forward kinematics of the measured joints, enters ``coarse_to_fine_region``:
  the controllers then switch to FINE mode (higher gains, integral action) while the coarse
  trajectory runs on to its end, the point above the hole;
* fine motion ends, once the trajectory has ended, as soon as the tip is within
  ``descent_region`` (the insertion tolerance) of the point above the hole and still closing
  on it, joint 1 coming in behind its filter (not swinging through it), or within
  ``insertion_alignment`` with every joint slower than ``settle_velocity``: the descent need
  not wait for the tip to come to rest, since the insertion settles at the mouth and checks
  the tip again, across the hole's axis, before anything screws in. A tip that settles
  (``settle_time``) anywhere else gets a constant-velocity fine line (paper section 5) from
  where it settled, up to ``MAX_FINE_LINES`` times before insertion is tried anyway (the
  screw-in itself is the final check);
* insertion descends along the hole axis to its mouth (a descent whose tip leaves the axis by
  more than ``descent_axis_tolerance`` is stopped and the gripper lifted straight back to the
  approach height, to come over the hole again: an insertion attempt, as a jam is); the
  descent moves the joints, which
  stop in their friction again, so once they have been still for ``mouth_settle_time`` (the
  vertical descent hardly moves joint 1; after a line at the mouth, which does, for
  ``settle_time``) the tip is checked again, now
  across the hole's axis: more than ``insertion_alignment`` off it, a fine line at the mouth
  takes it there (up to ``MAX_FINE_LINES`` times; more than ``descent_axis_tolerance`` off, the
  gripper is lifted back instead), and only then is the gripper screwed in; a
  jammed screw-in is retried up to
  ``max_insertion_attempts`` times (each lift goes straight up from where the gripper jammed),
  then the step is aborted to SAFE_HOLD; a step ends when the gripper reports attached, with
  the controllers commanded to HOLD under the new base (which starts their relaxation);
* any failure, a phase that overruns its planned time by ``phase_timeout``, or a trajectory that
  has not started ``phase_timeout`` after its request (the planner gone) ends in SAFE_HOLD:
  trajectories cancelled, controllers holding, grippers untouched (the base stays attached);
* :meth:`StepSequencer.resume` leaves SAFE_HOLD: with both grippers attached it returns to IDLE;
  with the moving gripper free it completes the interrupted step from where the arm is (straight
  up out of the hole it was leaving if it is still in it, then to the point above the target,
  settling, insertion). The way back above the target is a straight tip line where the arm can
  follow one, else a joint-space line that keeps the tip above the truss
  (:mod:`walker_supervisor.core.way_back`), also when the planner refuses the tip line; with
  neither, resume is refused and nothing changes.
"""

from __future__ import annotations

import dataclasses
import enum
import math
from collections.abc import Callable

import numpy as np

from walker_core.kinematics import KinematicsError, WalkerKinematics
from walker_core.parameter_schema import ParameterError, parameter
from walker_supervisor.core.route import PlannedStep
from walker_supervisor.core.step_geometry import StepTargets
from walker_supervisor.core.way_back import (
    line_is_followable, lowest_tip_height, vertical_configuration, vertical_ik)

__all__ = [
    'Phase', 'SupervisorParameters', 'SetControlMode', 'GripperRequest', 'TrajectoryRequest',
    'PrepareTrajectory', 'CancelTrajectory', 'Notice', 'StepOutcome', 'StepSequencer',
    'SequencerError', 'STANCE_MARGIN',
]


class Phase(enum.IntEnum):
    """Phases of a step; the values are those of ``walker_msgs/StepPhase``."""

    IDLE = 0
    EXTRACTION = 1
    COARSE = 2
    FINE = 3
    INSERTION = 4
    SAFE_HOLD = 5


#: Fine correction lines tried before insertion is attempted anyway.
MAX_FINE_LINES = 3
#: [rad] The descent planned ahead (on entering FINE) starts at the configuration above the
#: hole; joints farther than this from it (any joint) descend from where they are instead.
PREPARED_DESCENT_TOLERANCE = 0.02
#: [s] A step starts no earlier than this before the unscrewing would end with the relaxation
#: still running, so that the stance is measured after the relaxation, with the chain closed.
STANCE_MARGIN = 0.1


class SequencerError(ValueError):
    """An event that the sequencer cannot accept in its current state."""


@dataclasses.dataclass(frozen=True)
class SupervisorParameters:
    """Switching regions and fault limits of the step (section ``supervisor.``)."""

    coarse_to_fine_region: float = parameter(
        'tip distance from the point above the target at which COARSE hands over to FINE',
        'm', 0.001, 0.5, read_only=False,
        source='paper section 1: the phase switches on an error region; chosen: 3 cm')
    insertion_alignment: float = parameter(
        'largest tip error above the hole to descend from rest, and from the axis to screw in',
        'm', 1e-5, 0.05, read_only=False,
        source="chosen: a quarter of the 2 mm insertion tolerance, the benchmark's 0.5 mm")
    settle_velocity: float = parameter(
        'joints slower than this count as still', 'rad/s', 1e-4, 1.0, read_only=False,
        source='chosen')
    settle_time: float = parameter(
        'time the joints must be still after a motion of joint 1 before the tip is judged',
        's', 0.0, 10.0, read_only=False,
        source='chosen: joint 1 comes in behind its filter slowly enough to look still for 0.1 s')
    phase_timeout: float = parameter(
        'time a phase may overrun its plan before the step is aborted',
        's', 0.1, 600.0, read_only=False,
        source="chosen: joint 1's fine loop needs seconds to settle after an overshoot")
    max_insertion_attempts: int = parameter(
        'screw-in attempts before a jammed insertion aborts the step', '', 1, 10, read_only=False,
        source='chosen: a bounded retry')
    watchdog_timeout: float = parameter(
        'silence of the plant or a controller (steady clock) that puts the walker in safe hold',
        's', 0.05, 60.0, read_only=False,
        source='chosen: a loaded 2-core machine starves a process for over a second at times')
    coarse_start_tolerance: float = parameter(
        'largest joint distance from the start of the coarse motion, or of a way back, to begin '
        'it', 'rad', 1e-4, 0.5, read_only=False,
        source='chosen: below planner.stream.start_tolerance')
    relaxation_wait: float = parameter(
        "time after a screw-in until the controllers' relaxation is over (0: no wait)",
        's', 0.0, 5.0, read_only=False,
        source='chosen: control.relaxation.duration and a margin')
    mouth_settle_time: float = parameter(
        "time the joints must be still at the hole's mouth before the screw-in",
        's', 0.0, 10.0, read_only=False,
        source='chosen: the descent hardly moves joint 1')
    descent_region: float = parameter(
        'tip distance from the point above the hole within which a closing tip may descend',
        'm', 1e-5, 0.05, read_only=False,
        source='chosen: the insertion tolerance; the tip reaches the axis during the descent')
    descent_axis_tolerance: float = parameter(
        "tip distance from the hole's axis beyond which a descent is stopped and lifted back",
        'm', 1e-4, 0.05, read_only=False,
        source='chosen: ordinary descents are at most 2.2-3.0 mm off')
    descent_arrival_time: float = parameter(
        'a closing tip that would reach the point above the hole sooner is swinging through it',
        's', 0.001, 1.0, read_only=False,
        source='chosen: one decision period')
    sweep_lead: float = parameter(
        "how long before the lift ends the coarse motion's setpoints begin (0: after it)",
        's', 0.0, 1.0, read_only=False,
        source="chosen: joint 1's filter holds the sweep back while the gripper rises")

    def __post_init__(self) -> None:
        if self.insertion_alignment >= self.coarse_to_fine_region:
            raise ParameterError(
                f'supervisor.insertion_alignment ({self.insertion_alignment} m) must be smaller '
                f'than supervisor.coarse_to_fine_region ({self.coarse_to_fine_region} m)')
        if not self.descent_axis_tolerance > self.descent_region:
            raise ParameterError(
                f'supervisor.descent_axis_tolerance ({self.descent_axis_tolerance} m) must be '
                f'larger than supervisor.descent_region ({self.descent_region} m): the descent '
                f'may start that far off the axis')
        if not self.insertion_alignment <= self.descent_region < self.coarse_to_fine_region:
            raise ParameterError(
                f'supervisor.descent_region ({self.descent_region} m) must be at least '
                f'supervisor.insertion_alignment ({self.insertion_alignment} m) and smaller '
                f'than supervisor.coarse_to_fine_region ({self.coarse_to_fine_region} m)')


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
class TrajectoryRequest:
    """Plan and stream a trajectory.

    Attributes
    ----------
    purpose : str
        What the motion is for: 'extraction', 'coarse', 'fine', 'insertion' or 'retry_lift'
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
    """Something the operator should know that changes nothing (a warning to log)."""

    message: str


@dataclasses.dataclass
class StepOutcome:
    """How a step ended, with the figures the walk summary reports.

    Attributes
    ----------
    success : bool
    message : str
        Why it failed ('' on success).
    phase_durations : dict of str to float
        Time spent in each phase [s].
    duration : float
        Step time [s] from start to the screw-in (the gripper reported attached).
    insertion_error : float
        Tip distance [m] from the hole's axis when the screw-in was requested, at the mouth
        (forward kinematics of the measured joints: what the walker knows); before that, from
        the point above the hole when the descent started; NaN if insertion never started.
    insertion_attempts : int
    """

    success: bool
    message: str
    phase_durations: dict[str, float]
    duration: float
    insertion_error: float
    insertion_attempts: int


class StepSequencer:
    """Runs one step at a time through its phases.

    Parameters
    ----------
    parameters : SupervisorParameters
        Switching regions and fault limits.
    kinematics : WalkerKinematics
        For the tip position from the measured joints.
    base_gripper : str
        The base before the first step; after each completed step, the gripper that moved.
    screw_time : float
        Time a gripper takes to screw in or out [s] (``gripper.screw_time``).
    """

    def __init__(self, parameters: SupervisorParameters, kinematics: WalkerKinematics,
                 base_gripper: str = 'a', screw_time: float = 0.5) -> None:
        self.parameters = parameters
        self.kinematics = kinematics
        self.base_gripper = base_gripper
        # [s] how long a gripper may take to report free or attached after accepting
        self._screw_allowance = screw_time + parameters.phase_timeout
        self._gripper_deadline = math.inf
        self.phase = Phase.IDLE
        self.stage = ''
        self.reason = ''
        self.outcome: StepOutcome | None = None
        self._outcome_taken = True
        self._step: PlannedStep | None = None
        self._targets: StepTargets | None = None
        self._theta = np.zeros(5)
        self._grippers: dict[str, str] = {}
        self._phase_started = 0.0
        self._step_started = 0.0
        self._deadline = math.inf
        self._relaxed_at = -math.inf  # [s] when the last relaxation under a new base is over
        # measures the step's targets again from joint angles (role order), once the stance is
        # relaxed (None: the targets the step started with are final)
        self._remeasure: Callable[[np.ndarray], StepTargets] | None = None
        self._screw_time = screw_time
        self._settled_since: float | None = None
        # [m] tip_error() at this tick and the last (nan: none yet in this phase)
        self._tip_error_now = math.nan
        # [s] when the lift of a lift streamed with its sweep ends (None: no such stream)
        self._lift_ends: float | None = None
        self._attempts = 0
        self._durations: dict[str, float] = {}
        self._fine_lines = 0
        self._mouth_lines = 0
        self._insertion_error = math.nan
        self._trajectory_running = False
        self._gripper_answers_due = 0  # gripper commands sent and not answered yet
        # the moving gripper's reported state when the current screw-in was requested, until
        # it reports another (None: what it reports is about this attempt)
        self._state_before_screwing: str | None = None
        self._requested: str | None = None  # purpose of a trajectory requested, not started
        self._last_purpose = ''  # purpose of the last trajectory requested
        self._requested_at: float | None = None  # [s] first tick after the request
        self._planned_motions: dict[str, float] = {}  # [s] last planned duration, by purpose
        self._planned_ahead: set[str] = set()  # motions planned ahead for this step, and back
        self._asked_ahead: set[str] = set()  # motions asked ahead, whose plans may yet come
        self._free_since: float | None = None  # [s] the moving gripper reported free, unlifted
        self._progress = 0.0  # of the phase entered at _progress_key
        self._progress_key: tuple | None = None

    # ------------------------------------------------------------------ queries
    @property
    def busy(self) -> bool:
        """True while a step is under way."""
        return self.phase not in (Phase.IDLE, Phase.SAFE_HOLD)

    @property
    def step(self) -> PlannedStep | None:
        """The step under way (or the last one)."""
        return self._step

    @property
    def targets(self) -> StepTargets | None:
        """The targets of the step under way (or of the last one)."""
        return self._targets

    def take_outcome(self) -> StepOutcome | None:
        """Return the outcome of the step that ended since the last call, once; else None.

        A step ends once, however it was started and resumed: taken by the walk it belongs to,
        or, for a step completed by :meth:`resume` after its walk was aborted, by whoever asks
        next, so that it is never taken again as the first step of another walk.
        """
        if self._outcome_taken or self.outcome is None:
            return None
        self._outcome_taken = True
        return self.outcome

    def adopt(self, step: PlannedStep, targets: StepTargets, reason: str) -> None:
        """Take over an interrupted step, in SAFE_HOLD, so that :meth:`resume` completes it.

        Used by a supervisor restarted in the middle of a step; raises :class:`SequencerError`
        if a step is under way here.
        """
        if self.busy:
            raise SequencerError(f'a step is already under way (phase {self.phase.name})')
        self._step, self._targets = step, targets
        self.base_gripper = step.base_gripper
        self.phase, self.stage, self.reason = Phase.SAFE_HOLD, '', reason

    def tip_error(self) -> float:
        """Distance [m] of the tip (forward kinematics) from the current phase's target point."""
        if self._targets is None:
            return math.nan
        target = {Phase.EXTRACTION: self._targets.point_above_from,
                  Phase.INSERTION: self._targets.point_to}.get(self.phase,
                                                               self._targets.point_above_to)
        return float(np.linalg.norm(self.kinematics.forward(self._theta)[:3] - target))

    def phase_progress(self, now: float) -> float:
        """Fraction of the current phase done, in [0, 1] (``StepPhase.phase_progress``).

        EXTRACTION, COARSE and INSERTION go by time: the time in the phase over its planned
        duration, the sum of its timed parts (EXTRACTION: the unscrewing, ``screw_time``, and
        the lift; COARSE: the coarse motion; INSERTION: the descent, ``mouth_settle_time`` and the
        screw-in), each motion as planned once it streams and, until then, as the last one of
        its kind was (0 before the first). FINE goes by the tip error: 0 at
        ``coarse_to_fine_region``, 1 at ``insertion_alignment``. The value never decreases
        within a phase, and stays at 1 when a phase runs over its plan (a correction line, a
        retried screw-in); 0 in IDLE and SAFE_HOLD.
        """
        if self.phase in (Phase.IDLE, Phase.SAFE_HOLD) or self._targets is None:
            return 0.0
        key = (self.phase, self._phase_started)
        if key != self._progress_key:
            self._progress_key, self._progress = key, 0.0
        parameters = self.parameters
        if self.phase == Phase.FINE:
            value = (parameters.coarse_to_fine_region - self.tip_error()) \
                / (parameters.coarse_to_fine_region - parameters.insertion_alignment)
        else:
            motions = self._planned_motions
            planned = {
                Phase.EXTRACTION: self._screw_time + motions.get('extraction', 0.0),
                Phase.COARSE: motions.get('coarse', 0.0),
                Phase.INSERTION: motions.get('insertion', 0.0) + parameters.mouth_settle_time
                + self._screw_time}[self.phase]
            value = (now - self._phase_started) / planned if planned > 0.0 else 0.0
        if math.isfinite(value):
            self._progress = max(self._progress, min(1.0, value))
        return self._progress

    # ------------------------------------------------------------------ events
    def can_start(self, now: float) -> bool:
        """Return True if a step started now measures its stance after the last relaxation.

        The stance is measured again at the end of the relaxation, during the unscrewing
        (``screw_time``), so a step may start up to that long (less :data:`STANCE_MARGIN`)
        before the relaxation is over.
        """
        return now >= self._relaxed_at - max(0.0, self._screw_time - STANCE_MARGIN)

    def start(self, step: PlannedStep, targets: StepTargets, now: float,
              grippers: dict[str, str],
              remeasure: Callable[[np.ndarray], StepTargets] | None = None) -> list:
        """Begin a step: both grippers must be attached, and no step under way.

        The controllers hold while the moving gripper unscrews (a relaxation under way runs
        on). The extraction and coarse motions are planned ahead (:class:`PrepareTrajectory`)
        as soon as the targets are final: at once, or, while a relaxation is under way, when it
        is over.

        Parameters
        ----------
        targets : StepTargets
            The targets from the stance now.
        remeasure : callable, optional
            ``remeasure(theta_roles) -> StepTargets``: the targets measured again from joint
            angles [rad] (role order), both grippers attached. Called once, at the first tick
            after the relaxation while the gripper is still unscrewing; a
            :class:`~walker_core.kinematics.KinematicsError` keeps ``targets`` (with a
            :class:`Notice`). Without it, or with no relaxation under way, ``targets`` stand.

        Raises
        ------
        SequencerError
            A step is already under way, or a gripper is not attached.
        """
        if self.busy:
            raise SequencerError(f'a step is already under way (phase {self.phase.name})')
        if self.phase == Phase.SAFE_HOLD:
            raise SequencerError(f'the walker is in SAFE_HOLD ({self.reason}): resume first')
        if step.base_gripper != self.base_gripper:
            raise SequencerError(f'the step pivots on gripper {step.base_gripper} but the base '
                                 f'is gripper {self.base_gripper}')
        detached = sorted(g for g in ('a', 'b') if grippers.get(g) != 'attached')
        if detached:
            raise SequencerError(f'a step starts only with both grippers attached; gripper '
                                 f'{", ".join(detached)} is not')
        self._step, self._targets, self._grippers = step, targets, dict(grippers)
        self._theta = targets.start.copy()
        self._step_started = now
        self._durations = {}
        self._planned_ahead, self._asked_ahead = set(), set()
        self._attempts = 0
        self._fine_lines = 0
        self._insertion_error = math.nan
        self.outcome = None
        self.reason = ''
        self._remeasure = remeasure if now < self._relaxed_at else None
        self._enter(Phase.EXTRACTION, now, 'unscrewing')
        self._deadline = math.inf
        self._gripper_deadline = now + self._screw_allowance
        self._gripper_answers_due += 1
        commands = [SetControlMode('hold', step.base_gripper),
                    GripperRequest(step.moving_gripper, 'unscrew')]
        return commands + ([] if self._remeasure is not None else self._prepare())

    def gripper_done(self, success: bool, message: str, now: float) -> list:
        """Take the answer to a gripper command.

        ``success`` True means the command was accepted: the gripper is unscrewing or screwing,
        and its reported state (:meth:`tick`) says when it is free or attached. False means it
        was refused, failed, or jammed at once. An answer that arrives after a hold is
        ignored: the hold has stopped the step, and the gripper's reported state is what
        :meth:`resume` goes by.

        The gripper states and the answer travel separately: when the states have already shown
        the outcome (a jam, a gripper free) and the step has moved on, the late answer changes
        nothing either.
        """
        answered = self._gripper_answers_due > 0
        self._gripper_answers_due = max(0, self._gripper_answers_due - 1)
        if self.phase == Phase.SAFE_HOLD:
            return []
        if self.stage not in ('unscrewing', 'screwing'):
            if answered:
                return []
            raise SequencerError(f'unexpected gripper result in phase {self.phase.name} '
                                 f'({self.stage or "no stage"})')
        if success:
            self._gripper_deadline = now + self._screw_allowance
            return []
        if self.stage == 'unscrewing':
            return self._abort(f'unscrewing gripper {self._step.moving_gripper} failed: '
                               f'{message}', now)
        return self._jammed(message, now)

    @property
    def awaiting_plan(self) -> bool:
        """True while the freed gripper's lift waits for the sweep's plan (``sweep_lead``).

        False as soon as the plan is back (:meth:`motion_planned`) or will not come
        (:meth:`motion_not_planned`): the lift then starts at the next tick. The node holds
        the sim-time clock while this is True, so it must not stay True on a frozen clock.
        """
        return self.stage == 'unscrewing' and self._free_since is not None \
            and 'coarse' in self._asked_ahead and 'coarse' not in self._planned_ahead

    def _sweep_plan_due(self, now: float) -> bool:
        """Return True while the lift should wait for the sweep's plan, asked ahead.

        Streamed with the lift, the sweep saves ``sweep_lead``; so the lift waits for its plan
        at most that long after the gripper is free (a plan asked late, after a relaxation,
        on a loaded machine), and then streams alone. The wait is counted on the clock the
        ticks come with (simulated time in sim time; the node bounds its clock hold on the
        wall clock, :class:`~walker_supervisor.core.decision_clock.DecisionClock`).
        """
        if self.parameters.sweep_lead <= 0.0 or 'coarse' in self._planned_ahead \
                or 'coarse' not in self._asked_ahead:
            return False
        if self._free_since is None:
            self._free_since = now
        return now - self._free_since < self.parameters.sweep_lead

    def _unscrewed(self, now: float) -> list:
        if self._sweep_plan_due(now):
            return []
        self._free_since = None
        self.stage = 'lifting'
        self._remeasure = None  # too late: the chain is open
        request = self._extraction_request()
        if 'coarse' in self._planned_ahead:
            # the sweep streams with the lift, overlapping; only with the coarse motion's
            # plan already back, so the lift does not wait for it
            request = self._lift_with_sweep(request)
        return [self._issue(request)]

    def _extraction_request(self) -> TrajectoryRequest:
        t = self._targets
        return self._request('extraction', t.start, t.above_from, self._start_point(),
                             t.point_above_from)

    def _coarse_request(self) -> TrajectoryRequest:
        t = self._targets
        return self._request('coarse', t.above_from, t.above_to, t.point_above_from,
                             t.point_above_to, t.sweep)

    def _prepare(self) -> list:
        """Plan the extraction and the coarse motion ahead: the targets are final.

        The extraction is asked for as it will stream once both plans are back: with the
        sweep from ``sweep_lead`` before its end, so the two can be joined ahead too.
        """
        self._planned_ahead, self._asked_ahead = set(), {'extraction', 'coarse'}
        return [PrepareTrajectory(self._lift_with_sweep(self._extraction_request())),
                PrepareTrajectory(self._coarse_request())]

    def _lift_with_sweep(self, extraction: TrajectoryRequest) -> TrajectoryRequest:
        """Return the extraction streamed with the coarse motion (``sweep_lead`` > 0)."""
        if self.parameters.sweep_lead <= 0.0:
            return extraction
        # the controllers in COARSE mode from the start: acceleration feedback on joint 1 as
        # its sweep begins
        return dataclasses.replace(extraction, then=self._coarse_request(),
                                   lead=self.parameters.sweep_lead, mode='coarse')

    def _measure_stance_again(self, state: str, now: float) -> list:
        """Once relaxed, with the chain still closed: the targets from the joints now."""
        if self._remeasure is None or state == 'free' or now < self._relaxed_at:
            return []
        remeasure, self._remeasure = self._remeasure, None
        try:
            self._targets = remeasure(self._theta.copy())
        except KinematicsError as error:
            return [Notice(f'the stance measured after the relaxation gives no targets '
                           f'({error}); the step goes on with those from its start')
                    ] + self._prepare()
        return self._prepare()

    def _left_the_axis(self, now: float) -> list:
        """Stop a descent whose tip has left the hole's axis; lift it straight back up.

        Lowered farther, the gripper would meet the node's face beside the hole. Like a jam it
        counts as an insertion attempt: the gripper rises from where it is to the approach
        height, FINE brings it over the hole again, and a new descent starts.
        """
        offset = self.mouth_offset()
        self._attempts += 1
        reason = (f"the descent left the hole's axis ({offset * 1e3:.1f} mm off, tolerance "
                  f'{self.parameters.descent_axis_tolerance * 1e3:.1f} mm)')
        if self._attempts >= self.parameters.max_insertion_attempts:
            return self._abort(f'{reason}; {self._attempts} insertion attempts', now)
        up = self._straight_up(self._targets.point_above_to)
        if up is None:
            return self._abort(f'{reason}, and no straight lift from here', now)
        stop = [CancelTrajectory()] if self._trajectory_running else []
        self.stage = 'retry_lift'
        self._trajectory_running = False
        tip = self.kinematics.forward(self._theta)[:3]
        return stop + [Notice(f'{reason}: lifted back to come over the hole again'),
                       self._trajectory('retry_lift', self._theta, up[0], tip, up[1])]

    def _jammed(self, message: str, now: float) -> list:
        self._attempts += 1
        if self._attempts >= self.parameters.max_insertion_attempts:
            return self._abort(f'insertion jammed {self._attempts} times: {message}', now)
        self.stage = 'retry_lift'
        up = self._straight_up(self._targets.point_above_to)
        if up is None:
            return self._abort(f'insertion jammed: {message}; and no straight lift out of the '
                               f'hole from here', now)
        tip = self.kinematics.forward(self._theta)[:3]
        return [self._trajectory('retry_lift', self._theta, up[0], tip, up[1])]

    def motion_planned(self, purpose: str, planned_duration: float) -> None:
        """Note how long a motion asked for ahead (:class:`PrepareTrajectory`) will take [s].

        Only the phase progress uses it (:meth:`phase_progress`), before the motion streams,
        and the lift, which streams with the sweep (``sweep_lead``) only once the sweep's plan
        is back.
        """
        self._planned_motions[purpose] = float(planned_duration)
        self._planned_ahead.add(purpose)

    def motion_not_planned(self, purpose: str) -> None:
        """Note that a motion asked for ahead will not be planned (refused, or not asked)."""
        self._asked_ahead.discard(purpose)

    def trajectory_started(self, planned_duration: float, now: float,
                           first_duration: float | None = None) -> None:
        """Note that the requested trajectory is streaming and should take this long [s].

        ``first_duration`` [s]: for a request with a motion streamed with it (``then``), when
        the first motion ends, from now: the lift, after which the sweep goes on as COARSE.
        """
        self._trajectory_running = True
        self._requested = self._requested_at = None
        self._deadline = now + planned_duration + self.parameters.phase_timeout
        if first_duration is None:
            self._planned_motions[self._last_purpose] = planned_duration
            return
        self._lift_ends = now + first_duration
        self._planned_motions[self._last_purpose] = first_duration
        self._planned_motions['coarse'] = planned_duration - first_duration

    def trajectory_done(self, success: bool, message: str, now: float) -> list:
        """Take the end of the streamed trajectory (``success`` False: refused or aborted)."""
        self._trajectory_running = False
        purpose, self._requested = self._requested or self._last_purpose, None
        self._requested_at = None
        if self.phase in (Phase.IDLE, Phase.SAFE_HOLD):
            return []
        if not success:
            if purpose in ('fine', 'recover') and self.phase == Phase.FINE \
                    and self._joint_way_is_clear():
                # the planner found the tip line unfollowable where the check here did not
                # (a joint at its limit by a fraction of a milliradian at the line's end): the
                # joint-space way back goes to the step's own target configuration
                return [self._way_back('recover_joint')]
            return self._abort(f'{self.stage or self.phase.name.lower()} trajectory failed: '
                               f'{message}', now)
        if self.stage == 'lifting' and self._lift_ends is not None:
            # the sweep streamed with the lift has ended before a tick saw the lift end
            self._enter(Phase.COARSE, now, 'arriving')
            self._deadline = now + self.parameters.phase_timeout
            return []
        if self.stage == 'lifting':  # the next tick, with fresh joints, starts the coarse motion
            self.stage = 'lifted'
            self._deadline = now + self.parameters.phase_timeout
            return []
        if self.phase == Phase.COARSE:  # arrived before the region: wait for the error
            self.stage = 'arriving'
            self._settled_since = None
            self._deadline = now + self.parameters.phase_timeout
            return []
        if self.phase == Phase.FINE:  # the coarse motion or a fine line ended: settle
            self.stage = 'settling'
            self._settled_since = None
            self._deadline = now + self.parameters.phase_timeout
            return []
        if self.stage == 'retry_lift':  # above the hole again: settle, check, insert again
            self._fine_lines = 0
            return self._enter_fine(now, correction=False)
        if self.stage in ('descending', 'aligning'):  # at the mouth: settle, check, screw in
            self.stage = 'settling'
            self._settled_since = None
            self._deadline = now + self.parameters.phase_timeout
            return []
        return []

    def tick(self, now: float, theta_roles: np.ndarray, velocities: np.ndarray,
             grippers: dict[str, str]) -> list:
        """Periodic update with the measured joints (role order) and the gripper states."""
        self._theta = np.asarray(theta_roles, dtype=float)
        self._grippers = dict(grippers)
        if not self.busy:
            return []
        self._tip_error_now = self.tip_error()
        if grippers.get(self._step.base_gripper) != 'attached':
            return self._abort(f'the base gripper {self._step.base_gripper} reports '
                               f'{grippers.get(self._step.base_gripper, "nothing")}', now)
        if now > self._deadline:
            return self._abort(f'{self.phase.name.lower()} overran its planned time '
                               f'({self.stage})', now)
        if self._requested is not None:  # planned and streamed by the planner, or not at all
            if self._requested_at is None:
                self._requested_at = now
            elif now - self._requested_at > self.parameters.phase_timeout:
                return self._abort(f'the {self._requested} trajectory did not start within '
                                   f'{self.parameters.phase_timeout:g} s of its request (no '
                                   f'answer from the planner)', now)
        if self.stage == 'descending' and self._trajectory_running \
                and self.mouth_offset() > self.parameters.descent_axis_tolerance:
            return self._left_the_axis(now)
        if self.stage == 'unscrewing':
            state = grippers.get(self._step.moving_gripper, '')
            return self._measure_stance_again(state, now) + self._follow_gripper(now, state)
        if self.stage == 'screwing':
            return self._follow_gripper(now, grippers.get(self._step.moving_gripper, ''))
        if self.stage == 'lifted':
            return self._start_coarse_when_there(now)
        if self.stage == 'lifting' and self._lift_ends is not None and now >= self._lift_ends:
            # the lift is over; the sweep streamed with it goes on, now as the coarse motion
            # (the controllers have been in COARSE mode since the stream began)
            self._enter(Phase.COARSE, now, 'moving')
            return []
        if self.phase == Phase.COARSE and self.tip_error() < self.parameters.coarse_to_fine_region:
            return self._enter_fine(now, correction=False)
        if self.phase == Phase.COARSE and self.stage == 'arriving' \
                and self._settled(now, velocities, self.parameters.settle_time):
            # the coarse motion ended and the arm came to rest outside the region (friction,
            # overshoot): fine motion, with its higher gains and a fine line, takes it there
            return self._enter_fine(now, correction=True)
        if self.phase == Phase.FINE and self.stage == 'settling' and self._may_descend(velocities):
            # the descent need not wait for the tip to come to rest: the insertion settles at
            # the mouth and checks the tip against the axis again before it screws in
            return self._enter_insertion(now)
        if self.stage == 'settling' and self._settled(now, velocities, self._settle_wait()):
            if self.phase == Phase.FINE:
                if self.tip_error() <= self.parameters.insertion_alignment \
                        or self._fine_lines >= MAX_FINE_LINES:
                    return self._enter_insertion(now)
                return self._enter_fine(now, correction=True)  # settled, not aligned: a line
            if self.phase == Phase.INSERTION:
                if self.mouth_offset() > self.parameters.descent_axis_tolerance:
                    return self._left_the_axis(now)  # too far to slide at the mouth's height
                if self.mouth_offset() > self.parameters.insertion_alignment \
                        and self._mouth_lines < MAX_FINE_LINES:
                    return self._align_at_mouth()
                self.stage = 'screwing'
                self._insertion_error = self.mouth_offset()  # the same moment as the plant's
                self._deadline = math.inf
                self._gripper_deadline = now + self._screw_allowance
                self._gripper_answers_due += 1
                # a retry starts from 'jammed': that report is the last attempt's, not this one's
                self._state_before_screwing = grippers.get(self._step.moving_gripper, '')
                return [GripperRequest(self._step.moving_gripper, 'screw_in')]
        return []

    def _may_descend(self, velocities: np.ndarray) -> bool:
        """Return True if the tip is over the hole closely enough to start the descent.

        Either it is within ``descent_region`` of the point above the hole and closing on it
        slowly enough not to get there within ``descent_arrival_time`` (joint 1 coming in
        behind its filter: it arrives on the axis during the descent, 0.3 s; a tip swinging
        through the point is not closing so), or within ``insertion_alignment`` with every
        joint slower than ``settle_velocity`` (at rest there, or nearly).

        The tip's velocity is the measured joint velocities through the Jacobian of eq (1),
        not the change of its error between two ticks: a real-time supervisor's ticks come
        late and then bunched up, and 2 ms apart a tip swinging through at half a metre a
        second looked as if it were closing slowly (one went down 33 mm beside the hole).
        """
        error = self._tip_error_now
        if error <= self.parameters.descent_region and self._closing_slowly(velocities, error):
            return True
        return error <= self.parameters.insertion_alignment \
            and bool(np.all(np.abs(velocities) < self.parameters.settle_velocity))

    def _closing_slowly(self, velocities: np.ndarray, error: float) -> bool:
        """Return True if the tip closes on the point above the hole, and slowly.

        Slowly: slower than ``error / descent_arrival_time`` [m/s]; ``error`` [m] is the tip's
        distance from the point, ``velocities`` [rad/s] the joints' in role order.
        """
        tip = self.kinematics.forward(self._theta)[:3]
        tip_velocity = self.kinematics.jacobian(self._theta)[:3] @ np.asarray(velocities, float)
        towards = float(np.dot(tip_velocity, self._targets.point_above_to - tip))
        speed = float(np.linalg.norm(tip_velocity))
        return towards > 0.0 and speed * self.parameters.descent_arrival_time < error

    def _follow_gripper(self, now: float, state: str) -> list:
        """Move on once the moving gripper reports free (unscrewed) or attached (screwed)."""
        if self.stage == 'unscrewing' and state == 'free':
            return self._unscrewed(now)
        if self.stage == 'screwing' and state != self._state_before_screwing:
            self._state_before_screwing = None  # the gripper has reported on this attempt
        if self.stage == 'screwing' and state == 'attached':
            return self._finish(now)
        if self.stage == 'screwing' and state == 'jammed' and self._state_before_screwing is None:
            return self._jammed('the screw-in jammed', now)
        if now > self._gripper_deadline:
            action = 'unscrew' if self.stage == 'unscrewing' else 'screw in'
            return self._abort(f'gripper {self._step.moving_gripper} did not {action} in time '
                               f'(it reports {state or "nothing"})', now)
        return []

    def hold(self, reason: str, now: float) -> list:
        """Abort to SAFE_HOLD at once (an operator's hold, or a fault reported elsewhere)."""
        return self._abort(reason, now)

    def require_safe_hold(self) -> None:
        """Raise :class:`SequencerError` unless in SAFE_HOLD: only a hold can be resumed."""
        if self.phase != Phase.SAFE_HOLD:
            raise SequencerError(f'not in SAFE_HOLD (phase {self.phase.name})')

    def resume(self, now: float, theta_roles: np.ndarray, grippers: dict[str, str],
               nodes: dict[str, str]) -> list:
        """Leave SAFE_HOLD: back to IDLE, or on with the interrupted step.

        Parameters
        ----------
        theta_roles : ndarray, shape (5,)
            Joint angles now, role order of the base before the hold [rad].
        grippers, nodes : dict of str to str
            Each gripper's state ('free', 'attached', ...) and node ('' when free).

        Raises
        ------
        SequencerError
            Not in SAFE_HOLD; the base gripper is not attached; a gripper is still screwing or
            unscrewing; or the moving gripper is free with no step to complete.
        """
        self.require_safe_hold()
        self._theta = np.asarray(theta_roles, dtype=float)
        self._grippers = dict(grippers)
        busy = sorted(g for g, s in grippers.items() if s in ('screwing', 'unscrewing'))
        if busy:
            raise SequencerError(f'gripper {", ".join(busy)} is still {grippers[busy[0]]}: '
                                 f'resume once it has finished')
        if all(grippers.get(g) == 'attached' for g in ('a', 'b')):
            step = self._step
            if step is not None and nodes.get(step.moving_gripper) == step.to_node \
                    and self.base_gripper != step.moving_gripper:
                self.base_gripper = step.moving_gripper  # the step got as far as screwing in
                # the HOLD under the new base relaxes the chain: no stance before it is over
                self._relaxed_at = now + self.parameters.relaxation_wait
            self.phase, self.stage, self.reason = Phase.IDLE, '', ''
            return [SetControlMode('hold', self.base_gripper)]
        if grippers.get(self.base_gripper) != 'attached':
            raise SequencerError(f'the base gripper {self.base_gripper} is not attached: '
                                 f'nothing can move safely')
        if self._step is None or self._targets is None:
            raise SequencerError('the free gripper has no step to complete: jog it over a node '
                                 'and screw it in')
        tip = self.kinematics.forward(self._theta)[:3]
        in_hole = (tip[2] < 0.5 * self._targets.point_above_from[2] and np.linalg.norm(
            tip[:2] - self._targets.point_above_from[:2]) < self.parameters.coarse_to_fine_region)
        way = None if in_hole else self._way_back_purpose('recover')
        if not in_hole and way is None:
            raise SequencerError(self._no_way_back())
        up = self._straight_up(self._targets.point_above_from) if in_hole else None
        if in_hole and up is None:
            raise SequencerError('no straight lift out of the hole from here: jog the arm')
        self.reason = ''
        self._fine_lines = 0
        self._attempts = 0
        self._step_started = now
        self._durations = {}
        if in_hole:  # still in (or at) the hole it was leaving: out along the axis first
            self._enter(Phase.EXTRACTION, now, 'lifting')
            return [SetControlMode('fine', self._step.base_gripper),
                    self._trajectory('extraction', self._theta, up[0], tip, up[1])]
        self._enter(Phase.FINE, now, 'moving')
        return [SetControlMode('fine', self._step.base_gripper), self._way_back(way)]

    def forget_step(self) -> None:
        """Forget the last (or interrupted) step: an operator has changed the stance.

        After a gripper was screwed in or out by hand, the step's targets no longer describe
        the walker, so :meth:`resume` must not complete it.

        Raises
        ------
        SequencerError
            A step is under way.
        """
        if self.busy:
            raise SequencerError(f'a step is under way (phase {self.phase.name})')
        self._step, self._targets = None, None

    # ------------------------------------------------------------------ internals
    def _start_point(self) -> np.ndarray:
        return self.kinematics.forward(self._targets.start)[:3]

    def _request(self, purpose: str, start: np.ndarray, goal: np.ndarray,
                 start_point: np.ndarray, goal_point: np.ndarray, sweep: float = 0.0
                 ) -> TrajectoryRequest:
        return TrajectoryRequest(purpose, np.array(start, dtype=float),
                                 np.array(goal, dtype=float), np.array(start_point, dtype=float),
                                 np.array(goal_point, dtype=float), float(sweep),
                                 self._step.base_gripper,
                                 'coarse' if purpose == 'coarse' else 'fine')

    def _trajectory(self, purpose: str, start: np.ndarray, goal: np.ndarray,
                    start_point: np.ndarray, goal_point: np.ndarray) -> TrajectoryRequest:
        return self._issue(self._request(purpose, start, goal, start_point, goal_point))

    def _issue(self, request: TrajectoryRequest) -> TrajectoryRequest:
        """Request a motion now: it must start within ``phase_timeout``."""
        self._deadline = math.inf  # set by trajectory_started
        self._requested, self._requested_at = request.purpose, None
        self._last_purpose = request.purpose
        return request

    def _enter(self, phase: Phase, now: float, stage: str) -> None:
        if self.phase not in (Phase.IDLE, Phase.SAFE_HOLD):
            name = self.phase.name.lower()
            self._durations[name] = self._durations.get(name, 0.0) + now - self._phase_started
        self.phase, self.stage, self._phase_started = phase, stage, now
        self._settled_since = None
        self._lift_ends = self._free_since = None
        self._tip_error_now = math.nan  # measured against the new phase's point next tick

    def _start_coarse_when_there(self, now: float) -> list:
        """Enter COARSE once every joint is within ``coarse_start_tolerance`` of its start.

        The extraction line's stream may end before a lagging joint (late efforts, friction)
        has followed it; the planner refuses a coarse motion that starts far from the joints.
        """
        gap = float(np.max(np.abs(self._theta - self._targets.above_from)))
        if gap <= self.parameters.coarse_start_tolerance:
            return self._enter_coarse(now)
        return []

    def _enter_coarse(self, now: float) -> list:
        self._enter(Phase.COARSE, now, 'moving')
        return [SetControlMode('coarse', self._step.base_gripper),
                self._issue(self._coarse_request())]

    def _enter_fine(self, now: float, correction: bool) -> list:
        """Switch the controllers to FINE; with ``correction``, also run a fine line.

        Without a correction the coarse trajectory (if still streaming) runs on to its end, the
        point above the hole; a correction starts from where the joints have settled.
        """
        commands = []
        if self.phase != Phase.FINE:
            self._enter(Phase.FINE, now, 'arriving' if self._trajectory_running else 'settling')
            self._deadline = now + self.parameters.phase_timeout if not self._trajectory_running \
                else self._deadline
            commands.append(SetControlMode('fine', self._step.base_gripper))
            # the descent starts where every fine motion ends: plan it now, stream it when due
            commands.append(PrepareTrajectory(self._insertion_request()))
        if not correction:
            return commands
        self._fine_lines += 1
        self.stage = 'moving'
        purpose = self._way_back_purpose('fine')
        if purpose is None:
            return commands + self._abort(self._no_way_back(), now)
        return commands + [self._way_back(purpose)]

    def _way_back_purpose(self, line: str) -> str | None:
        """How to go from the measured joints to above the target (None: no safe way).

        ``line`` (a Cartesian line: 'fine' or 'recover') where the arm can follow one; else
        ``recover_joint`` (a joint-space line) if the tip stays at least half the approach
        height above the truss along it (:mod:`walker_supervisor.core.way_back`). A line
        starts with the gripper vertical: with the gripper tilted by more than
        ``coarse_start_tolerance`` of joint angle (a fault at the hole's mouth), ``upright``
        first turns it vertical where it is, and the line follows as a correction.
        """
        if line_is_followable(self.kinematics, self._theta, self._targets.point_above_to):
            if float(np.max(np.abs(self._upright() - self._theta))) \
                    > self.parameters.coarse_start_tolerance:
                return 'upright'
            return line
        return 'recover_joint' if self._joint_way_is_clear() else None

    def _upright(self) -> np.ndarray:
        """Joints with the tip where it is and the gripper vertical (a line's first point)."""
        return vertical_configuration(self.kinematics, self.kinematics.forward(self._theta)[:3],
                                      self._theta)

    def _joint_way_is_clear(self) -> bool:
        """Return True if the joint-space line to above the target keeps the tip up."""
        t = self._targets
        floor = t.point_to[2] + 0.5 * (t.point_above_to[2] - t.point_to[2])
        return lowest_tip_height(self.kinematics, self._theta, t.above_to) >= floor

    def _way_back(self, purpose: str) -> TrajectoryRequest:
        tip = self.kinematics.forward(self._theta)[:3]
        if purpose == 'upright':  # the tip stays where it is
            return self._trajectory(purpose, self._theta, self._upright(), tip, tip)
        return self._trajectory(purpose, self._theta, self._targets.above_to, tip,
                                self._targets.point_above_to)

    def _straight_up(self, above: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """Joints and point straight above the measured tip at the height of ``above``.

        A lift out of a hole follows the hole's axis from where the gripper is, which may be
        off the axis by as much as it missed the hole (a jam) or drifted while it was free in
        it; the planner refuses a lift that is not vertical. None when the arm cannot get there.
        """
        tip = self.kinematics.forward(self._theta)[:3]
        point = np.array([tip[0], tip[1], above[2]])
        try:
            return vertical_ik(self.kinematics, point, self._theta), point
        except KinematicsError:
            return None

    def _no_way_back(self) -> str:
        tip = self.kinematics.forward(self._theta)[:3]
        return (f'no safe way back above {self._step.to_node} from here (tip at '
                f'({tip[0]:+.3f}, {tip[1]:+.3f}, {tip[2]:+.3f}) m in the base frame): neither '
                f'a straight tip line nor a joint-space line keeps the arm in its workspace '
                f'and above the truss; jog the arm nearer and resume')

    def mouth_offset(self) -> float:
        """Horizontal distance [m] of the tip (forward kinematics) from the hole's axis."""
        if self._targets is None:
            return math.nan
        tip = self.kinematics.forward(self._theta)[:3]
        return float(np.linalg.norm(tip[:2] - self._targets.point_to[:2]))

    def _align_at_mouth(self) -> list:
        """Run a fine line at the mouth, from where the tip settled onto the hole's axis."""
        self._mouth_lines += 1
        self.stage = 'aligning'
        tip = self.kinematics.forward(self._theta)[:3]
        return [self._trajectory('fine', self._theta, self._targets.at_to, tip,
                                 self._targets.point_to)]

    def _enter_insertion(self, now: float) -> list:
        self._insertion_error = self.tip_error()
        self._mouth_lines = 0
        self._enter(Phase.INSERTION, now, 'descending')
        request = self._insertion_request()
        if float(np.max(np.abs(self._theta - request.start))) > PREPARED_DESCENT_TOLERANCE:
            # not where the step's own motions leave the arm (a resumed step's way back turns
            # the wrist its own way): the same line down the axis, planned from the measured
            # joints' IK branch and tip yaw (the planner checks its first setpoint against them)
            t = self._targets
            request = self._request('insertion', self._theta, t.at_to, t.point_above_to,
                                    t.point_to)
        return [self._issue(request)]

    def _insertion_request(self) -> TrajectoryRequest:
        """Return the descent: straight down the hole's axis from the point above it to its mouth.

        It starts at the configuration above the hole, where the coarse motion and every fine
        line leave the setpoints, so it can be planned on entering FINE and streamed the moment
        FINE ends; for joints farther than :data:`PREPARED_DESCENT_TOLERANCE` from it the same
        line is planned on their IK branch and tip yaw instead.
        """
        t = self._targets
        return self._request('insertion', t.above_to, t.at_to, t.point_above_to, t.point_to)

    def _settle_wait(self) -> float:
        """How long [s] the joints must be still before the tip is judged where it came to rest.

        ``mouth_settle_time`` after the descent, which moves joint 1 hardly at all; else (above
        the hole, or after a line at the mouth, both of which move joint 1, which comes in
        behind its filter slowly enough to look still for a moment) ``settle_time``.
        """
        if self.phase == Phase.INSERTION and self._mouth_lines == 0:
            return self.parameters.mouth_settle_time
        return self.parameters.settle_time

    def _settled(self, now: float, velocities: np.ndarray, duration: float) -> bool:
        """Return True once every joint has been below ``settle_velocity`` for ``duration`` [s]."""
        still = bool(np.all(np.abs(velocities) < self.parameters.settle_velocity))
        if not still:
            self._settled_since = None
            return False
        if self._settled_since is None:
            self._settled_since = now
        return now - self._settled_since >= duration

    @property
    def relaxed_at(self) -> float:
        """[s] When the last relaxation under a new base is over (a next step waits for it)."""
        return self._relaxed_at

    def _finish(self, now: float) -> list:
        """Screwed in: the step ends, HOLD under the new base, whose controllers relax the chain.

        The hole drew the gripper onto its axis while the joints stayed in their friction: the
        links are bent, and the joint angles would misplace the base frame of the next step by
        the bend (about a millimetre at the tip). The controllers' relaxation dither, started
        by this base change, lets the joints slide out of it by :attr:`relaxed_at`; the next
        step measures its stance again after that (:meth:`start`).
        """
        self._relaxed_at = now + self.parameters.relaxation_wait
        self._enter(Phase.IDLE, now, '')
        self._grippers[self._step.moving_gripper] = 'attached'
        self.base_gripper = self._step.moving_gripper
        self.outcome = StepOutcome(True, '', dict(self._durations), now - self._step_started,
                                   self._insertion_error, self._attempts + 1)
        self._outcome_taken = False
        return [SetControlMode('hold', self._step.moving_gripper)]

    def _abort(self, reason: str, now: float) -> list:
        self._remeasure = None
        if self.busy:
            self._enter(Phase.SAFE_HOLD, now, '')
            self.outcome = StepOutcome(False, reason, dict(self._durations),
                                       now - self._step_started, self._insertion_error,
                                       self._attempts)
            self._outcome_taken = False
        self.phase, self.reason = Phase.SAFE_HOLD, reason
        commands = [CancelTrajectory()] if self._trajectory_running \
            or self._requested is not None else []
        self._trajectory_running = False
        self._requested = self._requested_at = None
        return commands + [SetControlMode('hold', self.base_gripper)]
