"""INSERTION: down the hole's axis, settle at the mouth, screw in (paper section 2).

Insertion descends along the hole axis to its mouth (a descent whose tip leaves the axis by more
than ``descent_axis_tolerance`` is stopped and the gripper lifted straight back to the approach
height, to come over the hole again: an insertion attempt, as a jam is; stopped before it went
``descent_region`` down, there is nothing to lift and a fine line brings it over the hole). The
descent moves the joints, which stop in their friction again, so once they have been still for
``mouth_settle_time`` (the vertical descent hardly moves joint 1; after a line at the mouth,
which does, for ``settle_time``) the tip is checked again, now across the hole's axis: more than
``insertion_alignment`` off it, a fine line at the mouth takes it there (up to
:data:`~walker_supervisor.core.transitions.MAX_FINE_LINES` times; more than
``descent_axis_tolerance`` off, the gripper is lifted back instead), and only then is the
gripper screwed in. A jammed screw-in is retried up to ``max_insertion_attempts`` times (each
lift goes straight up from where the gripper jammed), then the step is aborted to SAFE_HOLD. A
step ends when the gripper reports attached, with the controllers commanded to HOLD under the
new base (which starts their relaxation).
"""

from __future__ import annotations

import math

import numpy as np

from walker_supervisor.core import transitions
from walker_supervisor.core.commands import (
    CancelTrajectory, GripperRequest, Notice, SetControlMode)
from walker_supervisor.core.phases import Phase, Stage, StepOutcome
from walker_supervisor.core.step_run import StepRun

__all__ = ['MAX_MOUTH_LINES', 'at_mouth', 'left_the_axis', 'jammed', 'follow_screwing']

#: Fine lines at the mouth tried before the gripper is screwed in anyway (as above the hole).
MAX_MOUTH_LINES = 3


def settle_wait(run: StepRun) -> float:
    """How long [s] the joints must be still at the mouth before the tip is judged.

    ``mouth_settle_time`` after the descent, which moves joint 1 hardly at all; after a line at
    the mouth, which moves joint 1 (it comes in behind its filter slowly enough to look still
    for a moment), ``settle_time``.
    """
    if run.tries.mouth_lines == 0:
        return run.parameters.mouth_settle_time
    return run.parameters.settle_time


def at_mouth(run: StepRun, now: float, velocities: np.ndarray, grippers: dict[str, str]) -> list:
    """Settled at the mouth: check the tip across the axis, then align it or screw in."""
    if not run.settled(now, velocities, settle_wait(run)):
        return []
    parameters = run.parameters
    if run.mouth_offset() > parameters.descent_axis_tolerance:
        return left_the_axis(run, now)  # too far to slide at the mouth's height
    if run.mouth_offset() > parameters.insertion_alignment \
            and run.tries.mouth_lines < MAX_MOUTH_LINES:
        return _align(run)
    run.stage = Stage.SCREWING
    run.tries.insertion_error = run.mouth_offset()  # the same moment as the plant's
    run.deadline = math.inf
    run.gripper.deadline = now + run.gripper.allowance
    run.gripper.answers_due += 1
    # a retry starts from 'jammed': that report is the last attempt's, not this one's
    run.gripper.state_before_screwing = grippers.get(run.step.moving_gripper, '')
    return [GripperRequest(run.step.moving_gripper, 'screw_in')]


def _align(run: StepRun) -> list:
    """Run a fine line at the mouth, from where the tip settled onto the hole's axis."""
    run.tries.mouth_lines += 1
    run.stage = Stage.ALIGNING
    return [run.trajectory('fine', run.theta, run.targets.at_to, run.tip(),
                           run.targets.point_to)]


def left_the_axis(run: StepRun, now: float) -> list:
    """Stop a descent whose tip has left the hole's axis; lift it straight back up.

    Lowered farther, the gripper would meet the node's face beside the hole. Like a jam it
    counts as an insertion attempt: the gripper rises from where it is to the approach height,
    FINE brings it over the hole again, and a new descent starts.
    """
    offset = run.mouth_offset()
    run.tries.insertions += 1
    reason = (f"the descent left the hole's axis ({offset * 1e3:.1f} mm off, tolerance "
              f'{run.parameters.descent_axis_tolerance * 1e3:.1f} mm)')
    if run.tries.insertions >= run.parameters.max_insertion_attempts:
        return run.abort(f'{reason}; {run.tries.insertions} insertion attempts', now)
    below = _below_the_approach(run)
    up = run.straight_up(run.targets.point_above_to) if below else None
    if below and up is None:
        return run.abort(f'{reason}, and no straight lift from here', now)
    stop = [CancelTrajectory()] if run.motions.running else []
    run.motions.running = False
    if not below:
        # stopped before it went down (the stream had only begun): nothing to lift out of,
        # a fine line from where the tip is brings it over the hole
        run.tries.fine_lines = 0
        return stop + [Notice(f'{reason} before it went down: brought over the hole again')] \
            + transitions.enter_fine(run, now, correction=True)
    run.stage = Stage.RETRY_LIFT
    return stop + [Notice(f'{reason}: lifted back to come over the hole again'),
                   run.trajectory('retry_lift', run.theta, up[0], run.tip(), up[1])]


def _below_the_approach(run: StepRun) -> bool:
    """Return True if the tip is more than ``descent_region`` [m] below the approach height.

    Only then is there a straight lift to make: the planner's extraction line must rise.
    """
    height = run.targets.point_above_to[2] - run.tip()[2]
    return height > run.parameters.descent_region


def jammed(run: StepRun, message: str, now: float) -> list:
    """Take a jammed screw-in: lift straight back up to try again, or stop after the last."""
    run.tries.insertions += 1
    if run.tries.insertions >= run.parameters.max_insertion_attempts:
        return run.abort(f'insertion jammed {run.tries.insertions} times: {message}', now)
    run.stage = Stage.RETRY_LIFT
    up = run.straight_up(run.targets.point_above_to)
    if up is None:
        return run.abort(f'insertion jammed: {message}; and no straight lift out of the hole '
                         f'from here', now)
    return [run.trajectory('retry_lift', run.theta, up[0], run.tip(), up[1])]


def follow_screwing(run: StepRun, now: float, state: str) -> list:
    """Take the moving gripper's reported state while it screws in."""
    watch = run.gripper
    if state != watch.state_before_screwing:
        watch.state_before_screwing = None  # the gripper has reported on this attempt
    if state == 'attached':
        return _finish(run, now)
    if state == 'jammed' and watch.state_before_screwing is None:
        return jammed(run, 'the screw-in jammed', now)
    if now > watch.deadline:
        return run.abort(f'gripper {run.step.moving_gripper} did not screw in in time (it '
                         f'reports {state or "nothing"})', now)
    return []


def _finish(run: StepRun, now: float) -> list:
    """Screwed in: the step ends, HOLD under the new base, whose controllers relax the chain.

    The hole drew the gripper onto its axis while the joints stayed in their friction: the
    links are bent, and the joint angles would misplace the base frame of the next step by the
    bend (about a millimetre at the tip). The controllers' relaxation dither, started by this
    base change, lets the joints slide out of it by ``relaxed_at``; the next step measures its
    stance again after that.
    """
    run.relaxed_at = now + run.parameters.relaxation_wait
    run.enter(Phase.IDLE, now, Stage.NONE)
    run.grippers[run.step.moving_gripper] = 'attached'
    run.base_gripper = run.step.moving_gripper
    run.outcome = StepOutcome(True, '', dict(run.durations), now - run.step_started,
                              run.tries.insertion_error, run.tries.insertions + 1)
    run.outcome_taken = False
    return [SetControlMode('hold', run.step.moving_gripper)]
