"""Which planner request serves each motion the sequencer asks for (free of ROS).

Which of the planner's named trajectory types serves each purpose of a step (paper section 5):
extraction and insertion are straight lines along the hole axis, the coarse motion is the
bang-bang node-to-node trajectory, the fine motion a constant-velocity Cartesian line; a step
resumed after a safe hold recovers to the point above its target with a Cartesian blend (or,
where the arm cannot follow a straight tip line, a minimum-jerk joint move). An
operator's joint jog is a minimum-jerk joint move, a tip jog a constant-velocity Cartesian line.

:func:`planner_request` builds the planner core's :class:`~walker_planner.core.planning.
PlanRequest`: the supervisor node sends it as ``plan_trajectory``
(:mod:`walker_supervisor.trajectory_requests`), the headless loop plans it directly.
"""

from __future__ import annotations

import math

from walker_core.joint_roles import roles_to_physical
from walker_core.kinematics import WalkerKinematics
from walker_planner.core.planning import PlanRequest
from walker_supervisor.core.sequencer import TrajectoryRequest
from walker_supervisor.core.way_back import vertical_configuration

__all__ = ['TRAJECTORY_TYPES', 'planner_request']

#: Planner trajectory type for each purpose, and whether it takes tip points (Cartesian).
TRAJECTORY_TYPES = {
    'extraction': ('extraction_line', True),
    'retry_lift': ('extraction_line', True),
    'coarse': ('bang_bang_node', True),
    'fine': ('cartesian_line', True),
    'insertion': ('insertion_line', True),
    'recover': ('cartesian_parabolic_accel', True),
    # back to above the target where no straight tip line is followable (core/way_back.py)
    'recover_joint': ('joint_min_jerk', False),
    # the gripper turned vertical where it is, before a way back that is a line
    'upright': ('joint_min_jerk', False),
    'jog_joint': ('joint_min_jerk', False),  # teleoperation (core/teleop.py)
    'jog_tip': ('cartesian_line', True),
}
#: Motions that start where the joints are now (the others start at a planned point).
_FROM_MEASURED = frozenset({'fine', 'retry_lift', 'recover', 'jog_tip'})


def planner_request(request: TrajectoryRequest, kinematics: WalkerKinematics) -> PlanRequest:
    """Build the planner request for one motion of a step.

    A Cartesian motion of :data:`_FROM_MEASURED` starts from the measured joints made exact:
    the tip where their forward kinematics puts it, the gripper vertical, on their IK branch and
    with their tip yaw, so the planner's first setpoint is where the joints are and nothing
    jumps. The others (extraction, coarse motion, descent) start at their planned point, on the
    IK branch and tip yaw of the request's start joints. Joint vectors are in physical order.
    """
    type_name, cartesian = TRAJECTORY_TYPES[request.purpose]
    base = request.base_gripper
    if not cartesian:
        return PlanRequest(
            type_name, base,
            start=tuple(float(v) for v in roles_to_physical(request.start, base)),
            goal=tuple(float(v) for v in roles_to_physical(request.goal, base)))
    start = kinematics.forward(request.start)[:3] if request.purpose in _FROM_MEASURED \
        else request.start_point
    joints = vertical_configuration(kinematics, start, request.start)
    sweep_direction = 0
    if type_name == 'bang_bang_node' and abs(abs(request.sweep) - math.pi) < 1e-6:
        sweep_direction = 1 if request.sweep > 0 else -1
    return PlanRequest(
        type_name, base, start=tuple(float(v) for v in start),
        goal=tuple(float(v) for v in request.goal_point),
        start_joints=tuple(float(v) for v in roles_to_physical(joints, base)),
        sweep_direction=sweep_direction)
