"""A walk through the step sequencer, decided in the lock-step loop as the supervisor node does.

The supervisor node's walk, free of ROS: the route (:func:`~walker_supervisor.core.route.
plan_route`), each step's targets from the measured stance
(:func:`~walker_supervisor.core.step_geometry.measure_step_targets`), the
:class:`~walker_supervisor.core.sequencer.StepSequencer` ticked every ``TICK_PERIOD`` of
simulated time and at once when a gripper's state changes or a motion ends, its commands
carried out by the :class:`~walker_headless.executor.CommandExecutor`, the step reports
(time-optimal bound, true insertion error and residual vibration from the plant's tip pose),
the phase messages and the walk's feedback.

The supervisor's decisions are lock-stepped: they fall on the simulated times the node's
would with the plant waiting for them (``sim.wait_for_decisions``), and planner and gripper
answers take no simulated time.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from walker_core.joint_roles import GRIPPERS, other_gripper, physical_to_roles
from walker_core.kinematics import KinematicsError, WalkerKinematics
from walker_core.truss import Truss, UnknownNodeError
from walker_supervisor.core.route import (
    PlannedStep, Stance, UnreachableTargetError, plan_route)
from walker_supervisor.core.commands import GripperRequest, TrajectoryRequest
from walker_supervisor.core.phases import Phase, SequencerError, StepOutcome
from walker_supervisor.core.sequencer import StepSequencer
from walker_supervisor.core.step_geometry import StepTargets, measure_step_targets
from walker_supervisor.core.walk import VibrationMeter, Walk

from walker_headless.executor import (
    CommandExecutor, GripperAnswered, MotionNotPlanned, MotionPlanned, Said, StreamEnded,
    StreamFailed, StreamStarted)
from walker_headless.loop import RobotLoop, stamp_seconds
from walker_headless.records import PhaseRecord, StepReportRecord

__all__ = ['WalkDriver', 'WalkRefusedError', 'TICK_PERIOD', 'FEEDBACK_PERIOD']

#: [s] the supervisor's decision period (``supervisor_node.TICK_PERIOD``)
TICK_PERIOD = 0.02
#: [s] the walk's feedback period (``supervisor_node.FEEDBACK_PERIOD``)
FEEDBACK_PERIOD = 0.1
#: The phase is published again, within a phase, each time its progress has grown this much.
PROGRESS_STEP = 0.25
#: The motions whose planner bounds make up a step's time-optimal bound.
_BOUNDED = frozenset({'extraction', 'coarse', 'insertion'})
#: [s] shortest window of the residual vibration figures (five poses at 100 Hz)
_MIN_VIBRATION_WINDOW = 0.05


class WalkRefusedError(ValueError):
    """A walk that cannot start: the reason, nothing moved."""


class WalkDriver:
    """The supervisor's walk in the lock-step loop (see the module docstring).

    Parameters
    ----------
    loop : RobotLoop
        The robot side.
    say : callable, optional
        ``say(level, text)`` for what the supervisor would log.
    """

    def __init__(self, loop: RobotLoop, say: Callable[[str, str], None] | None = None) -> None:
        sections = loop.sections
        self.loop = loop
        self.params = sections.walker
        self.settings = sections.supervisor
        self.kinematics = WalkerKinematics.from_parameters(self.params)
        self.truss = Truss.from_parameters(self.params)
        self.executor = CommandExecutor(loop, self.kinematics)
        self.sequencer = StepSequencer(self.settings, self.kinematics, loop.state.base,
                                       self.params.gripper.screw_time)
        self.vibration = VibrationMeter(max(self.settings.mouth_settle_time,
                                            _MIN_VIBRATION_WINDOW))
        self._say = say or (lambda level, text: None)
        self.walk: Walk | None = None
        self.done = False  # the walk has ended (relaxed after its last step, or failed)
        self.reports: list[StepReportRecord] = []
        self.phases: list[PhaseRecord] = []
        self.feedback: Callable | None = None  # feedback(walk, sequencer) every FEEDBACK_PERIOD
        self._tick_ns = round(TICK_PERIOD * 1e9)
        self._next_tick = 0  # [ns]
        self._grippers_seen: dict[str, str] = {}
        self._step_bound = 0.0
        self._bounded: set[str] = set()
        self._true_insertion_error = math.nan
        self._residual_vibration = math.nan
        self._last_feedback = -math.inf
        self._last_phase: tuple | None = None
        self._published_progress = 0.0
        self._tick_due = False

    # ------------------------------------------------------------------ measurements
    @property
    def grippers(self) -> dict[str, str]:
        """Each gripper's state ('free', 'attached', ...) as ``gripper_states`` says."""
        statuses = self.loop.state.statuses
        return {g: statuses[g].mode.name.lower() for g in GRIPPERS}

    def _theta_roles(self) -> np.ndarray:
        return physical_to_roles(np.array(self.loop.positions), self.sequencer.base_gripper)

    def _velocity_roles(self) -> np.ndarray:
        return physical_to_roles(np.array(self.loop.velocities), self.sequencer.base_gripper)

    # ------------------------------------------------------------------ the walk
    def start_walk(self, target: str) -> list[PlannedStep]:
        """Plan the route to ``target`` from the stance now and begin the walk.

        Raises
        ------
        WalkRefusedError
            With the reason: a target unknown or out of reach, a gripper not attached, a walk
            under way or the walker in safe hold (nothing moves).
        """
        if self.walk is not None:
            raise WalkRefusedError(self.walk.refusal(step_running=self.sequencer.busy))
        if self.sequencer.phase == Phase.SAFE_HOLD:
            raise WalkRefusedError(f'the walker is in safe hold ({self.sequencer.reason}): call '
                              f'resume first')
        try:
            stance = self._current_stance()
            drive = self.params.robot.drive.yaw
            positions = self.loop.positions
            route = plan_route(self.truss, stance, target, yaws=(positions[0], positions[4]),
                               yaw_limits=(drive.position_min, drive.position_max))
        except (SequencerError, UnknownNodeError, UnreachableTargetError) as error:
            raise WalkRefusedError(str(error)) from None
        self.walk = Walk(target, route)
        self._say('info', f'walking to {target}: {len(route)} steps '
                  + ' -> '.join(s.to_node for s in route))
        return route

    def _current_stance(self) -> Stance:
        base = self.sequencer.base_gripper
        other = other_gripper(base)
        grippers = self.grippers
        if grippers[base] != 'attached' or grippers[other] != 'attached':
            raise SequencerError('a walk starts only with both grippers attached (now: '
                                 + ', '.join(f'{g}: {grippers[g]}' for g in GRIPPERS) + ')')
        statuses = self.loop.state.statuses
        stance = Stance(base, statuses[base].node, statuses[other].node)
        if stance.other_node not in self.truss.neighbors(stance.base_node):
            raise SequencerError(f'the grippers are in {stance.base_node} and '
                                 f'{stance.other_node}, which are not neighbouring nodes')
        return stance

    # ------------------------------------------------------------------ each period
    def decide(self) -> None:
        """Decide at the loop's state: a motion's end, a gripper's change, the periodic tick."""
        loop = self.loop
        if loop.poses_out:
            state = loop.state
            self.vibration.add(stamp_seconds(loop.stamp), state.poses[state.tip].position)
        ended = self.executor.take_stream_end()
        if ended is not None:
            self._handle([ended])
        if loop.grippers_changed:  # a gripper_states message: a change of mode decides now
            grippers = self.grippers
            if grippers != self._grippers_seen:
                changed = bool(self._grippers_seen)
                self._grippers_seen = grippers
                self._tick_due = self._tick_due or changed
        if loop.stamp >= self._next_tick:  # the timer: on its grid of simulated time
            self._tick_due = True
            while self._next_tick <= loop.stamp:
                self._next_tick += self._tick_ns
        while self._tick_due:
            self._tick_due = False
            self._tick()

    def _tick(self) -> None:
        now = self.loop.time
        sequencer = self.sequencer
        self._execute(sequencer.tick(now, self._theta_roles(), self._velocity_roles(),
                                     self.grippers))
        walk = self.walk
        if walk is not None:
            if not sequencer.busy:
                self._advance_walk(walk, now)
            if now - self._last_feedback >= FEEDBACK_PERIOD and self.feedback is not None:
                self.feedback(walk, sequencer)
                self._last_feedback = now
        self._publish_phase()

    def _advance_walk(self, walk: Walk, now: float) -> None:
        """Between steps: record the step that ended, then start the next or end the walk."""
        sequencer = self.sequencer
        outcome = sequencer.take_outcome()
        if outcome is not None:
            self._record_outcome(walk, outcome)
        if sequencer.phase == Phase.SAFE_HOLD and not walk.failed:
            walk.outcomes.append(StepOutcome(False, sequencer.reason, {}, 0.0, math.nan, 0))
        if walk.finished:
            # a walk ends relaxed: a stance measured after it is not bent by its last seat
            if now >= sequencer.relaxed_at:
                self.done = True
            return
        if not sequencer.can_start(now):  # it would measure its stance bent
            return
        step = walk.next_step()
        self.executor.forget_prepared()
        try:
            targets = self._measure_targets(step, self._theta_roles())
            commands = sequencer.start(step, targets, now, self.grippers,
                                       lambda theta: self._measure_targets(step, theta))
        except (KinematicsError, SequencerError) as error:
            walk.outcomes.append(StepOutcome(False, f'step to {step.to_node} refused: {error}',
                                             {}, 0.0, math.nan, 0))
            self._say('error', walk.outcomes[-1].message)
            return
        self._step_bound = 2.0 * self.params.gripper.screw_time
        self._bounded = set()
        self._true_insertion_error = math.nan
        self._say('info', f'step {walk.step_index + 1}/{len(walk.route)}: gripper '
                  f'{step.moving_gripper} {step.from_node} -> {step.to_node} '
                  f'({math.degrees(targets.sweep):+.0f} deg about {step.base_node})')
        self._execute(commands)

    def _measure_targets(self, step: PlannedStep, theta_roles: np.ndarray) -> StepTargets:
        return measure_step_targets(self.kinematics, step, self.truss.position(step.base_node),
                                    self.truss.position(step.from_node),
                                    self.truss.position(step.to_node), theta_roles,
                                    self.params.gripper.approach_height)

    def _record_outcome(self, walk: Walk, outcome: StepOutcome) -> None:
        walk.outcomes.append(outcome)
        step = walk.route[len(walk.outcomes) - 1]
        bound = self._step_bound
        report = StepReportRecord(
            stamp=self.loop.stamp, step_index=len(walk.outcomes) - 1,
            step_count=len(walk.route), base_gripper=step.base_gripper,
            moving_gripper=step.moving_gripper, base_node=step.base_node,
            from_node=step.from_node, to_node=step.to_node, sweep=float(step.sweep),
            success=outcome.success, message=outcome.message,
            phase_names=list(outcome.phase_durations),
            phase_durations=[float(v) for v in outcome.phase_durations.values()],
            duration=float(outcome.duration), time_optimal_bound=float(bound),
            bound_ratio=float(outcome.duration / bound) if bound > 0 else 0.0,
            insertion_error=float(self._true_insertion_error),
            insertion_error_estimated=float(outcome.insertion_error),
            residual_vibration=float(self._residual_vibration),
            insertion_attempts=outcome.insertion_attempts)
        self.reports.append(report)
        if self.loop.recording is not None:
            self.loop.recording.step_report(report)
        self._say('info' if outcome.success else 'error',
                  f'step {report.step_index + 1} {"done" if outcome.success else "failed"} in '
                  f'{outcome.duration:.2f} s' + (f': {outcome.message}' if outcome.message
                                                 else ''))

    # ------------------------------------------------------------------ commands
    def _execute(self, commands: list) -> None:
        sequencer = self.sequencer
        for command in commands:
            if isinstance(command, TrajectoryRequest) and command.purpose in ('fine',
                                                                              'insertion'):
                self.vibration.clear()
            if isinstance(command, GripperRequest):
                if command.action == 'screw_in' and sequencer.phase == Phase.INSERTION:
                    self._measure_insertion()
                refusal = self._release_interlock(command) if command.action == 'unscrew' \
                    else ''
                if refusal:
                    self._say('error', f'unscrewing gripper {command.gripper} refused: '
                              f'{refusal}')
                    self._handle([GripperAnswered(False, refusal)])
                    continue
            self._handle(self.executor.execute(command))

    def _handle(self, events: list) -> None:
        """Give the sequencer what the executor answered; carry out what it decides."""
        sequencer = self.sequencer
        for event in events:
            now = self.loop.time
            if isinstance(event, GripperAnswered):
                try:
                    self._execute(sequencer.gripper_done(event.success, event.message, now))
                except SequencerError as error:
                    self._say('error', f'gripper answer ignored: {error}')
            elif isinstance(event, StreamStarted):
                for purpose, bound in event.bounds.items():
                    if purpose in _BOUNDED and purpose not in self._bounded:
                        self._bounded.add(purpose)
                        self._step_bound += bound
                sequencer.trajectory_started(event.duration, now, event.first_duration)
            elif isinstance(event, StreamFailed):
                self._say('error', event.message)
                self._execute(sequencer.trajectory_done(False, event.message, now))
            elif isinstance(event, StreamEnded):
                self._execute(sequencer.trajectory_done(event.success, event.message, now))
                if sequencer.phase == Phase.INSERTION and sequencer.stage == 'settling':
                    # at the mouth: the residual vibration and the true error are of the arm
                    # at rest there, not of the descent's last centimetres
                    self.vibration.clear()
                self._tick_due = True  # the next motion or phase is decided now
            elif isinstance(event, MotionPlanned):
                sequencer.motion_planned(event.purpose, event.duration)
            elif isinstance(event, MotionNotPlanned):
                sequencer.motion_not_planned(event.purpose)
            elif isinstance(event, Said):
                self._say(event.level, event.message)

    def _measure_insertion(self) -> None:
        """Take the figures of the screw-in's start: where the plant's tip is, how it rings."""
        self._residual_vibration = self.vibration.amplitude()
        tip = self.vibration.latest()
        hole = self.truss.position(self.sequencer.step.to_node)
        self._true_insertion_error = float(np.linalg.norm(tip[:2] - hole[:2]))

    def _release_interlock(self, command: GripperRequest) -> str:
        """Why releasing the gripper is unsafe now ('' when it is not): the other must be held."""
        other = other_gripper(command.gripper)
        state = self.grippers[other]
        return '' if state == 'attached' else \
            f'interlock: gripper {other} is {state}, not attached'

    # ------------------------------------------------------------------ the phase topic
    def _publish_phase(self) -> None:
        sequencer, walk = self.sequencer, self.walk
        step = sequencer.step if sequencer.busy else None
        key = (sequencer.phase, sequencer.reason, sequencer.base_gripper,
               walk.step_index if walk else 0, walk is not None, sequencer.step)
        progress = sequencer.phase_progress(self.loop.time)
        advanced = progress > self._published_progress \
            and progress >= min(1.0, self._published_progress + PROGRESS_STEP)
        if key == self._last_phase and not advanced:
            return
        self._last_phase, self._published_progress = key, progress
        held = sequencer.phase == Phase.SAFE_HOLD and sequencer.step is not None \
            and self.grippers[sequencer.step.moving_gripper] != 'attached'
        shown = sequencer.step if step is not None or held else None
        record = PhaseRecord(
            stamp=self.loop.stamp, phase=int(sequencer.phase),
            base_gripper=sequencer.base_gripper,
            step_index=walk.step_index if walk is not None else 0,
            step_count=len(walk.route) if walk is not None else 0,
            from_node=shown.from_node if shown else '', to_node=shown.to_node if shown else '',
            base_node=shown.base_node if shown else '',
            base_heading=float(sequencer.targets.frame.heading) if shown else 0.0,
            phase_progress=progress, reason=sequencer.reason)
        self.phases.append(record)
        if self.loop.recording is not None:
            self.loop.recording.phase(record)
