"""Turn the sequencer's trajectory requests into planner service requests (ROS layer).

Which of the planner's named trajectory types serves each purpose of a step (paper section 5):
extraction and insertion are straight lines along the hole axis, the coarse motion is the
bang-bang node-to-node trajectory, the fine motion a constant-velocity Cartesian line; a step
resumed after a safe hold recovers to the point above its target with a Cartesian blend (or,
where the arm cannot follow a straight tip line, a minimum-jerk joint move). An
operator's joint jog is a minimum-jerk joint move, a tip jog a constant-velocity Cartesian line.
"""

from __future__ import annotations

import math

from walker_msgs.srv import PlanTrajectory

from walker_core.joint_roles import roles_to_physical
from walker_core.kinematics import WalkerKinematics
from walker_supervisor.core.sequencer import TrajectoryRequest
from walker_supervisor.core.way_back import vertical_configuration

__all__ = ['TRAJECTORY_TYPES', 'plan_request']

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


def plan_request(request: TrajectoryRequest, kinematics: WalkerKinematics
                 ) -> PlanTrajectory.Request:
    """Build the ``plan_trajectory`` request for one motion of a step.

    A Cartesian motion of :data:`_FROM_MEASURED` starts from the measured joints made exact:
    the tip where their forward kinematics puts it, the gripper vertical, on their IK branch and
    with their tip yaw, so the planner's first setpoint is where the joints are and nothing
    jumps. The others (extraction, coarse motion, descent) start at their planned point, on the
    IK branch and tip yaw of the request's start joints.
    """
    type_name, cartesian = TRAJECTORY_TYPES[request.purpose]
    call = PlanTrajectory.Request(trajectory_type=type_name, base_gripper=request.base_gripper)
    if cartesian:
        start = kinematics.forward(request.start)[:3] if request.purpose in _FROM_MEASURED \
            else request.start_point
        joints = vertical_configuration(kinematics, start, request.start)
        call.start = [float(v) for v in start]
        call.goal = [float(v) for v in request.goal_point]
        call.start_joints = [float(v) for v in roles_to_physical(joints, request.base_gripper)]
        if type_name == 'bang_bang_node' and abs(abs(request.sweep) - math.pi) < 1e-6:
            call.sweep_direction = 1 if request.sweep > 0 else -1
    else:
        call.start = [float(v) for v in roles_to_physical(request.start, request.base_gripper)]
        call.goal = [float(v) for v in roles_to_physical(request.goal, request.base_gripper)]
    return call
