"""The step under way, as its phases share it: targets, joints, phase and stage, motions.

:class:`StepRun` holds what every phase of :class:`~walker_supervisor.core.sequencer.
StepSequencer` reads and writes, with the moves they all make: entering a phase, asking for a
motion, judging the joints still, stopping in safe hold. The phases themselves are in
:mod:`.extraction`, :mod:`.approach` (COARSE and FINE), :mod:`.insertion` and
:mod:`.recovery` (resume); no module here talks to ROS.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np

from walker_core.kinematics import KinematicsError, WalkerKinematics
from walker_supervisor.core.hole_search import HoleSearch
from walker_supervisor.core.commands import CancelTrajectory, SetControlMode, TrajectoryRequest
from walker_supervisor.core.descent_contact import DescentContact
from walker_supervisor.core.parameters import SupervisorParameters
from walker_supervisor.core.phases import Phase, Stage, StepOutcome
from walker_supervisor.core.route import PlannedStep
from walker_supervisor.core.sighting import Sighting
from walker_supervisor.core.step_geometry import StepTargets
from walker_supervisor.core.way_back import vertical_ik

__all__ = ['StepRun', 'Motions', 'GripperWatch', 'Tries', 'Looks']


@dataclasses.dataclass
class Motions:
    """The step's trajectories as the sequencer knows them.

    Attributes
    ----------
    running : bool
        A trajectory streams.
    requested : str or None
        Purpose of a trajectory requested and not started (planned and streamed by the
        planner, or not at all).
    requested_at : float or None
        [s] the first tick after that request.
    last_purpose : str
        Purpose of the last trajectory requested.
    planned : dict of str to float
        [s] the last planned duration of each purpose (the phase progress).
    planned_ahead, asked_ahead : set of str
        Motions asked ahead for this step whose plans are back; whose plans may yet come.
    lift_ends : float or None
        [s] when the lift of a lift streamed with its sweep ends (None: no such stream).
    """

    running: bool = False
    requested: str | None = None
    requested_at: float | None = None
    last_purpose: str = ''
    planned: dict[str, float] = dataclasses.field(default_factory=dict)
    planned_ahead: set[str] = dataclasses.field(default_factory=set)
    asked_ahead: set[str] = dataclasses.field(default_factory=set)
    lift_ends: float | None = None


@dataclasses.dataclass
class GripperWatch:
    """The moving gripper's commands and reports.

    Attributes
    ----------
    allowance : float
        [s] how long a gripper may take to report free or attached after accepting.
    deadline : float
        [s] by when it must (inf: no command under way).
    answers_due : int
        Commands sent and not answered yet.
    state_before_screwing : str or None
        Its reported state when the current screw-in was requested, until it reports another
        (None: what it reports is about this attempt).
    free_since : float or None
        [s] it reported free and the lift has not started.
    """

    allowance: float
    deadline: float = math.inf
    answers_due: int = 0
    state_before_screwing: str | None = None
    free_since: float | None = None


@dataclasses.dataclass
class Tries:
    """What the step tried: insertions, fine lines (above the hole and at its mouth)."""

    insertions: int = 0
    fine_lines: int = 0
    mouth_lines: int = 0
    #: [m] the tip's distance from the hole's axis when the last line at the mouth began
    mouth_offset_lined: float = math.inf
    #: [m] the tip's distance from its target when insertion started (then from the axis at
    #: the screw-in); NaN before
    insertion_error: float = math.nan
    #: the descent under way feeling for the node's face (None: none, or judged)
    contact: DescentContact | None = None


@dataclasses.dataclass
class Looks:
    """The looks of a step's approach.

    Attributes
    ----------
    due : bool
        A look is wanted before the next descent.
    taken : int
        Looks asked for since the last change of what is known of the hole.
    asked_at : float or None
        [s] When the look under way was asked for (None: none under way).
    height_shift : float
        [m] The probes' height shift the last look assumed (``run.height_shift``).
    sightings : list of Sighting
        The step's looks that saw the hole.
    located : tuple of ndarray, or None
        The hole located from them (position [m], covariance [m^2], base frame), until the walk
        runner's map takes it.
    raised : bool
        The point above the hole has gone up for a look along a steeper line of sight.
    arriving : bool
        The look under way was taken on arrival, the arm not yet at rest.
    frames : list of Sighting
        What each frame of the look under way showed, in order.
    asked : int
        Frames of the look under way asked for.
    done : list of float or None
        The weights of the frames of the look that ended since the walk runner last asked
        (None: none ended).
    last : Sighting or None
        What the last look's frames showed together.
    """

    due: bool = False
    taken: int = 0
    asked_at: float | None = None
    height_shift: float = 0.0
    sightings: list[Sighting] = dataclasses.field(default_factory=list)
    located: tuple[np.ndarray, np.ndarray] | None = None
    raised: bool = False
    arriving: bool = False
    frames: list[Sighting] = dataclasses.field(default_factory=list)
    asked: int = 0
    done: list[float] | None = None
    last: Sighting | None = None


class StepRun:
    """The state of the step under way (or of the last one) and the moves every phase makes.

    Parameters
    ----------
    parameters : SupervisorParameters
    kinematics : WalkerKinematics
    base_gripper : str
    screw_time : float
        [s] a screw-in or unscrew (``gripper.screw_time``).
    camera : bool
        The grippers carry wrist cameras (``gripper.camera.enabled``).
    frame_interval : float
        [s] Between two frames of one look (:mod:`.looking`).
    """

    def __init__(self, parameters: SupervisorParameters, kinematics: WalkerKinematics,
                 base_gripper: str, screw_time: float, camera: bool = False,
                 frame_interval: float = 0.0) -> None:
        self.parameters = parameters
        self.kinematics = kinematics
        self.base_gripper = base_gripper
        self.screw_time = screw_time
        self.phase, self.stage, self.reason = Phase.IDLE, Stage.NONE, ''
        self.outcome: StepOutcome | None = None
        self.outcome_taken = True
        self.step: PlannedStep | None = None
        self.targets: StepTargets | None = None
        self.theta = np.zeros(5)  # [rad] measured joints, role order
        self.grippers: dict[str, str] = {}
        self.phase_started = self.step_started = 0.0  # [s]
        self.deadline = math.inf  # [s] the phase must have moved on by then
        self.durations: dict[str, float] = {}  # [s] time in each phase
        self.settled_since: float | None = None  # [s] the joints have been still since
        self.relaxed_at = -math.inf  # [s] when the last relaxation under a new base is over
        # measures the targets again from joint angles (role order) once the stance is relaxed
        # (None: the targets the step started with are final)
        self.remeasure: Callable[[np.ndarray], StepTargets] | None = None
        self.tip_error_now = math.nan  # [m] tip_error() at this tick (nan: none in the phase)
        self.motions = Motions()
        self.gripper = GripperWatch(screw_time + parameters.phase_timeout)
        self.tries = Tries()
        # the search on a jam (None: a jam is retried at the same point); ``estimate`` the
        # targets at the map's estimate, which the probes are offsets from
        self.search: HoleSearch | None = None
        self.estimate: StepTargets | None = None
        # why the search ended without the hole ('' while it has not): resume does not try
        # the same places again
        self.search_over = ''
        # joints [rad] (role order) of each jam with the gripper resting on the node's face,
        # until the map takes them (StepSequencer.take_felt_faces)
        self.felt_faces: list[np.ndarray] = []
        # [m] how far the probes' mouth is moved in height from the estimate's: the height the
        # map took from a jam on the node's face (StepSequencer.move_mouth)
        self.height_shift = 0.0
        # the grippers carry wrist cameras; the looks of the step's approach (:mod:`.looking`)
        self.camera = camera
        self.frame_interval = float(frame_interval)
        self.looks = Looks()

    # ------------------------------------------------------------------ where the tip is
    @property
    def busy(self) -> bool:
        """True while a step is under way."""
        return self.phase not in (Phase.IDLE, Phase.SAFE_HOLD)

    def tip(self) -> np.ndarray:
        """Return the tip [m] in the base frame (forward kinematics of the measured joints)."""
        return self.kinematics.forward(self.theta)[:3]

    def tip_error(self) -> float:
        """Distance [m] of the tip from the current phase's target point."""
        if self.targets is None:
            return math.nan
        target = {Phase.EXTRACTION: self.targets.point_above_from,
                  Phase.INSERTION: self.targets.point_to}.get(self.phase,
                                                              self.targets.point_above_to)
        return float(np.linalg.norm(self.tip() - target))

    def mouth_offset(self) -> float:
        """Horizontal distance [m] of the tip from the target hole's axis."""
        if self.targets is None:
            return math.nan
        return float(np.linalg.norm(self.tip()[:2] - self.targets.point_to[:2]))

    def straight_up(self, above: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """Return the joints and point straight above the tip at the height of ``above``.

        A lift out of a hole follows the hole's axis from where the gripper is, which may be
        off the axis by as much as it missed the hole (a jam) or drifted while it was free in
        it; the planner refuses a lift that is not vertical. None when the arm cannot get there.
        """
        tip = self.tip()
        point = np.array([tip[0], tip[1], above[2]])
        try:
            return vertical_ik(self.kinematics, point, self.theta), point
        except KinematicsError:
            return None

    # ------------------------------------------------------------------ moves
    def enter(self, phase: Phase, now: float, stage: Stage) -> None:
        """Enter ``phase`` at ``stage``; the time in the phase left counts in the durations."""
        if self.busy:
            name = self.phase.name.lower()
            self.durations[name] = self.durations.get(name, 0.0) + now - self.phase_started
        self.phase, self.stage, self.phase_started = phase, stage, now
        self.settled_since = None
        self.motions.lift_ends = self.gripper.free_since = None
        self.tip_error_now = math.nan  # measured against the new phase's point next tick

    def settled(self, now: float, velocities: np.ndarray, duration: float) -> bool:
        """Return True once every joint has been below ``settle_velocity`` for ``duration`` [s]."""
        still = bool(np.all(np.abs(velocities) < self.parameters.settle_velocity))
        if not still:
            self.settled_since = None
            return False
        if self.settled_since is None:
            self.settled_since = now
        return now - self.settled_since >= duration

    def wait_again(self, now: float, stage: Stage) -> list:
        """Wait at ``stage`` (a motion ended) for at most ``phase_timeout``."""
        self.stage = stage
        self.settled_since = None
        self.deadline = now + self.parameters.phase_timeout
        return []

    def request(self, purpose: str, start: np.ndarray, goal: np.ndarray,
                start_point: np.ndarray, goal_point: np.ndarray, sweep: float = 0.0
                ) -> TrajectoryRequest:
        """Return a motion of the step (not asked for yet): COARSE mode for the sweep."""
        return TrajectoryRequest(purpose, np.array(start, dtype=float),
                                 np.array(goal, dtype=float), np.array(start_point, dtype=float),
                                 np.array(goal_point, dtype=float), float(sweep),
                                 self.step.base_gripper,
                                 'coarse' if purpose == 'coarse' else 'fine')

    def issue(self, request: TrajectoryRequest) -> TrajectoryRequest:
        """Ask for a motion now: it must start within ``phase_timeout``."""
        self.deadline = math.inf  # set when it starts
        motions = self.motions
        motions.requested, motions.requested_at = request.purpose, None
        motions.last_purpose = request.purpose
        return request

    def trajectory(self, purpose: str, start: np.ndarray, goal: np.ndarray,
                   start_point: np.ndarray, goal_point: np.ndarray) -> TrajectoryRequest:
        """Ask for a motion of the step now (:meth:`request`, :meth:`issue`)."""
        return self.issue(self.request(purpose, start, goal, start_point, goal_point))

    def abort(self, reason: str, now: float) -> list:
        """Stop in SAFE_HOLD: trajectories cancelled, controllers hold, grippers unchanged."""
        self.remeasure = None
        if self.busy:
            self.enter(Phase.SAFE_HOLD, now, Stage.NONE)
            self.outcome = StepOutcome(False, reason, dict(self.durations),
                                       now - self.step_started, self.tries.insertion_error,
                                       self.tries.insertions,
                                       self.search.probes_moved if self.search else 0)
            self.outcome_taken = False
        self.phase, self.reason = Phase.SAFE_HOLD, reason
        motions = self.motions
        commands = [CancelTrajectory()] if motions.running or motions.requested is not None \
            else []
        motions.running = False
        motions.requested = motions.requested_at = None
        return commands + [SetControlMode('hold', self.base_gripper)]
