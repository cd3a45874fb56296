"""The walk runner: every decision of the step-phase supervisor, free of ROS.

:class:`WalkRunner` is to the supervisor node what control_toolbox's ``Pid`` is to ``PidROS``:
it takes events in and gives commands out (:mod:`walker_supervisor.core.commands`), keeps no
clock, no thread and no future, and never blocks; the same inputs give the same commands. It
owns the walk (goals, their route and progress, each step's outcome and figures, cancel), the
step under way (:class:`~walker_supervisor.core.sequencer.StepSequencer`), taking up a step a
restarted supervisor finds on record, hold and resume, the health of its sources and the release
interlock, the planner requests (:class:`~walker_supervisor.core.motion_requests.MotionRequests`:
plans asked ahead, retries over a new client, giving up) and what it reports (phase, feedback,
step records, goal results, diagnostics).

Times are floats in seconds: ``now`` on the graph's clock (simulated time in sim time; what the
step's phases, deadlines and the walk run on), ``steady`` on a monotonic clock (what the health
watchdog and the planner-request waits run on; it runs while a simulated clock stands still).
A loop without a wall clock passes the same time for both. Joint arrays are in physical order
(``walker_core.joint_roles.PHYSICAL_JOINT_NAMES``), radians and rad/s.

Events in (those marked * return the commands to carry out, in order)
--------------------------------------------------------------------
Measurements: :meth:`joint_states`, :meth:`gripper_states` *, :meth:`tip_pose`,
:meth:`controller_states` *, :meth:`latched_mode` (the base a restarted supervisor takes back).
Answers: :meth:`request_sent`, :meth:`request_failed` *, :meth:`plan_answered` *,
:meth:`follow_accepted` *, :meth:`follow_done` *, :meth:`gripper_answered` *,
:meth:`frame_seen` *.
Operator: :meth:`start_goal` * (raises :class:`~walker_supervisor.core.goals.GoalRefusedError`),
:meth:`cancel_goal`, :meth:`hold` *, :meth:`resume` (the answer, and commands; raises
:class:`~walker_supervisor.core.phases.SequencerError`); teleoperation's own:
:meth:`teleop_situation`, :meth:`release_refusal`, :meth:`command_mode` *, :meth:`use_base`,
:meth:`stance_changed` *, :attr:`teleop_operation`.
Time: :meth:`tick` * (the decision), :meth:`watch` * (the watchdog).

A loop's period
---------------
1. The measurements of the period: :meth:`joint_states` (also when a message had no usable
   positions: the plant was heard), :meth:`gripper_states`, :meth:`tip_pose` for each pose,
   :meth:`controller_states` with each controller's newest report.
2. The answers that came in since the last period, in the order they came.
3. Every :data:`TICK_PERIOD` of ``now`` (and at once after a :class:`DecideNow`): :meth:`tick`.
4. Every :data:`WATCH_PERIOD` of ``steady``: :meth:`watch`.

Carry out each call's commands before the next call: :class:`SetControlMode` to the
controllers; :class:`GripperRequest` to the plant (answer :meth:`gripper_answered` once it has
accepted or refused; the gripper states then tell when it is done); :class:`PlanMotion` to the
planner (``call`` is the planner core's request; answer :meth:`plan_answered` with its ticket);
:class:`FollowMotion` (answer :meth:`follow_accepted`, then :meth:`follow_done` when the stream
ends); :class:`LookRequest` to the moving gripper's wrist camera (answer :meth:`frame_seen`
with the frame once it is ready); :class:`CancelFollow` (stop that stream); the records
(:class:`PhaseRecord`, :class:`StepRecord`, :class:`HoleSighted`, :class:`Feedback`,
:class:`GoalEnded`) to publish; :class:`Notice` to log.
A shell without ROS clients or files may ignore :class:`RenewPlannerClient`,
:class:`RenewModePublisher`, :class:`StopOrphanStream`, :class:`RecordStep`,
:class:`ForgetRecordedStep` and :class:`DecideNow`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping

import numpy as np

from walker_core.gripper_state import GripperState
from walker_core.joint_roles import PHYSICAL_JOINT_NAMES, physical_to_roles
from walker_core.kinematics import KinematicsError, WalkerKinematics
from walker_core.truss import Truss
from walker_supervisor.core.adoption import AdoptionRefusedError, RecordedStep, adopt_step
from walker_supervisor.core.commands import (
    CancelTrajectory, DecideNow, ForgetRecordedStep, GripperRequest, HoleSighted, Notice,
    PrepareTrajectory, RecordStep, SetControlMode, StopJog, StopOrphanStream, TrajectoryRequest)
from walker_supervisor.core.controller_watch import ControllerReport, ControllerWatch
from walker_supervisor.core.goals import (
    GOALS, GoalRefusedError, check_target, goal_route, stance_now)
from walker_supervisor.core.health import (
    HealthMonitor, Level, SourceStatus, reason_naming_silent_sources)
from walker_supervisor.core.map_planning import MapPlanning
from walker_supervisor.core.motion_requests import (
    MotionEnded, MotionPlanned, MotionRequests, MotionStarted, PlannedAhead)
from walker_supervisor.core.phases import Phase, SequencerError, Stage, StepOutcome
from walker_supervisor.core.prepared_motions import PlanAnswer
from walker_supervisor.core.reports import (
    PhaseAnnouncer, StepFigures, goal_ended, goal_feedback)
from walker_supervisor.core.route import PlannedStep
from walker_supervisor.core.sighting import (
    HoleSighter, JointHistory, LookResult, look_result)
from walker_supervisor.core.parameters import SupervisorParameters
from walker_supervisor.core.sequencer import StepSequencer
from walker_supervisor.core.step_geometry import StepTargets
from walker_supervisor.core.teleop import Situation, busy_reason
from walker_supervisor.core.truss_map import SurveyFileError, TrussMap
from walker_supervisor.core.walk import Walk

__all__ = ['WalkRunner', 'Measurements', 'ControllerReport', 'PlanAnswer', 'TICK_PERIOD',
           'WATCH_PERIOD', 'FEEDBACK_PERIOD', 'ANSWER_WAIT', 'ANSWER_GIVE_UP',
           'PLANT_JOINT_STATES', 'PLANT_GRIPPER_STATES']

#: [s] of ``now``: the decision period. The graph also decides at once when a gripper's state
#: changes and when a motion ends (:class:`DecideNow`): about 50 ms a step in sim time.
TICK_PERIOD = 0.02
WATCH_PERIOD = 0.1  # [s] of ``steady``: the watchdog's period
FEEDBACK_PERIOD = 0.1  # [s] of ``now``: goal feedback at most this often
#: [s] of ``steady``: a planner request unanswered this long is sent again over a new client;
#: unanswered ANSWER_GIVE_UP after it was first sent, its motion fails and the step holds
ANSWER_WAIT = 4.0
ANSWER_GIVE_UP = 20.0
# The sources the watchdog names after the plant's streams (a controller's: 'controller <joint>')
PLANT_JOINT_STATES = 'plant joint states'
PLANT_GRIPPER_STATES = 'plant gripper states'


class Measurements:
    """What the runner last heard: joints (physical order), grippers and their nodes."""

    def __init__(self) -> None:
        self.positions: np.ndarray | None = None  # [rad]; None before the first
        self.velocities = np.zeros(5)  # [rad/s]
        self.grippers: dict[str, str] = {}  # gripper -> its GripperState
        self.nodes: dict[str, str] = {}  # node of each gripper ('' when free)

    def roles(self, base: str) -> np.ndarray:
        """Joint angles in the role order of ``base`` [rad]."""
        return physical_to_roles(self.positions, base)


class WalkRunner:
    """Every decision of the supervisor: the walk, its steps, their faults and reports.

    Parameters
    ----------
    params : walker_core.robot_parameters.WalkerParameters
        The robot, truss and gripper (the parameter file).
    settings : SupervisorParameters
        The ``supervisor.`` section.
    join : callable
        ``join(first, second, lead) -> trajectory``: two :class:`PlanAnswer` streamed as one,
        the second from ``lead`` [s] (within both) before the first ends; raises
        :class:`~walker_planner.core.errors.PlanningError` when they cannot be.
    recorded_step : RecordedStep, optional
        The step an earlier supervisor left on record (a restart).
    answer_wait, give_up_after : float
        [s] of ``steady``: :data:`ANSWER_WAIT`, :data:`ANSWER_GIVE_UP`.
    """

    def __init__(self, params, settings: SupervisorParameters,
                 join: Callable[[PlanAnswer, PlanAnswer, float], object],
                 recorded_step: RecordedStep | None = None, answer_wait: float = ANSWER_WAIT,
                 give_up_after: float = ANSWER_GIVE_UP) -> None:
        self.params = params
        self.kinematics = WalkerKinematics.from_parameters(params)
        self.truss = Truss.from_parameters(params)
        self.sequencer = StepSequencer(settings, self.kinematics, 'a', params.gripper.screw_time,
                                       bool(params.gripper.camera.enabled),
                                       math.pi / params.robot.flexibility.joint1_mode)
        #: places the holes the moving gripper's camera sees (:mod:`.looking`)
        self.sighter = HoleSighter(params)
        self._joint_history = JointHistory()
        #: the last look taken (None before any), for a report against the plant's truth
        self.last_look: LookResult | None = None
        self._look_frames: list = []  # (instant [s], gripper pose, Sighting) of the look
        #: the truss map and the step targets planned on it
        self.mapped = MapPlanning(self.kinematics, self.truss, settings,
                                  params.gripper.insertion_position_tolerance,
                                  params.gripper.approach_height,
                                  params.gripper.screw_length)
        self.measured = Measurements()
        timeout = settings.watchdog_timeout
        self.health = HealthMonitor({PLANT_JOINT_STATES: timeout, PLANT_GRIPPER_STATES: timeout,
                                     **{f'controller {j}': timeout for j in PHYSICAL_JOINT_NAMES}},
                                    trouble_grace=timeout)
        self.controllers = ControllerWatch()
        self.figures = StepFigures(settings.mouth_settle_time, params.gripper.screw_time)
        self._motions = MotionRequests(self.kinematics, join, answer_wait, give_up_after,
                                       settings.motion_end_margin)
        self._announcer = PhaseAnnouncer()
        self._walk: Walk | None = None
        self._goal = ''  # the goal under way: 'walk_to' or 'step' ('' when none)
        self._recorded = recorded_step
        self._adoption_due = False
        self._base_known = False
        #: The operator's command under way (its description; '' when none): set by teleop.
        self.teleop_operation = ''
        self._last_feedback = -math.inf
        self._steady = -math.inf  # [s] the newest steady time heard
        self._last_watch = math.inf  # [s] steady time of the last watch (none yet: inf)
        self._out: list = []

    # ------------------------------------------------------------------ queries
    @property
    def settings(self) -> SupervisorParameters:
        """The ``supervisor.`` section in force."""
        return self.sequencer.parameters

    @property
    def walk(self) -> Walk | None:
        """The walk under way (a ``step`` goal is a walk of one step), or None."""
        return self._walk

    @property
    def measured_enough(self) -> bool:
        """True once joints, both grippers and every watched source have been heard."""
        return self.measured.positions is not None and len(self.measured.grippers) == 2 \
            and not self.health.unheard()

    @property
    def awaiting_plan(self) -> bool:
        """True while a freed gripper waits for the sweep's plan (the sequencer's)."""
        return self.sequencer.awaiting_plan

    @property
    def awaiting_answer(self) -> bool:
        """True while a planner request of the step is sent and unanswered."""
        return self._motions.awaiting_answer

    def set_settings(self, settings: SupervisorParameters) -> None:
        """Take a new ``supervisor.`` section (validated by the caller)."""
        self.sequencer.parameters = settings
        self.mapped.set_settings(settings)
        self.figures.set_window(settings.mouth_settle_time)
        self.health.set_timeouts(settings.watchdog_timeout,
                                 trouble_grace=settings.watchdog_timeout)
        self._motions.end_margin = settings.motion_end_margin

    # ------------------------------------------------------------------ measurements
    def joint_states(self, positions, velocities, steady: float) -> None:
        """Take the plant's joint states (``positions`` None: heard, but not usable)."""
        self._steady = steady
        self.health.seen(PLANT_JOINT_STATES, steady)
        if positions is None:
            return
        positions = np.asarray(positions, dtype=float)
        if positions.shape != (5,) or not np.all(np.isfinite(positions)):
            return
        self.measured.positions = positions
        if velocities is not None:
            self.measured.velocities = np.asarray(velocities, dtype=float)

    def gripper_states(self, states: Mapping[str, tuple[str, str]], now: float,
                       steady: float, position_errors: Mapping[str, float] | None = None
                       ) -> list:
        """Take the plant's gripper states: gripper -> (state, node).

        ``position_errors``: gripper -> its tip's distance from the nearest hole's axis [m]
        as the plant measures it; the one of the step's gripper as it starts screwing in (or
        jams) is the step's insertion error.
        """
        self._steady = steady
        self.health.seen(PLANT_GRIPPER_STATES, steady)
        grippers = self.measured.grippers
        first, before = not grippers, dict(grippers)
        for name, (state, node) in states.items():
            grippers[name], self.measured.nodes[name] = state, node
        step = self.sequencer.step
        if position_errors and step is not None and self.sequencer.phase == Phase.INSERTION:
            moving = step.moving_gripper
            if grippers.get(moving) != before.get(moving) and grippers.get(moving) in (
                    GripperState.SCREWING, GripperState.JAMMED):
                self.figures.plant_measured(float(position_errors.get(moving, math.nan)))
        free = sorted(g for g in ('a', 'b') if grippers.get(g) != GripperState.ATTACHED)
        if first and free and self.sequencer.phase == Phase.IDLE:
            # a supervisor restarted in the middle of a step: nothing may move by itself, and
            # a motion an earlier incarnation started may still be streaming: stop it
            self._execute(self.sequencer.hold(f'started with gripper {", ".join(free)} not '
                                              f'attached', now), now)
            self._adoption_due = True
            self._emit(StopOrphanStream())
        elif not first and grippers != before:
            self._emit(DecideNow())  # a gripper done unscrewing or screwing in
        return self._flush()

    def tip_pose(self, stamp: float, point) -> None:
        """Take the tip's position [m] measured at ``stamp`` [s] (the residual vibration)."""
        self.figures.vibration.add(stamp, np.asarray(point, dtype=float))

    def controller_states(self, reports: Mapping[str, ControllerReport], now: float,
                          steady: float) -> list:
        """Take each controller's newest report (joint -> report), of those that reported."""
        self._steady = steady
        if self.sequencer.phase == Phase.IDLE and not self.sequencer.busy \
                and self._recorded is None and not self._adoption_due:
            self.controllers.expect_idle_hold()
        for joint, report in reports.items():
            self.health.seen(f'controller {joint}', steady,
                             self.controllers.trouble(report, self.sequencer.busy, joint))
        self._emit(*self.controllers.fell_back(reports, self.sequencer.busy, now, steady))
        self._emit(*self.controllers.unexpected_modes(reports, now, steady))
        limit = self.settings.mode_mismatch_hold_time
        if self.controllers.mismatch_lasted(steady, limit) \
                and self.sequencer.phase != Phase.SAFE_HOLD:
            reason = (f'a controller stayed in a mode this supervisor did not command for '
                      f'{limit:g} s in spite of its corrections (another control_mode publisher?)')
            self._emit(Notice(reason, 'error'))
            self._execute(self.sequencer.hold(reason, now), now)
            self._emit(StopJog(reason))
            self._announce(now)
        return self._flush()

    def latched_mode(self, base: str) -> None:
        """Take the base of the last mode command on record (a restarted supervisor)."""
        if not self._base_known and not self.sequencer.busy and base in ('a', 'b'):
            self.sequencer.base_gripper = base
            self._base_known = True

    # ------------------------------------------------------------------ answers
    def request_sent(self, ticket: int, steady: float) -> None:
        """Note that a :class:`PlanMotion` or :class:`FollowMotion` left: it is waited for."""
        self._motions.sent(ticket, steady)

    def request_failed(self, ticket: int, now: float) -> list:
        """Take a request that could not be sent (its server was not found in time)."""
        self._apply(self._motions.failed(ticket), now)
        return self._flush()

    def plan_answered(self, ticket: int, answer: PlanAnswer | None, now: float) -> list:
        """Take the answer to :class:`PlanMotion` ``ticket`` (None: the call failed)."""
        self._apply(self._motions.planned(ticket, answer), now)
        return self._flush()

    def follow_accepted(self, ticket: int, accepted: bool, now: float) -> list:
        """Take the acceptance (or refusal) of :class:`FollowMotion` ``ticket``."""
        self._apply(self._motions.accepted(ticket, accepted, now), now)
        return self._flush()

    def follow_done(self, ticket: int, success: bool, message: str, now: float) -> list:
        """Take the end of the stream of ``ticket`` (``success``), or its refusal or stop."""
        ended = self._motions.ended(ticket, success, message)
        self._apply(ended, now)
        if ended:
            self._emit(DecideNow())  # the next motion or phase is decided now
        return self._flush()

    def frame_seen(self, gripper: str, image: np.ndarray, exposure_time: float,
                   now: float) -> list:
        """Take the frame a :class:`LookRequest` asked for: RGB ``image`` of ``exposure_time``.

        The hole is placed through the joints measured at the tick nearest the frame's
        instant (:class:`~walker_supervisor.core.sighting.HoleSighter`); once the look has its
        frames, the map takes the hole they located, and the step goes on from what they showed.
        A frame that showed the hole gives a :class:`HoleSighted` to publish, first.
        """
        sequencer = self.sequencer
        step, targets = sequencer.step, sequencer.targets
        theta = self._joint_history.at(exposure_time)
        if step is None or targets is None or theta is None \
                or gripper != step.moving_gripper:
            self._emit(Notice(f'frame of camera {gripper} ignored: no look of that gripper is '
                              f'under way', 'warning'))
            return self._flush()
        roles = physical_to_roles(theta, step.base_gripper)
        known = self.mapped.map.estimate(step.to_node, seen=False)
        height = float(targets.frame.to_base(known.position)[2])
        try:
            sighting = self.sighter.sight(image, self.kinematics, roles,
                                          float(targets.point_to[2]))
            commands = sequencer.frame_seen(sighting, height,
                                            math.sqrt(max(known.covariance[2, 2], 0.0)), now)
        except (ValueError, SequencerError) as error:
            self._emit(Notice(f'frame of camera {gripper} ignored: {error}', 'warning'))
            return self._flush()
        pose = self.kinematics.forward_transform(roles)
        if sighting.found:  # back in the gripper's frame: the offset and the height assumed
            self._emit(HoleSighted(gripper, exposure_time,
                                   np.linalg.solve(pose, np.append(sighting.hole, 1.0))[:3]))
        taken = sequencer.look_frames_taken
        self._look_frames = (self._look_frames + [(exposure_time, pose, sighting)])[-taken:]
        located = sequencer.take_located()
        if located is not None:
            self.mapped.map.sight(step.to_node, targets.frame, step.base_node, self.kinematics,
                                  roles, *located)
        weights = sequencer.take_look_done()
        if weights is not None:
            self.last_look = look_result(gripper, step.to_node, sequencer.last_look,
                                         self._look_frames, weights, located,
                                         not sequencer.looking)
        self._execute(commands, now)
        return self._flush()

    def gripper_answered(self, success: bool, message: str, now: float) -> list:
        """Take the plant's answer to a :class:`GripperRequest` (accepted, or refused: why)."""
        try:
            commands = self.sequencer.gripper_done(success, message, now)
        except SequencerError as error:  # an answer nobody waits for: say so, keep running
            self._emit(Notice(f'gripper answer ignored: {error}', 'error'))
            return self._flush()
        self._execute(commands, now)
        return self._flush()

    # ------------------------------------------------------------------ goals
    def start_goal(self, goal: str, target: str, now: float, steady: float) -> list:
        """Take a ``walk_to`` or ``step`` goal to node ``target``, or refuse it.

        Raises
        ------
        GoalRefusedError
            Why the goal cannot be taken now (:mod:`walker_supervisor.core.goals`); nothing
            changed.
        """
        if goal not in GOALS:
            raise GoalRefusedError(f'unknown goal {goal!r}: expected one of {", ".join(GOALS)}')
        self._steady = steady
        check_target(self.truss, target)
        refusal = self._refusal(steady)
        if refusal:
            raise GoalRefusedError(refusal)
        stance = stance_now(self.sequencer.base_gripper, self.measured.grippers,
                            self.measured.nodes, self.truss)
        drive = self.params.robot.drive.yaw
        positions = self.measured.positions
        route = goal_route(goal, self.truss, stance, target,
                           (float(positions[0]), float(positions[4])),
                           (drive.position_min, drive.position_max))
        self._walk, self._goal = Walk(target, route), goal
        if goal == 'walk_to':
            self._emit(Notice(f'walking to {target}: {len(route)} steps '
                              + ' -> '.join(s.to_node for s in route), 'info'))
        return self._flush()

    def _refusal(self, steady: float) -> str:
        """Why no goal may start now ('' when one may)."""
        if self._walk is not None:
            return self._walk.refusal(step_running=self.sequencer.busy)
        if self.sequencer.phase == Phase.SAFE_HOLD:
            return f'the walker is in safe hold ({self.sequencer.reason}): call resume first'
        if self.measured.positions is None:
            return 'no joint states received from the plant yet'
        faults = self.health.faults(steady, include_trouble=False)
        if faults:
            return 'cannot start while ' + '; '.join(faults)
        if self.teleop_operation:
            return (f'a teleoperation command is under way ({self.teleop_operation}): wait for '
                    f'its answer, or call hold to stop a jog')
        return ''

    def cancel_goal(self) -> None:
        """Cancel the goal under way: the step under way finishes, no other starts."""
        if self._walk is not None:
            self._walk.cancel_requested = True

    # ------------------------------------------------------------------ hold and resume
    def hold(self, reason: str, now: float) -> list:
        """Stop in safe hold at once (an operator's hold): the step, and any jog."""
        self._execute(self.sequencer.hold(reason, now), now)
        self._emit(StopJog(reason))
        self._announce(now)  # at once: the decision ticks run on the graph's clock
        return self._flush()

    def resume(self, now: float, steady: float) -> tuple[str, list]:
        """Leave safe hold: the request and a healthy graph, two independent conditions.

        Returns the answer and the commands. Outside SAFE_HOLD there is nothing to resume,
        and that is the answer whatever the graph's health.

        Raises
        ------
        SequencerError
            Why it cannot resume now; nothing changed.
        """
        self.sequencer.require_safe_hold()
        faults = self.health.faults(steady, include_trouble=False)
        if faults:
            raise SequencerError('cannot resume while ' + '; '.join(faults))
        if self.measured.positions is None:
            raise SequencerError('no joint states from the plant')
        self._execute(self.sequencer.resume(
            now, self.measured.roles(self.sequencer.base_gripper), dict(self.measured.grippers),
            dict(self.measured.nodes)), now)
        # at once, before anything can end the motion again: every resume must show on the
        # phase topic as the phase it entered
        self._announce(now)
        answer = (f'resumed: completing the step to {self.sequencer.step.to_node}'
                  if self.sequencer.busy else 'resumed: ready for a step or a walk')
        return answer, self._flush()

    # ------------------------------------------------------------------ teleoperation's
    def teleop_situation(self) -> Situation:
        """Return what an operator's command is judged against (:mod:`.teleop`)."""
        target = self._walk.target if self._walk is not None else None
        positions = self.measured.positions
        return Situation(busy_reason(target, self.sequencer.phase, self.teleop_operation),
                         dict(self.measured.grippers), dict(self.measured.nodes),
                         self.sequencer.base_gripper,
                         None if positions is None else positions.copy())

    def release_refusal(self, gripper: str, steady: float) -> str:
        """Why releasing ``gripper`` is unsafe now ('' when it is not).

        Independent of the sequencer's rules (it starts a step only with both grippers
        attached) and of the plant's own interlock: the other gripper must be reported
        attached in a gripper state heard within the watchdog timeout.
        """
        other = 'b' if gripper == 'a' else 'a'
        if any(f.startswith(PLANT_GRIPPER_STATES)
               for f in self.health.faults(steady, include_trouble=False)):
            return 'interlock: the gripper states are not fresh'
        state = self.measured.grippers.get(other)
        if state != GripperState.ATTACHED:
            return f'interlock: gripper {other} is {state or "unknown"}, not attached'
        return ''

    def command_mode(self, mode: str, base: str, now: float) -> list:
        """Put the controllers in ``mode`` for ``base`` (an operator's command)."""
        return [self.controllers.commanded(SetControlMode(mode, base), now)]

    def use_base(self, gripper: str) -> None:
        """Take ``gripper`` as the base (an operator's command)."""
        self.sequencer.base_gripper = gripper

    def stance_changed(self) -> list:
        """Forget the last step: an operator screwed a gripper in or out.

        Raises
        ------
        SequencerError
            A step is under way.
        """
        self.sequencer.forget_step()
        self.mapped.forget_stance()
        return [ForgetRecordedStep()]

    # ------------------------------------------------------------------ time
    def tick(self, now: float, steady: float) -> list:
        """Decide: the step's next move, the walk's next step, feedback and the phase."""
        self._steady = steady
        measured = self.measured
        if self._adoption_due and measured.positions is not None and len(measured.grippers) == 2:
            self._adoption_due = False
            self._adopt()
        self._apply(self._motions.check(steady, now), now)
        if measured.positions is not None:
            self._joint_history.add(now, measured.positions)
            base = self.sequencer.base_gripper
            self._execute(self.sequencer.tick(now, measured.roles(base),
                                              physical_to_roles(measured.velocities, base),
                                              dict(measured.grippers)), now)
            self._take_felt_faces()
        walk = self._walk
        if walk is not None:
            if not self.sequencer.busy:
                self._advance_walk(walk, now)
            if self._walk is not None and now - self._last_feedback >= FEEDBACK_PERIOD:
                self._emit(goal_feedback(self._goal, walk, self.sequencer, now))
                self._last_feedback = now
        else:
            self._end_step_outside_walk()
        self._announce(now)
        return self._flush()

    def watch(self, now: float, steady: float, clock_held: bool = False) -> list:
        """Watch the sources: one that falls silent stops the walker in safe hold.

        ``clock_held``: the graph's simulated clock stands still for this runner's own request
        (the plant steps no further): the silence of the sources driven by it is no fault.
        """
        stalled = self._own_stall(steady)
        self._steady = steady
        self._apply(self._motions.check(steady, now), now)
        if stalled:
            # What the sources sent while this process stood still has not been taken yet:
            # their silence is its own. Each has a whole timeout to be heard again.
            self.health.excuse(self.health.names, steady)
        if clock_held:
            self.health.excuse([name for name in self.health.names
                                if name != PLANT_GRIPPER_STATES], steady)
        busy = self.sequencer.busy
        faults = [fault for fault in self.health.faults(steady, include_trouble=busy)
                  if not fault.endswith(': not heard from yet')]
        if faults:
            self._emit(StopJog('fault: ' + '; '.join(faults)))
        # Between steps no step moves: a fault is reported on the diagnostics and refuses new
        # goals while it lasts, and needs no resume.
        if stalled and not busy:
            self._emit(Notice(stalled, 'warning'))
        elif stalled:
            self._emit(StopJog(stalled))
            self._emit(Notice(stalled, 'error'))
            self._execute(self.sequencer.hold(stalled, now), now)
            self._announce(now)
        elif faults and busy:
            reason = 'fault: ' + '; '.join(faults)
            self._emit(Notice(reason, 'error'))
            self._execute(self.sequencer.hold(reason, now), now)
            self._announce(now)
        elif self.sequencer.phase == Phase.SAFE_HOLD:
            # the hold's first reason may be a consequence (controllers holding on stale
            # inputs): name the dead source behind it as soon as the watchdog sees it
            reason = reason_naming_silent_sources(self.sequencer.reason,
                                                  self.health.status(steady))
            if reason != self.sequencer.reason:
                self._emit(Notice(f'in safe hold: {reason}', 'error'))
                self._execute(self.sequencer.hold(reason, now), now)
                self._announce(now)
        return self._flush()

    def _own_stall(self, steady: float) -> str:
        """Say how long this runner itself stood still, if longer than the watchdog timeout.

        The watch comes every ``WATCH_PERIOD`` on the steady clock; a gap of more than the
        watchdog timeout between two is a stall of the process (frozen, starved, swapped out),
        not of its sources. Returns the hold reason naming it, or ``''``.
        """
        previous, self._last_watch = self._last_watch, steady
        gap = steady - previous
        if not gap > self.settings.watchdog_timeout:
            return ''
        return (f'fault: the supervisor itself stalled {gap:.1f} s (its watchdog, due every '
                f'{WATCH_PERIOD:g} s, ran late by more than its timeout '
                f'{self.settings.watchdog_timeout:g} s): its decisions were late; its inputs '
                f'are not to blame')

    def diagnostics(self, steady: float, extra: list[SourceStatus]
                    ) -> tuple[Level, str, list[SourceStatus]]:
        """Return the walker's status: level, summary, every source's status (and ``extra``).

        ``extra``: the shell's own (its clients' servers discovered or not). In safe hold the
        level is ERROR with the reason; else the worst of the statuses.
        """
        statuses = self.health.status(steady) + list(extra)
        if self.sequencer.phase == Phase.SAFE_HOLD:
            return Level.ERROR, f'safe hold: {self.sequencer.reason}', statuses
        return (max((s.level for s in statuses), default=Level.OK),
                f'phase {self.sequencer.phase.name}', statuses)

    # ------------------------------------------------------------------ the walk
    def _advance_walk(self, walk: Walk, now: float) -> None:
        """Between steps: record the step that ended, then start the next or end the walk."""
        outcome = self.sequencer.take_outcome()
        if outcome is not None:
            self._record_outcome(walk, outcome)
        if self.sequencer.phase == Phase.SAFE_HOLD and not walk.failed:
            walk.outcomes.append(StepOutcome(False, self.sequencer.reason, {}, 0.0, math.nan, 0))
        if walk.finished:
            # a walk ends relaxed: a stance measured after it is not bent by its last seat
            if now >= self.sequencer.relaxed_at:
                if walk.reached and walk.outcomes:  # the last node again, from the relaxed stance
                    self._survey_screw_in(walk.outcomes[-1])
                base = self.sequencer.base_gripper
                self._emit(goal_ended(self._goal, walk, base, self.measured.nodes.get(base, ''),
                                      self.figures))
                self._walk, self._goal = None, ''
            return
        if not self.sequencer.can_start(now):  # it would measure its stance bent
            return
        step = walk.next_step()
        self._motions.prepared.clear()
        try:
            targets = self._measure_targets(step, self.measured.roles(self.sequencer.base_gripper))
            commands = self.sequencer.start(step, targets, now, dict(self.measured.grippers),
                                            lambda theta: self._measure_again(step, theta,
                                                                              targets),
                                            self.mapped.search(step))
        except (KinematicsError, SequencerError) as error:
            walk.outcomes.append(StepOutcome(False, f'step to {step.to_node} refused: {error}',
                                             {}, 0.0, math.nan, 0))
            self._emit(Notice(walk.outcomes[-1].message, 'error'))
            return
        self._emit(RecordStep(step, targets.frame.heading, self.mapped.map.to_dict()))
        self.figures.start()
        self._emit(Notice(f'step {walk.step_index + 1}/{len(walk.route)}: gripper '
                          f'{step.moving_gripper} {step.from_node} -> {step.to_node} '
                          f'({math.degrees(targets.sweep):+.0f} deg about {step.base_node})',
                          'info'))
        self._execute(commands, now)

    def _measure_targets(self, step: PlannedStep, theta_roles: np.ndarray) -> StepTargets:
        """Return the step's targets from the stance ``theta_roles`` [rad] (role order).

        The stance is surveyed into the truss map first; the targets are planned on the map
        (:class:`~walker_supervisor.core.map_planning.MapPlanning`).
        """
        return self.mapped.targets(step, theta_roles)

    def _take_felt_faces(self) -> None:
        """Take into the map the heights of the target node felt by the step's jams."""
        step, targets = self.sequencer.step, self.sequencer.targets
        for theta in self.sequencer.take_felt_faces():
            if step is not None and targets is not None:
                self.mapped.felt_face(step, targets.frame, theta)
                self.sequencer.move_mouth(
                    float(targets.frame.to_base(self.mapped.map.position(step.to_node))[2]))

    def _survey_screw_in(self, outcome: StepOutcome) -> None:
        """Survey the node a step screwed into from the joints, in its base's role order."""
        step, targets = self.sequencer.step, self.sequencer.targets
        if not outcome.success or step is None or targets is None \
                or self.measured.positions is None:
            return
        self.mapped.screwed_in(step, targets, self.measured.roles(step.base_gripper))
        if outcome.search_probes:
            estimate = self.mapped.map.estimate(step.to_node)
            self._emit(Notice(f'hole of {step.to_node} found by the search: probe '
                              f'{outcome.search_probes}, {outcome.hole_offset * 1e3:.1f} mm from '
                              f'the estimate; surveyed at '
                              f'{", ".join(f"{v:.4f}" for v in estimate.position)} m', 'info'))

    def _measure_again(self, step: PlannedStep, theta_roles: np.ndarray,
                       first: StepTargets) -> StepTargets:
        """Measure the targets from the relaxed stance (the sequencer's remeasure); record."""
        targets = self._measure_targets(step, theta_roles)
        change = math.remainder(targets.frame.heading - first.frame.heading, 2 * math.pi)
        self._emit(RecordStep(step, targets.frame.heading, self.mapped.map.to_dict()),
                   Notice(f'stance measured again after the relaxation: the base heading moved '
                          f'by {change * 1e3:+.3f} mrad', 'info'))
        return targets

    def _record_outcome(self, walk: Walk, outcome: StepOutcome) -> None:
        self._survey_screw_in(outcome)
        if outcome.success:
            self._emit(ForgetRecordedStep())
        walk.outcomes.append(outcome)
        index = len(walk.outcomes) - 1
        self._emit(self.figures.record(index, len(walk.route), walk.route[index], outcome))
        text = (f'step {index + 1} {"done" if outcome.success else "failed"} in '
                f'{outcome.duration:.2f} s' + (f': {outcome.message}' if outcome.message else ''))
        self._emit(Notice(text, 'info' if outcome.success else 'error'))

    def _end_step_outside_walk(self) -> None:
        """Log a step resumed after its walk ended, once it has ended; forget its record.

        Its outcome is taken here so that the next walk does not count it as its own first
        step.
        """
        outcome = self.sequencer.take_outcome()
        if outcome is None:
            return
        step = self.sequencer.step
        self._survey_screw_in(outcome)
        if outcome.success:
            self._emit(ForgetRecordedStep(),
                       Notice(f'step {step.from_node} -> {step.to_node} completed after resume '
                              f'in {outcome.duration:.2f} s', 'info'))
        else:
            self._emit(Notice(f'step {step.from_node} -> {step.to_node} failed after resume: '
                              f'{outcome.message}', 'error'))

    def _adopt(self) -> None:
        """Take up the step an earlier incarnation left unfinished, if its gripper is free."""
        record, self._recorded = self._recorded, None
        if record is None:
            return
        survey = self.mapped.map
        if record.survey is not None:
            # the map the step was planned on (its frame, its target, its search), kept only
            # if the record describes the walker
            survey = TrussMap(self.truss, survey.prior_std, survey.joint_std)
            try:
                survey.load(record.survey)
            except SurveyFileError as error:
                survey = self.mapped.map
                self._emit(Notice(f'the truss map on record is not usable ({error}): the '
                                  f'step is taken up on the nominal places of its nodes',
                                  'warning'))
        try:
            adopted = adopt_step(record, self.measured.grippers, self.measured.nodes,
                                 self.measured.positions, survey, self.kinematics,
                                 self.params.gripper.approach_height)
        except AdoptionRefusedError as error:
            self._emit(Notice(f'cannot take up the interrupted step: {error}', 'error'))
            return
        if adopted is None:
            # not the situation the record describes (another run's, or a step completed by
            # hand): forget it, so that it cannot be taken up later by mistake
            self._emit(Notice(f'the step on record ({record.from_node} -> {record.to_node} '
                              f'about {record.base_node}) does not describe the walker now: '
                              f'forgotten', 'info'), ForgetRecordedStep())
            return
        step, targets = adopted
        if survey is not self.mapped.map:
            self.mapped.map.load(record.survey)
        self.sequencer.adopt(step, targets, f'restarted in the middle of the step '
                             f'{step.from_node} -> {step.to_node}: resume to complete it',
                             self.mapped.search(step))
        # the adopted step's base is measured attached in its node: a latched mode heard after
        # (this supervisor's own hold, commanded before the record was read) must not change it
        self._base_known = True
        self._emit(Notice(self.sequencer.reason))

    # ------------------------------------------------------------------ commands
    def _execute(self, commands: list, now: float) -> None:
        """Carry out the sequencer's commands: the walk's part, then out to the shell."""
        for command in commands:
            if isinstance(command, SetControlMode):
                self._emit(self.controllers.commanded(command, now))
            elif isinstance(command, GripperRequest):
                self._gripper(command, now)
            elif isinstance(command, TrajectoryRequest):
                if command.purpose in ('fine', 'insertion'):
                    self.figures.vibration.clear()
                self._apply(self._motions.request(command), now)
            elif isinstance(command, PrepareTrajectory):
                self._apply(self._motions.prepare(command.request), now)
            elif isinstance(command, CancelTrajectory):
                self._apply(self._motions.cancel(), now)
            else:
                self._emit(command)

    def _gripper(self, request: GripperRequest, now: float) -> None:
        if request.action == 'screw_in' and self.sequencer.phase == Phase.INSERTION:
            self.figures.screw_in(self.truss.position(self.sequencer.step.to_node))
        if request.action == 'unscrew':
            refusal = self.release_refusal(request.gripper, self._steady)
            if refusal:
                self._emit(Notice(f'unscrewing gripper {request.gripper} refused: {refusal}',
                                  'error'))
                self._execute(self.sequencer.gripper_done(False, refusal, now), now)
                return
        self._emit(request)

    def _apply(self, items: list, now: float) -> None:
        """Carry out what the planner requests say: to the step, or out to the shell."""
        for item in items:
            if isinstance(item, MotionStarted):
                self.sequencer.trajectory_started(item.duration, now, item.first_duration)
            elif isinstance(item, MotionEnded) and item.unreported:
                # the planner never said the motion ended: hold, as for setpoints gone stale,
                # rather than plan on with it (the controllers hold their trajectory's end)
                self._execute(self.sequencer.hold(f'fault: {item.message}', now), now)
                self._announce(now)
            elif isinstance(item, MotionEnded):
                self._execute(self.sequencer.trajectory_done(item.success, item.message, now),
                              now)
                if self.sequencer.phase == Phase.INSERTION \
                        and self.sequencer.stage == Stage.SETTLING:
                    # at the mouth: the residual vibration and the true error are of the arm
                    # at rest there, not of the descent's last centimetres
                    self.figures.vibration.clear()
            elif isinstance(item, PlannedAhead):
                waiting = self.sequencer.awaiting_plan
                if item.duration is None:
                    self.sequencer.motion_not_planned(item.purpose)
                else:
                    self.sequencer.motion_planned(item.purpose, item.duration)
                if waiting:  # a freed gripper waiting for it lifts now, not at the next tick
                    self._emit(DecideNow())
            elif isinstance(item, MotionPlanned):
                self.figures.planned(item.purpose, item.time_optimal_bound)
            elif isinstance(item, SetControlMode):
                self._emit(self.controllers.commanded(item, now))
            else:
                self._emit(item)

    def _announce(self, now: float) -> None:
        self._emit(*self._announcer.announce(now, self.sequencer, self._walk,
                                             self.measured.grippers))

    def _emit(self, *commands) -> None:
        self._out.extend(commands)

    def _flush(self) -> list:
        out, self._out = self._out, []
        return out
