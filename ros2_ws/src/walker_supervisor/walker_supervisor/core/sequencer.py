"""The step-phase state machine (paper section 2, Figure 2), free of ROS.

A step runs EXTRACTION -> COARSE -> FINE -> INSERTION. :class:`StepSequencer` takes events (a
gripper command answered, a trajectory started or ended, a plan asked ahead back, a periodic
tick with the measured joints and gripper states, a hold, a resume) and returns the commands the
walk must carry out (:mod:`walker_supervisor.core.commands`: set the controllers' mode, screw a
gripper in or out, plan and stream or cancel a trajectory). It never blocks and never talks to
ROS, so every path through a step, faults included, is tested with plain pytest.

Each phase has its module, which says its rules: :mod:`.extraction`, :mod:`.approach` (COARSE
and FINE), :mod:`.insertion`, and :mod:`.recovery` (resume). What they share is the
:class:`~walker_supervisor.core.step_run.StepRun`; the parameters and their rules are in
:mod:`.parameters`. Rules every phase keeps:

* a step starts only with both grippers attached, and the moving gripper is unscrewed only
  while the base gripper is verified attached; a base gripper that reports anything else stops
  the step;
* any failure, a phase that overruns its planned time by ``phase_timeout``, or a trajectory
  that has not started ``phase_timeout`` after its request (the planner gone) ends in SAFE_HOLD:
  trajectories cancelled, controllers holding, grippers untouched (the base stays attached).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from walker_core.gripper_state import GripperState
from walker_core.kinematics import KinematicsError, WalkerKinematics
from walker_supervisor.core import (
    approach, extraction, insertion, looking, recovery, transitions)
from walker_supervisor.core.hole_search import HoleSearch
from walker_supervisor.core.transitions import MAX_FINE_LINES
from walker_supervisor.core.parameters import SupervisorParameters
from walker_supervisor.core.phases import Phase, SequencerError, Stage, StepOutcome
from walker_supervisor.core.progress import PhaseProgress
from walker_supervisor.core.route import PlannedStep
from walker_supervisor.core.sighting import Sighting
from walker_supervisor.core.step_geometry import StepTargets, probe_targets
from walker_supervisor.core.step_run import StepRun

__all__ = ['StepSequencer', 'MAX_FINE_LINES', 'STANCE_MARGIN']

#: [s] A step starts no earlier than this before the unscrewing would end with the relaxation
#: still running, so that the stance is measured after the relaxation, with the chain closed.
STANCE_MARGIN = 0.1


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
    camera : bool
        The grippers carry wrist cameras (``gripper.camera.enabled``): the step looks before
        it descends (:mod:`.looking`).
    frame_interval : float
        [s] Between two frames of one look: half the period of the link's mode whose ringing
        the frames' weighted mean cancels (:mod:`.looking`).
    """

    def __init__(self, parameters: SupervisorParameters, kinematics: WalkerKinematics,
                 base_gripper: str = 'a', screw_time: float = 0.5, camera: bool = False,
                 frame_interval: float = 0.0) -> None:
        self._run = StepRun(parameters, kinematics, base_gripper, screw_time, camera,
                            frame_interval)
        self._progress = PhaseProgress()

    # ------------------------------------------------------------------ queries
    @property
    def parameters(self) -> SupervisorParameters:
        """The switching regions and fault limits in force (may be set anew)."""
        return self._run.parameters

    @parameters.setter
    def parameters(self, parameters: SupervisorParameters) -> None:
        self._run.parameters = parameters

    @property
    def kinematics(self) -> WalkerKinematics:
        """The kinematics of the tip."""
        return self._run.kinematics

    @property
    def base_gripper(self) -> str:
        """The base now ('a' or 'b'); an operator's command may set it between steps."""
        return self._run.base_gripper

    @base_gripper.setter
    def base_gripper(self, gripper: str) -> None:
        self._run.base_gripper = gripper

    @property
    def phase(self) -> Phase:
        """The phase now."""
        return self._run.phase

    @property
    def stage(self) -> Stage:
        """Where the step is within its phase."""
        return self._run.stage

    @property
    def reason(self) -> str:
        """Why the phase was entered (the fault behind SAFE_HOLD; '' otherwise)."""
        return self._run.reason

    @property
    def outcome(self) -> StepOutcome | None:
        """How the last step ended (None while it runs)."""
        return self._run.outcome

    @property
    def busy(self) -> bool:
        """True while a step is under way."""
        return self._run.busy

    @property
    def step(self) -> PlannedStep | None:
        """The step under way (or the last one)."""
        return self._run.step

    @property
    def targets(self) -> StepTargets | None:
        """The targets of the step under way (or of the last one)."""
        return self._run.targets

    @property
    def relaxed_at(self) -> float:
        """[s] When the last relaxation under a new base is over (a next step waits for it)."""
        return self._run.relaxed_at

    @property
    def awaiting_plan(self) -> bool:
        """True while the freed gripper's lift waits for the sweep's plan (``sweep_lead``).

        False as soon as the plan is back (:meth:`motion_planned`) or will not come
        (:meth:`motion_not_planned`): the lift then starts at the next tick. The node holds
        the sim-time clock while this is True, so it must not stay True on a frozen clock.
        """
        return extraction.awaiting_plan(self._run)

    def take_felt_faces(self) -> list[np.ndarray]:
        """Return, once, the joints [rad] of the jams that rested on the node's face.

        Role order of the step's base; each a jam since the last call whose descent had felt
        the face (the gripper resting on it).
        """
        felt, self._run.felt_faces = self._run.felt_faces, []
        return felt

    def move_mouth(self, height: float) -> None:
        """Take the target mouth's height [m] (base frame) felt since the step began.

        The search's next probes descend there; the probe the gripper is lifting back to after
        a jam (the map takes the height that jam felt) moves there at once, before FINE brings
        the tip over it. Without a search nothing changes: a retry is made where the last was.
        """
        run = self._run
        if run.search is None or run.targets is None:
            return
        estimate = run.estimate if run.estimate is not None else run.targets
        run.height_shift = float(height) - float(estimate.point_to[2])
        looking.height_felt(run)
        if run.stage == Stage.RETRY_LIFT and run.estimate is not None:
            try:
                run.targets = probe_targets(run.kinematics, run.estimate, run.search.offset,
                                            run.height_shift)
            except KinematicsError:
                pass  # out of reach there: the probe keeps its height

    @property
    def looking(self) -> bool:
        """True while the step means to look again before its descent."""
        return looking.wanted(self._run)

    @property
    def look_frames_taken(self) -> int:
        """Frames of the look under way (or of the last look) taken so far."""
        return len(self._run.looks.frames)

    @property
    def last_look(self) -> Sighting | None:
        """What the last look's frames showed together (None before a look has ended)."""
        return self._run.looks.last

    def take_look_done(self) -> list[float] | None:
        """Return, once, the frames' weights of the look that ended since the last call."""
        done, self._run.looks.done = self._run.looks.done, None
        return done

    def take_located(self) -> tuple[np.ndarray, np.ndarray] | None:
        """Return, once, the hole the step's looks located since the last call (or None).

        Its mouth's position [m] and covariance [m^2] in the base frame.
        """
        located, self._run.looks.located = self._run.looks.located, None
        return located

    def frame_seen(self, sighting: Sighting, height: float, height_std: float,
                   now: float) -> list:
        """Take what the frame asked for by a :class:`LookRequest` showed (:mod:`.looking`).

        ``height`` [m] (base frame) and ``height_std`` [m]: the target's mouth height as the
        map knew it before any look.

        Raises
        ------
        SequencerError
            No look is under way.
        """
        run = self._run
        if not (run.busy and run.stage == Stage.LOOKING):
            raise SequencerError(f'no look is under way (phase {run.phase.name}, stage '
                                 f'{run.stage or "none"})')
        return looking.seen(run, now, sighting, height, height_std)

    def take_outcome(self) -> StepOutcome | None:
        """Return the outcome of the step that ended since the last call, once; else None.

        A step ends once, however it was started and resumed: taken by the walk it belongs to,
        or, for a step completed by :meth:`resume` after its walk was aborted, by whoever asks
        next, so that it is never taken again as the first step of another walk.
        """
        run = self._run
        if run.outcome_taken or run.outcome is None:
            return None
        run.outcome_taken = True
        return run.outcome

    def tip_error(self) -> float:
        """Distance [m] of the tip (forward kinematics) from the current phase's target point."""
        return self._run.tip_error()

    def mouth_offset(self) -> float:
        """Horizontal distance [m] of the tip (forward kinematics) from the hole's axis."""
        return self._run.mouth_offset()

    def phase_progress(self, now: float) -> float:
        """Fraction of the current phase done, in [0, 1] (:class:`.progress.PhaseProgress`)."""
        return self._progress.of(self._run, now)

    def can_start(self, now: float) -> bool:
        """Return True if a step started now measures its stance after the last relaxation.

        The stance is measured again at the end of the relaxation, during the unscrewing
        (``screw_time``), so a step may start up to that long (less :data:`STANCE_MARGIN`)
        before the relaxation is over.
        """
        run = self._run
        return now >= run.relaxed_at - max(0.0, run.screw_time - STANCE_MARGIN)

    # ------------------------------------------------------------------ events
    def start(self, step: PlannedStep, targets: StepTargets, now: float,
              grippers: dict[str, str],
              remeasure: Callable[[np.ndarray], StepTargets] | None = None,
              search: HoleSearch | None = None) -> list:
        """Begin a step: both grippers must be attached, and no step under way.

        The controllers hold while the moving gripper unscrews (a relaxation under way runs
        on). The extraction and coarse motions are planned ahead
        (:class:`~walker_supervisor.core.commands.PrepareTrajectory`) as soon as the targets
        are final: at once, or, while a relaxation is under way, when it is over.

        Parameters
        ----------
        targets : StepTargets
            The targets from the stance now.
        remeasure : callable, optional
            ``remeasure(theta_roles) -> StepTargets``: the targets measured again from joint
            angles [rad] (role order), both grippers attached. Called once, at the first tick
            after the relaxation while the gripper is still unscrewing; a
            :class:`~walker_core.kinematics.KinematicsError` keeps ``targets`` (with a
            :class:`~walker_supervisor.core.commands.Notice`). Without it, or with no
            relaxation under way, ``targets`` stand.
        search : HoleSearch, optional
            The probes to try, one after each jam, around the target
            (:mod:`~walker_supervisor.core.hole_search`); without it a jam is retried at the
            same point up to ``max_insertion_attempts`` times.

        Raises
        ------
        SequencerError
            A step is already under way, or a gripper is not attached.
        """
        return extraction.start(self._run, step, targets, now, grippers, remeasure, search)

    def adopt(self, step: PlannedStep, targets: StepTargets, reason: str,
              search: HoleSearch | None = None) -> None:
        """Take over an interrupted step, in SAFE_HOLD, so that :meth:`resume` completes it.

        Used by a supervisor restarted in the middle of a step, with the search a jam of its
        screw-in starts (as :meth:`start`'s); raises :class:`SequencerError` if a step is under
        way here.
        """
        run = self._run
        if run.busy:
            raise SequencerError(f'a step is already under way (phase {run.phase.name})')
        run.step, run.targets = step, targets
        run.search, run.estimate, run.height_shift = search, None, 0.0
        run.search_over = ''
        run.base_gripper = step.base_gripper
        run.phase, run.stage, run.reason = Phase.SAFE_HOLD, Stage.NONE, reason

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
        run = self._run
        answered = run.gripper.answers_due > 0
        run.gripper.answers_due = max(0, run.gripper.answers_due - 1)
        if run.phase == Phase.SAFE_HOLD:
            return []
        if run.stage not in (Stage.UNSCREWING, Stage.SCREWING):
            if answered:
                return []
            raise SequencerError(f'unexpected gripper result in phase {run.phase.name} '
                                 f'({run.stage or "no stage"})')
        if success:
            run.gripper.deadline = now + run.gripper.allowance
            return []
        if run.stage == Stage.UNSCREWING:
            return run.abort(f'unscrewing gripper {run.step.moving_gripper} failed: {message}',
                             now)
        return insertion.jammed(run, message, now)

    def motion_planned(self, purpose: str, planned_duration: float) -> None:
        """Note how long a motion asked for ahead will take [s].

        Only the phase progress uses it (:meth:`phase_progress`), before the motion streams,
        and the lift, which streams with the sweep (``sweep_lead``) only once the sweep's plan
        is back.
        """
        self._run.motions.planned[purpose] = float(planned_duration)
        self._run.motions.planned_ahead.add(purpose)

    def motion_not_planned(self, purpose: str) -> None:
        """Note that a motion asked for ahead will not be planned (refused, or not asked)."""
        self._run.motions.asked_ahead.discard(purpose)

    def trajectory_started(self, planned_duration: float, now: float,
                           first_duration: float | None = None) -> None:
        """Note that the requested trajectory is streaming and should take this long [s].

        ``first_duration`` [s]: for a request with a motion streamed with it (``then``), when
        the first motion ends, from now: the lift, after which the sweep goes on as COARSE.
        """
        run, motions = self._run, self._run.motions
        motions.running = True
        motions.requested = motions.requested_at = None
        run.deadline = now + planned_duration + run.parameters.phase_timeout
        if first_duration is None:
            motions.planned[motions.last_purpose] = planned_duration
            return
        motions.lift_ends = now + first_duration
        motions.planned[motions.last_purpose] = first_duration
        motions.planned['coarse'] = planned_duration - first_duration

    def trajectory_done(self, success: bool, message: str, now: float) -> list:
        """Take the end of the streamed trajectory (``success`` False: refused or aborted)."""
        run, motions = self._run, self._run.motions
        motions.running = False
        purpose, motions.requested = motions.requested or motions.last_purpose, None
        motions.requested_at = None
        if not run.busy:
            return []
        if not success:
            if purpose in ('fine', 'recover') and run.phase == Phase.FINE \
                    and recovery.joint_way_is_clear(run):
                # the planner found the tip line unfollowable where the check here did not (a
                # joint at its limit by a fraction of a milliradian at the line's end): the
                # joint-space way back goes to the step's own target configuration
                return [recovery.way_back(run, 'recover_joint')]
            return run.abort(f'{run.stage or run.phase.name.lower()} trajectory failed: '
                             f'{message}', now)
        if run.stage == Stage.LIFTING:
            return extraction.lift_ended(run, now)
        if run.phase == Phase.COARSE:  # arrived before the region: wait for the error
            return run.wait_again(now, Stage.ARRIVING)
        if run.phase == Phase.FINE:  # the coarse motion or a fine line ended: settle
            return run.wait_again(now, Stage.SETTLING)
        if run.stage == Stage.RETRY_LIFT:  # above the hole again: settle, check, insert again
            run.tries.fine_lines = 0
            return transitions.enter_fine(run, now, correction=False)
        if run.stage in (Stage.DESCENDING, Stage.ALIGNING):  # at the mouth: settle, screw in
            return run.wait_again(now, Stage.SETTLING)
        return []

    def tick(self, now: float, theta_roles: np.ndarray, velocities: np.ndarray,
             grippers: dict[str, str]) -> list:
        """Periodic update with the measured joints (role order) and the gripper states."""
        run = self._run
        run.theta = np.asarray(theta_roles, dtype=float)
        run.grippers = dict(grippers)
        if not run.busy:
            return []
        run.tip_error_now = run.tip_error()
        stopped = self._fault(now, grippers)
        if stopped:
            return stopped
        if run.stage == Stage.DESCENDING and run.motions.running \
                and run.mouth_offset() > run.parameters.descent_axis_tolerance:
            return insertion.left_the_axis(run, now)
        if run.stage == Stage.DESCENDING and run.motions.running:
            return insertion.feel_the_face(run, now)
        moving = grippers.get(run.step.moving_gripper, '')
        if run.stage == Stage.UNSCREWING:
            return extraction.follow_unscrewing(run, now, moving)
        if run.stage == Stage.SCREWING:
            return insertion.follow_screwing(run, now, moving)
        if run.stage == Stage.LIFTED:
            return extraction.coarse_when_there(run, now)
        if run.stage == Stage.LIFTING and run.motions.lift_ends is not None \
                and now >= run.motions.lift_ends:
            # the lift is over; the sweep streamed with it goes on, now as the coarse motion
            # (the controllers have been in COARSE mode since the stream began)
            run.enter(Phase.COARSE, now, Stage.MOVING)
            return []
        if run.phase == Phase.COARSE:
            return approach.coarse_tick(run, now, velocities)
        if run.phase == Phase.FINE and run.stage in (Stage.SETTLING, Stage.LOOKING):
            return approach.fine_settling(run, now, velocities)
        if run.phase == Phase.INSERTION and run.stage == Stage.SETTLING:
            return insertion.at_mouth(run, now, velocities, grippers)
        return []

    def _fault(self, now: float, grippers: dict[str, str]) -> list:
        """Stop the step for a base that lets go, a phase overrun, or a motion never started."""
        run = self._run
        base = run.step.base_gripper
        if grippers.get(base) != GripperState.ATTACHED:
            return run.abort(f'the base gripper {base} reports {grippers.get(base, "nothing")}',
                             now)
        if now > run.deadline:
            return run.abort(f'{run.phase.name.lower()} overran its planned time ({run.stage})',
                             now)
        motions = run.motions
        if motions.requested is not None:  # planned and streamed by the planner, or not at all
            if motions.requested_at is None:
                motions.requested_at = now
            elif now - motions.requested_at > run.parameters.phase_timeout:
                return run.abort(f'the {motions.requested} trajectory did not start within '
                                 f'{run.parameters.phase_timeout:g} s of its request (no answer '
                                 f'from the planner)', now)
        return []

    def hold(self, reason: str, now: float) -> list:
        """Abort to SAFE_HOLD at once (an operator's hold, or a fault reported elsewhere)."""
        return self._run.abort(reason, now)

    def require_safe_hold(self) -> None:
        """Raise :class:`SequencerError` unless in SAFE_HOLD: only a hold can be resumed."""
        if self._run.phase != Phase.SAFE_HOLD:
            raise SequencerError(f'not in SAFE_HOLD (phase {self._run.phase.name})')

    def resume(self, now: float, theta_roles: np.ndarray, grippers: dict[str, str],
               nodes: dict[str, str]) -> list:
        """Leave SAFE_HOLD: back to IDLE, or on with the interrupted step (:mod:`.recovery`).

        Parameters
        ----------
        theta_roles : ndarray, shape (5,)
            Joint angles now, role order of the base before the hold [rad].
        grippers, nodes : dict of str to str
            Each gripper's state (a ``GripperState``) and node ('' when free).

        Raises
        ------
        SequencerError
            Not in SAFE_HOLD; the base gripper is not attached; a gripper is still screwing or
            unscrewing; the moving gripper is free with no step to complete, or no safe way
            back from where the arm is.
        """
        return recovery.resume(self._run, now, theta_roles, grippers, nodes)

    def forget_step(self) -> None:
        """Forget the last (or interrupted) step: an operator has changed the stance.

        After a gripper was screwed in or out by hand, the step's targets no longer describe
        the walker, so :meth:`resume` must not complete it.

        Raises
        ------
        SequencerError
            A step is under way.
        """
        run = self._run
        if run.busy:
            raise SequencerError(f'a step is under way (phase {run.phase.name})')
        run.step, run.targets = None, None

