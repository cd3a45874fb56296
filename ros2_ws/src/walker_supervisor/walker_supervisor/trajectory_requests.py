"""Turn the sequencer's trajectory requests into planner service requests (ROS layer).

Which trajectory type serves each motion, and from where it starts, is decided in
:mod:`walker_supervisor.core.plan_requests`; this module only converts its answer into the
``plan_trajectory`` request.
"""

from __future__ import annotations

from walker_msgs.srv import PlanTrajectory

from walker_core.kinematics import WalkerKinematics
from walker_supervisor.core.plan_requests import TRAJECTORY_TYPES, planner_request
from walker_supervisor.core.sequencer import TrajectoryRequest

__all__ = ['TRAJECTORY_TYPES', 'plan_request']


def plan_request(request: TrajectoryRequest, kinematics: WalkerKinematics
                 ) -> PlanTrajectory.Request:
    """Build the ``plan_trajectory`` request for one motion of a step."""
    planned = planner_request(request, kinematics)
    return PlanTrajectory.Request(
        trajectory_type=planned.trajectory_type, base_gripper=planned.base_gripper,
        start=list(planned.start), goal=list(planned.goal),
        start_joints=list(planned.start_joints), sweep_direction=planned.sweep_direction)
