"""Which planner request serves each motion of a step (paper section 5), free of ROS.

Extraction and insertion are straight lines along the hole axis, the coarse motion is the
bang-bang node-to-node trajectory, the fine motion a constant-velocity Cartesian line; a step
resumed after a safe hold recovers to the point above its target with a Cartesian blend (or,
where the arm cannot follow a straight tip line, a minimum-jerk joint move). An operator's
joint jog is a minimum-jerk joint move, a tip jog a constant-velocity Cartesian line.

The request is the planner core's own (:class:`walker_planner.core.planning.PlanRequest`): the
graph sends it as ``walker_msgs/srv/PlanTrajectory``, a headless loop hands it to
:func:`walker_planner.core.planning.plan` as it is.
"""

from __future__ import annotations

import dataclasses
import math

from walker_core.joint_roles import roles_to_physical
from walker_core.kinematics import WalkerKinematics
from walker_planner.core.planning import PlanRequest
from walker_supervisor.core.commands import TrajectoryRequest
from walker_supervisor.core.way_back import vertical_configuration

__all__ = ['TRAJECTORY_TYPES', 'planner_call']

#: Planner trajectory type for each purpose, and whether it takes tip points (Cartesian).
TRAJECTORY_TYPES = {
    'extraction': ('extraction_line', True),
    'retry_lift': ('extraction_line', True),
    # up the gripper's axis, for a look at the hole from higher (core/looking.py)
    'look_lift': ('extraction_line', True),
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
_FROM_MEASURED = frozenset({'fine', 'retry_lift', 'look_lift', 'recover', 'jog_tip'})


def planner_call(request: TrajectoryRequest, kinematics: WalkerKinematics,
                 max_velocity: float = 0.0) -> PlanRequest:
    """Return the planner's request for one motion.

    A Cartesian motion of :data:`_FROM_MEASURED` starts from the measured joints made exact:
    the tip where their forward kinematics puts it, the gripper vertical, on their IK branch and
    with their tip yaw, so the planner's first setpoint is where the joints are and nothing
    jumps. The others (extraction, coarse motion, descent) start at their planned point, on the
    IK branch and tip yaw of the request's start joints.

    Parameters
    ----------
    request : TrajectoryRequest
        The motion (joint angles in role order [rad], tip points in the base frame [m]).
    kinematics : WalkerKinematics
    max_velocity : float
        [rad/s or m/s] speed limit of the motion (0: the planner's parameter file's).

    Returns
    -------
    PlanRequest
        Joint angles in physical order [rad], tip points [m].
    """
    type_name, cartesian = TRAJECTORY_TYPES[request.purpose]
    call = PlanRequest(trajectory_type=type_name, base_gripper=request.base_gripper,
                       max_velocity=float(max_velocity))
    if not cartesian:
        return dataclasses.replace(
            call, start=_floats(roles_to_physical(request.start, request.base_gripper)),
            goal=_floats(roles_to_physical(request.goal, request.base_gripper)))
    start = kinematics.forward(request.start)[:3] if request.purpose in _FROM_MEASURED \
        else request.start_point
    joints = vertical_configuration(kinematics, start, request.start)
    direction = 0
    if type_name == 'bang_bang_node' and abs(abs(request.sweep) - math.pi) < 1e-6:
        direction = 1 if request.sweep > 0 else -1
    return dataclasses.replace(
        call, start=_floats(start), goal=_floats(request.goal_point),
        start_joints=_floats(roles_to_physical(joints, request.base_gripper)),
        sweep_direction=direction)


def _floats(values) -> tuple[float, ...]:
    return tuple(float(v) for v in values)
