"""Every entry into a step's phase after the extraction: the one owner of the transitions.

The phase modules (:mod:`.extraction`, :mod:`.approach`, :mod:`.insertion`) decide *when* a
step goes on to its next phase, and call the entry here; an entry sets the phase and its first
stage, and returns the commands that start it (the controllers' mode, the motion asked of the
planner). Keeping them in one module that imports no phase module keeps the phases from
calling each other: COARSE (:func:`enter_coarse`) after the extraction, FINE
(:func:`enter_fine`) from COARSE, after a lift back out of the hole or a descent stopped before
it went down, INSERTION (:func:`enter_insertion`) from FINE.
"""

from __future__ import annotations

import math

import numpy as np

from walker_core.kinematics import KinematicsError
from walker_supervisor.core import recovery
from walker_supervisor.core.commands import PrepareTrajectory, SetControlMode, TrajectoryRequest
from walker_supervisor.core.descent_contact import DescentContact
from walker_supervisor.core.phases import Phase, Stage
from walker_supervisor.core.step_run import StepRun

__all__ = ['MAX_FINE_LINES', 'PREPARED_DESCENT_TOLERANCE', 'coarse_request', 'descent_goal',
           'descent_request', 'enter_coarse', 'enter_fine', 'enter_insertion']

#: Fine correction lines tried before insertion is attempted anyway.
MAX_FINE_LINES = 3
#: [rad] The descent planned ahead (on entering FINE) starts at the configuration above the
#: hole; joints farther than this from it (any joint) descend from where they are instead.
PREPARED_DESCENT_TOLERANCE = 0.02


def coarse_request(run: StepRun) -> TrajectoryRequest:
    """Return the coarse motion: the node-to-node sweep to above the target hole."""
    t = run.targets
    joints, point = t.coarse_goal
    return run.request('coarse', t.above_from, joints, t.point_above_from, point, t.sweep)


def enter_coarse(run: StepRun, now: float) -> list:
    """Enter COARSE: the controllers in COARSE mode, the sweep asked for."""
    run.enter(Phase.COARSE, now, Stage.MOVING)
    return [SetControlMode('coarse', run.step.base_gripper), run.issue(coarse_request(run))]


def enter_fine(run: StepRun, now: float, correction: bool) -> list:
    """Switch the controllers to FINE; with ``correction``, also run a fine line.

    Without a correction the coarse trajectory (if still streaming) runs on to its end, the
    point above the hole; a correction starts from where the joints have settled.
    """
    commands = []
    if run.phase != Phase.FINE:
        running = run.motions.running
        run.enter(Phase.FINE, now, Stage.ARRIVING if running else Stage.SETTLING)
        run.deadline = run.deadline if running else now + run.parameters.phase_timeout
        commands.append(SetControlMode('fine', run.step.base_gripper))
        # the descent starts where every fine motion ends: plan it now, stream it when due
        commands.append(PrepareTrajectory(descent_request(run)))
    if not correction:
        return commands
    run.tries.fine_lines += 1
    run.stage = Stage.MOVING
    purpose = recovery.way_back_purpose(run, 'fine')
    if purpose is None:
        return commands + run.abort(recovery.no_way_back(run), now)
    return commands + [recovery.way_back(run, purpose)]


def descent_goal(run: StepRun) -> tuple[np.ndarray, np.ndarray]:
    """Return the joints [rad] and the point [m] a descent is commanded to.

    ``insertion_overtravel`` below the hole's nominal mouth on its axis, the tip vertical and
    its yaw as at the mouth: the node's face stops the gripper before it, wherever the node
    really is within that much. The nominal mouth if that point is out of reach.
    """
    t = run.targets
    overtravel = run.parameters.insertion_overtravel
    if overtravel <= 0.0:
        return t.at_to, t.point_to
    point = t.point_to - np.array([0.0, 0.0, overtravel])
    try:
        joints = run.kinematics.inverse([*point, 0.0, t.at_to[4]], reference=t.at_to)
    except KinematicsError:
        return t.at_to, t.point_to
    return np.asarray(joints, dtype=float), point


def descent_request(run: StepRun) -> TrajectoryRequest:
    """Return the descent: straight down the hole's axis from the point above it to contact.

    It starts at the configuration above the hole, where the coarse motion and every fine line
    leave the setpoints, so it can be planned on entering FINE and streamed the moment FINE
    ends; for joints farther than :data:`PREPARED_DESCENT_TOLERANCE` from it the same line is
    planned on their IK branch and tip yaw instead (:func:`enter_insertion`).
    """
    t = run.targets
    joints, point = descent_goal(run)
    return run.request('insertion', t.above_to, joints, t.point_above_to, point)


def enter_insertion(run: StepRun, now: float) -> list:
    """Enter INSERTION: the descent streams."""
    run.tries.insertion_error = run.tip_error()
    run.tries.mouth_lines, run.tries.mouth_offset_lined = 0, math.inf
    run.enter(Phase.INSERTION, now, Stage.DESCENDING)
    joints, point = descent_goal(run)
    run.tries.contact = DescentContact(float(run.targets.point_to[2]), float(point[2]))
    request = descent_request(run)
    if float(np.max(np.abs(run.theta - request.start))) > PREPARED_DESCENT_TOLERANCE:
        # not where the step's own motions leave the arm (a resumed step's way back turns the
        # wrist its own way): the same line down the axis, planned from the measured joints'
        # IK branch and tip yaw (the planner checks its first setpoint against them)
        t = run.targets
        request = run.request('insertion', run.theta, joints, t.point_above_to, point)
    return [run.issue(request)]
