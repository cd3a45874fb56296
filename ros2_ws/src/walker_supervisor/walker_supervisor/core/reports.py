"""What the supervisor reports: the phase, each step's figures, a goal's feedback and result.

:class:`PhaseAnnouncer` says when the phase is published again: on a change of phase, reason,
base, step or walk, and within a phase each time its progress has grown by
:data:`PROGRESS_STEP` (and when it reaches 1). :class:`StepFigures` keeps the figures of the
step under way that the sequencer does not know: its time-optimal bound (the planner's bounds
of its extraction, coarse motion and insertion, plus the two screw actions), and at the
screw-in the tip's measured distance from the hole's axis and its residual vibration.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

import numpy as np

from walker_core.gripper_state import GripperState
from walker_supervisor.core.commands import Feedback, GoalEnded, Notice, PhaseRecord, StepRecord
from walker_supervisor.core.phases import Phase, StepOutcome
from walker_supervisor.core.route import PlannedStep
from walker_supervisor.core.walk import VibrationMeter, Walk

__all__ = ['PhaseAnnouncer', 'StepFigures', 'goal_feedback', 'goal_ended', 'phase_fields',
           'report_fields', 'PROGRESS_STEP', 'BOUNDED_MOTIONS', 'MIN_VIBRATION_WINDOW']

#: The phase is published again, within a phase, each time its progress has grown this much
#: (and when it reaches 1): a few messages per phase.
PROGRESS_STEP = 0.25
#: The motions whose planner bounds make up a step's time-optimal bound.
BOUNDED_MOTIONS = frozenset({'extraction', 'coarse', 'insertion'})
#: [s] shortest window of the residual vibration figures (five poses at 100 Hz)
MIN_VIBRATION_WINDOW = 0.05


class PhaseAnnouncer:
    """Decides when the phase is published, and what it says."""

    def __init__(self) -> None:
        self._last: tuple | None = None
        self._published_progress = 0.0

    def announce(self, now: float, sequencer, walk: Walk | None,
                 grippers: Mapping[str, str]) -> list:
        """Return the phase to publish at ``now`` [s] (with a log line on a change), or [].

        Nothing is said before the grippers are known: a supervisor restarted in the middle of
        a step would announce IDLE, then hold once it saw a gripper free.
        """
        if not grippers:
            return []
        step = sequencer.step
        key = (sequencer.phase, sequencer.reason, sequencer.base_gripper,
               walk.step_index if walk else 0, walk is not None, step)
        progress = sequencer.phase_progress(now)
        advanced = progress > self._published_progress \
            and progress >= min(1.0, self._published_progress + PROGRESS_STEP)
        if key == self._last and not advanced:
            return []
        out = []
        if self._last is not None and key[0] != self._last[0]:
            text = f'phase {sequencer.phase.name}' + (f': {sequencer.reason}'
                                                      if sequencer.reason else '')
            out.append(Notice(text, 'warning' if sequencer.phase == Phase.SAFE_HOLD else 'info'))
        self._last, self._published_progress = key, progress
        held = sequencer.phase == Phase.SAFE_HOLD and step is not None \
            and grippers.get(step.moving_gripper) != GripperState.ATTACHED
        shown = step if sequencer.busy or held else None
        out.append(PhaseRecord(
            sequencer.phase, sequencer.base_gripper, sequencer.reason, progress,
            walk.step_index if walk else 0, len(walk.route) if walk else 0,
            shown.from_node if shown else '', shown.to_node if shown else '',
            shown.base_node if shown else '',
            float(sequencer.targets.frame.heading) if shown else 0.0))
        return out


class StepFigures:
    """The figures of the step under way that the walk summary reports.

    Parameters
    ----------
    vibration_window : float
        [s] window of the residual vibration (at least :data:`MIN_VIBRATION_WINDOW`).
    screw_time : float
        [s] a screw-in or unscrew (``gripper.screw_time``): two of them are in every step's
        bound.
    """

    def __init__(self, vibration_window: float, screw_time: float) -> None:
        self.vibration = VibrationMeter(window=max(vibration_window, MIN_VIBRATION_WINDOW))
        self._screw_time = float(screw_time)
        self.time_optimal_bound = 0.0
        self._bounded: set[str] = set()
        self.insertion_error = math.nan
        self.residual_vibration = math.nan

    def set_window(self, window: float) -> None:
        """Take a new vibration window [s]."""
        self.vibration.window = max(window, MIN_VIBRATION_WINDOW)

    def start(self) -> None:
        """Start a step: its bound is the two screw actions until its motions are planned."""
        self.time_optimal_bound = 2.0 * self._screw_time
        self._bounded = set()
        self.insertion_error = math.nan

    def planned(self, purpose: str, time_optimal_bound: float) -> None:
        """Add a motion's bound [s]: its extraction, coarse motion and insertion, once each.

        Fine corrections and retries are not in the bound.
        """
        if purpose in BOUNDED_MOTIONS and purpose not in self._bounded:
            self._bounded.add(purpose)
            self.time_optimal_bound += time_optimal_bound

    def screw_in(self, hole: np.ndarray) -> None:
        """Keep the tip's figures as the screw-in starts over ``hole`` [m] (the drawing's).

        The error is the tip's horizontal distance from the hole's axis where it is as the
        screw-in starts (what the plant's thread checks), not a mean over the settle window,
        which the ring biases when the window is short. Until the plant says where the hole
        really is (:meth:`plant_measured`), it is taken from the drawing's hole: on a truss as
        built that holds the node's placement error too.
        """
        self.residual_vibration = self.vibration.amplitude()
        tip = self.vibration.latest()
        self.insertion_error = float(np.linalg.norm(tip[:2] - np.asarray(hole)[:2]))

    def plant_measured(self, position_error: float) -> None:
        """Take the plant's own insertion error [m]: the tip from the real hole's axis.

        The plant reports it with the screw-in's start (``walker_msgs/GripperState``'s
        ``position_error`` as the gripper starts screwing or jams): it replaces the error
        from the drawing's hole.
        """
        if math.isfinite(position_error):
            self.insertion_error = float(position_error)

    def record(self, step_index: int, step_count: int, step: PlannedStep,
               outcome: StepOutcome) -> StepRecord:
        """Return the record of a step that ended."""
        return StepRecord(step_index, step_count, step, outcome, float(self.time_optimal_bound),
                          float(self.insertion_error), float(self.residual_vibration))


def goal_feedback(goal: str, walk: Walk, sequencer, now: float) -> Feedback:
    """Return the feedback of the goal under way at ``now`` [s]."""
    step = sequencer.step if sequencer.busy else None
    return Feedback(goal, walk.step_index, len(walk.route), sequencer.phase,
                    sequencer.phase_progress(now), step.from_node if step else '',
                    step.to_node if step else '', float(sequencer.tip_error()) if step else 0.0)


def goal_ended(goal: str, walk: Walk, base: str, base_node: str,
               figures: StepFigures) -> GoalEnded:
    """Return the result of a goal whose walk is finished, its base and the base's node now.

    Succeeded when every step did; canceled when a cancel stopped it with no step failed;
    aborted otherwise, with the failed step's reason. A ``step`` goal carries its step's
    figures.
    """
    if walk.reached:
        status, message = 'succeeded', ''
    elif walk.cancel_requested and not walk.failed:
        status = 'canceled'
        message = f'cancelled after {walk.step_index} of {len(walk.route)} steps'
    else:
        status = 'aborted'
        message = walk.outcomes[-1].message if walk.failed else 'the walk did not finish'
    ended = GoalEnded(goal, status, message, sum(o.success for o in walk.outcomes),
                      float(sum(o.duration for o in walk.outcomes)), walk.path, base, base_node)
    if goal == 'step' and walk.outcomes:
        ended = dataclasses.replace(ended, step_duration=walk.outcomes[-1].duration,
                                    insertion_error=figures.insertion_error,
                                    time_optimal_bound=figures.time_optimal_bound)
    return ended


def phase_fields(record: PhaseRecord) -> dict:
    """Return the fields of ``walker_msgs/StepPhase`` (less its header) of a phase record.

    Plain values (``phase`` an int), as the node's message and a headless bag carry them.
    """
    return {'phase': int(record.phase), 'base_gripper': record.base_gripper,
            'reason': record.reason, 'phase_progress': float(record.phase_progress),
            'step_index': record.step_index, 'step_count': record.step_count,
            'from_node': record.from_node, 'to_node': record.to_node,
            'base_node': record.base_node, 'base_heading': float(record.base_heading)}


def report_fields(record: StepRecord) -> dict:
    """Return the fields of ``walker_msgs/StepReport`` (less its header) of a step record.

    Plain values in SI units (s, m, rad), as the node's message and a headless bag carry them.
    """
    step, outcome = record.step, record.outcome
    return {
        'step_index': record.step_index, 'step_count': record.step_count,
        'base_gripper': step.base_gripper, 'moving_gripper': step.moving_gripper,
        'base_node': step.base_node, 'from_node': step.from_node, 'to_node': step.to_node,
        'sweep': float(step.sweep), 'success': outcome.success, 'message': outcome.message,
        'phase_names': list(outcome.phase_durations),
        'phase_durations': [float(v) for v in outcome.phase_durations.values()],
        'duration': float(outcome.duration),
        'time_optimal_bound': float(record.time_optimal_bound),
        'bound_ratio': float(record.bound_ratio),
        'insertion_error': float(record.insertion_error),
        'insertion_error_estimated': float(outcome.insertion_error),
        'residual_vibration': float(record.residual_vibration),
        'insertion_attempts': outcome.insertion_attempts,
        'search_probes': outcome.search_probes, 'hole_offset': float(outcome.hole_offset)}
