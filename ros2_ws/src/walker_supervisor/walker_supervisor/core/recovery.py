"""Leaving SAFE_HOLD, and the way back above the target from wherever the arm is.

:func:`resume` leaves SAFE_HOLD: with both grippers attached it returns to IDLE; with the moving
gripper free it completes the interrupted step from where the arm is (straight up out of the
hole it was leaving if it is still in it, then to the point above the target, settling,
insertion). A step whose search for the hole has ended without it is not resumed: the same
probes would jam again, so the hold stays for an operator to jog the gripper over the hole. The
way back above the target is a straight tip line where the arm can follow one,
else a joint-space line that keeps the tip above the truss
(:mod:`walker_supervisor.core.way_back`), also when the planner refuses the tip line; with
neither, resume is refused and nothing changes. A fine line (:mod:`.approach`) goes the same
way.
"""

from __future__ import annotations

import numpy as np

from walker_core.gripper_state import TURNING, GripperState
from walker_supervisor.core.commands import SetControlMode, TrajectoryRequest
from walker_supervisor.core.phases import Phase, SequencerError, Stage
from walker_supervisor.core.step_run import StepRun
from walker_supervisor.core.way_back import (
    line_is_followable, lowest_tip_height, vertical_configuration)

__all__ = ['resume', 'way_back_purpose', 'way_back', 'joint_way_is_clear', 'no_way_back']


def resume(run: StepRun, now: float, theta_roles: np.ndarray, grippers: dict[str, str],
           nodes: dict[str, str]) -> list:
    """Leave SAFE_HOLD (see :meth:`StepSequencer.resume`); raises SequencerError."""
    if run.phase != Phase.SAFE_HOLD:
        raise SequencerError(f'not in SAFE_HOLD (phase {run.phase.name})')
    run.theta = np.asarray(theta_roles, dtype=float)
    run.grippers = dict(grippers)
    busy = sorted(g for g, s in grippers.items() if s in TURNING)
    if busy:
        raise SequencerError(f'gripper {", ".join(busy)} is still {grippers[busy[0]]}: resume '
                             f'once it has finished')
    if all(grippers.get(g) == GripperState.ATTACHED for g in ('a', 'b')):
        step = run.step
        if step is not None and nodes.get(step.moving_gripper) == step.to_node \
                and run.base_gripper != step.moving_gripper:
            run.base_gripper = step.moving_gripper  # the step got as far as screwing in
            # the HOLD under the new base relaxes the chain: no stance before it is over
            run.relaxed_at = now + run.parameters.relaxation_wait
        run.phase, run.stage, run.reason = Phase.IDLE, Stage.NONE, ''
        return [SetControlMode('hold', run.base_gripper)]
    if grippers.get(run.base_gripper) != GripperState.ATTACHED:
        raise SequencerError(f'the base gripper {run.base_gripper} is not attached: nothing '
                             f'can move safely')
    if run.step is None or run.targets is None:
        raise SequencerError('the free gripper has no step to complete: jog it over a node and '
                             'screw it in')
    if run.search_over:
        raise SequencerError(f'{run.search_over}: resume does not try the same places again; '
                             f'jog the gripper over the hole and screw it in')
    tip, above_from = run.tip(), run.targets.point_above_from
    in_hole = (tip[2] < 0.5 * above_from[2] and np.linalg.norm(tip[:2] - above_from[:2])
               < run.parameters.coarse_to_fine_region)
    way = None if in_hole else way_back_purpose(run, 'recover')
    if not in_hole and way is None:
        raise SequencerError(no_way_back(run))
    up = run.straight_up(above_from) if in_hole else None
    if in_hole and up is None:
        raise SequencerError('no straight lift out of the hole from here: jog the arm')
    run.reason = ''
    run.tries.fine_lines = run.tries.insertions = 0
    run.step_started = now
    run.durations = {}
    if in_hole:  # still in (or at) the hole it was leaving: out along the axis first
        run.enter(Phase.EXTRACTION, now, Stage.LIFTING)
        return [SetControlMode('fine', run.step.base_gripper),
                run.trajectory('extraction', run.theta, up[0], tip, up[1])]
    run.enter(Phase.FINE, now, Stage.MOVING)
    return [SetControlMode('fine', run.step.base_gripper), way_back(run, way)]


def way_back_purpose(run: StepRun, line: str) -> str | None:
    """How to go from the measured joints to above the target (None: no safe way).

    ``line`` (a Cartesian line: 'fine' or 'recover') where the arm can follow one; else
    ``recover_joint`` (a joint-space line) if the tip stays at least half the approach height
    above the truss along it. A line starts with the gripper vertical: with the gripper tilted
    by more than ``coarse_start_tolerance`` of joint angle (a fault at the hole's mouth),
    ``upright`` first turns it vertical where it is, and the line follows as a correction.
    """
    if line_is_followable(run.kinematics, run.theta, run.targets.point_above_to):
        if float(np.max(np.abs(_upright(run) - run.theta))) \
                > run.parameters.coarse_start_tolerance:
            return 'upright'
        return line
    return 'recover_joint' if joint_way_is_clear(run) else None


def way_back(run: StepRun, purpose: str) -> TrajectoryRequest:
    """Ask for the way back of ``purpose`` (:func:`way_back_purpose`) from the joints now."""
    tip = run.tip()
    if purpose == 'upright':  # the tip stays where it is
        return run.trajectory(purpose, run.theta, _upright(run), tip, tip)
    return run.trajectory(purpose, run.theta, run.targets.above_to, tip,
                          run.targets.point_above_to)


def joint_way_is_clear(run: StepRun) -> bool:
    """Return True if the joint-space line to above the target keeps the tip up."""
    t = run.targets
    floor = t.point_to[2] + 0.5 * (t.point_above_to[2] - t.point_to[2])
    return lowest_tip_height(run.kinematics, run.theta, t.above_to) >= floor


def no_way_back(run: StepRun) -> str:
    """Say why there is no way back above the target from here."""
    tip = run.tip()
    return (f'no safe way back above {run.step.to_node} from here (tip at ({tip[0]:+.3f}, '
            f'{tip[1]:+.3f}, {tip[2]:+.3f}) m in the base frame): neither a straight tip line '
            f'nor a joint-space line keeps the arm in its workspace and above the truss; jog '
            f'the arm nearer and resume')


def _upright(run: StepRun) -> np.ndarray:
    """Joints with the tip where it is and the gripper vertical (a line's first point)."""
    return vertical_configuration(run.kinematics, run.tip(), run.theta)
