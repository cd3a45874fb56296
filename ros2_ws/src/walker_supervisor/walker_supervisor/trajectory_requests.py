"""Turn the sequencer's trajectory requests into planner service requests (ROS layer).

Which of the planner's named trajectory types serves each purpose of a step (paper section 5):
extraction and insertion are straight lines along the hole axis, the coarse motion is the
bang-bang node-to-node trajectory, the fine motion a constant-velocity Cartesian line.
"""

from __future__ import annotations

from walker_msgs.srv import PlanTrajectory

from walker_core.joint_roles import roles_to_physical
from walker_core.kinematics import WalkerKinematics
from walker_supervisor.core.sequencer import TrajectoryRequest
from walker_supervisor.core.step_geometry import BaseFrame

__all__ = ['TRAJECTORY_TYPES', 'plan_request']

#: Planner trajectory type for each purpose, and whether it takes tip points (Cartesian).
TRAJECTORY_TYPES = {
    'extraction': ('extraction_line', True),
    'retry_lift': ('extraction_line', True),
    'coarse': ('bang_bang_node', False),
    'fine': ('cartesian_line', True),
    'insertion': ('insertion_line', True),
}


def plan_request(request: TrajectoryRequest, kinematics: WalkerKinematics,
                 frame: BaseFrame | None) -> PlanTrajectory.Request:
    """Build the ``plan_trajectory`` request for one motion of a step."""
    type_name, cartesian = TRAJECTORY_TYPES[request.purpose]
    call = PlanTrajectory.Request(trajectory_type=type_name, base_gripper=request.base_gripper)
    if cartesian:
        call.start = [float(v) for v in request.start_point]
        call.goal = [float(v) for v in request.goal_point]
    else:
        call.start = [float(v) for v in roles_to_physical(request.start, request.base_gripper)]
        call.goal = [float(v) for v in roles_to_physical(request.goal, request.base_gripper)]
    return call
