"""EXTRACTION: unscrew the moving gripper, lift it along the hole's axis (paper section 2).

The step starts with both grippers attached and no step under way; the controllers hold while
the moving gripper unscrews (a relaxation under way runs on). The step's targets rest on the
base frame measured from the stance; a screw-in bends the closed chain, which the controllers'
relaxation dither frees after it (``relaxation_wait``), so the frame is measured again once the
relaxation is over, while the gripper is still unscrewing and the chain still closed. The
extraction and coarse motions are then planned at once
(:class:`~walker_supervisor.core.commands.PrepareTrajectory`), so that they stream the moment
the gripper is free; the sweep streams with the lift, from ``sweep_lead`` before its end, once
its plan is back: the freed gripper waits at most ``sweep_lead`` for it, then lifts alone. The
lifted arm waits until it is within ``coarse_start_tolerance`` of the coarse motion's start.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np

from walker_core.gripper_state import GripperState
from walker_core.kinematics import KinematicsError
from walker_supervisor.core import transitions
from walker_supervisor.core.commands import (
    GripperRequest, Notice, PrepareTrajectory, SetControlMode, TrajectoryRequest)
from walker_supervisor.core.hole_search import HoleSearch
from walker_supervisor.core.phases import Phase, SequencerError, Stage
from walker_supervisor.core.route import PlannedStep
from walker_supervisor.core.step_geometry import StepTargets
from walker_supervisor.core.step_run import Looks, StepRun

__all__ = ['start', 'awaiting_plan', 'follow_unscrewing', 'lift_ended', 'coarse_when_there']


def start(run: StepRun, step: PlannedStep, targets: StepTargets, now: float,
          grippers: dict[str, str],
          remeasure: Callable[[np.ndarray], StepTargets] | None,
          search: HoleSearch | None = None) -> list:
    """Begin a step (see :meth:`StepSequencer.start`); raises SequencerError."""
    if run.busy:
        raise SequencerError(f'a step is already under way (phase {run.phase.name})')
    if run.phase == Phase.SAFE_HOLD:
        raise SequencerError(f'the walker is in SAFE_HOLD ({run.reason}): resume first')
    if step.base_gripper != run.base_gripper:
        raise SequencerError(f'the step pivots on gripper {step.base_gripper} but the base '
                             f'is gripper {run.base_gripper}')
    detached = sorted(g for g in ('a', 'b') if grippers.get(g) != GripperState.ATTACHED)
    if detached:
        raise SequencerError(f'a step starts only with both grippers attached; gripper '
                             f'{", ".join(detached)} is not')
    run.step, run.targets, run.grippers = step, targets, dict(grippers)
    run.theta = targets.start.copy()
    run.step_started = now
    run.durations = {}
    run.motions.planned_ahead, run.motions.asked_ahead = set(), set()
    run.tries.insertions = run.tries.fine_lines = 0
    run.tries.insertion_error = math.nan
    run.search, run.estimate, run.height_shift = search, None, 0.0
    run.looks = Looks(due=run.camera and run.parameters.max_looks > 0)
    run.search_over = ''
    run.outcome = None
    run.reason = ''
    run.remeasure = remeasure if now < run.relaxed_at else None
    run.enter(Phase.EXTRACTION, now, Stage.UNSCREWING)
    run.deadline = math.inf
    run.gripper.deadline = now + run.gripper.allowance
    run.gripper.answers_due += 1
    commands = [SetControlMode('hold', step.base_gripper),
                GripperRequest(step.moving_gripper, 'unscrew')]
    return commands + ([] if run.remeasure is not None else _prepare(run))


def awaiting_plan(run: StepRun) -> bool:
    """Return True while the freed gripper's lift waits for the sweep's plan (``sweep_lead``)."""
    motions = run.motions
    return run.stage == Stage.UNSCREWING and run.gripper.free_since is not None \
        and 'coarse' in motions.asked_ahead and 'coarse' not in motions.planned_ahead


def follow_unscrewing(run: StepRun, now: float, state: str) -> list:
    """Take the moving gripper's reported state while it unscrews."""
    commands = _measure_stance_again(run, state, now)
    if state == GripperState.FREE:
        return commands + _unscrewed(run, now)
    if now > run.gripper.deadline:
        return commands + run.abort(f'gripper {run.step.moving_gripper} did not unscrew in '
                                    f'time (it reports {state or "nothing"})', now)
    return commands


def lift_ended(run: StepRun, now: float) -> list:
    """Take the end of the lift's stream: the sweep ended too, or COARSE starts next tick."""
    if run.motions.lift_ends is not None:
        # the sweep streamed with the lift has ended before a tick saw the lift end
        run.enter(Phase.COARSE, now, Stage.ARRIVING)
        run.deadline = now + run.parameters.phase_timeout
        return []
    run.stage = Stage.LIFTED  # the next tick, with fresh joints, starts the coarse motion
    run.deadline = now + run.parameters.phase_timeout
    return []


def coarse_when_there(run: StepRun, now: float) -> list:
    """Enter COARSE once every joint is within ``coarse_start_tolerance`` of its start.

    The extraction line's stream may end before a lagging joint (late efforts, friction)
    has followed it; the planner refuses a coarse motion that starts far from the joints.
    """
    gap = float(np.max(np.abs(run.theta - run.targets.above_from)))
    if gap <= run.parameters.coarse_start_tolerance:
        return transitions.enter_coarse(run, now)
    return []


def _sweep_plan_due(run: StepRun, now: float) -> bool:
    """Return True while the lift should wait for the sweep's plan, asked ahead.

    Streamed with the lift, the sweep saves ``sweep_lead``; so the lift waits for its plan
    at most that long after the gripper is free (a plan asked late, after a relaxation,
    on a loaded machine), and then streams alone. The wait is counted on the clock the
    ticks come with (simulated time in sim time; the node bounds its clock hold on the
    wall clock, :class:`~walker_supervisor.core.decision_clock.DecisionClock`).
    """
    motions = run.motions
    if run.parameters.sweep_lead <= 0.0 or 'coarse' in motions.planned_ahead \
            or 'coarse' not in motions.asked_ahead:
        return False
    if run.gripper.free_since is None:
        run.gripper.free_since = now
    return now - run.gripper.free_since < run.parameters.sweep_lead


def _unscrewed(run: StepRun, now: float) -> list:
    if _sweep_plan_due(run, now):
        return []
    run.gripper.free_since = None
    run.stage = Stage.LIFTING
    run.remeasure = None  # too late: the chain is open
    request = _extraction_request(run)
    if 'coarse' in run.motions.planned_ahead:
        # the sweep streams with the lift, overlapping; only with the coarse motion's plan
        # already back, so the lift does not wait for it
        request = _lift_with_sweep(run, request)
    return [run.issue(request)]


def _extraction_request(run: StepRun) -> TrajectoryRequest:
    t = run.targets
    return run.request('extraction', t.start, t.above_from, run.kinematics.forward(t.start)[:3],
                       t.point_above_from)


def _prepare(run: StepRun) -> list:
    """Plan the extraction and the coarse motion ahead: the targets are final.

    The extraction is asked for as it will stream once both plans are back: with the sweep
    from ``sweep_lead`` before its end, so the two can be joined ahead too.
    """
    run.motions.planned_ahead, run.motions.asked_ahead = set(), {'extraction', 'coarse'}
    return [PrepareTrajectory(_lift_with_sweep(run, _extraction_request(run))),
            PrepareTrajectory(transitions.coarse_request(run))]


def _lift_with_sweep(run: StepRun, extraction: TrajectoryRequest) -> TrajectoryRequest:
    """Return the extraction streamed with the coarse motion (``sweep_lead`` > 0)."""
    if run.parameters.sweep_lead <= 0.0:
        return extraction
    # the controllers in COARSE mode from the start: acceleration feedback on joint 1 as its
    # sweep begins
    return dataclasses.replace(extraction, then=transitions.coarse_request(run),
                               lead=run.parameters.sweep_lead, mode='coarse')


def _measure_stance_again(run: StepRun, state: str, now: float) -> list:
    """Once relaxed, with the chain still closed: the targets from the joints now."""
    if run.remeasure is None or state == GripperState.FREE or now < run.relaxed_at:
        return []
    remeasure, run.remeasure = run.remeasure, None
    try:
        run.targets = remeasure(run.theta.copy())
    except KinematicsError as error:
        return [Notice(f'the stance measured after the relaxation gives no targets ({error}); '
                       f'the step goes on with those from its start')] + _prepare(run)
    return _prepare(run)
