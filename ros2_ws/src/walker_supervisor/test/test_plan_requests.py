"""Which planner request serves each motion of a step, and what the node sends of it."""

import math

import numpy as np
import pytest

from walker_core.joint_roles import roles_to_physical
from walker_core.kinematics import WalkerKinematics
from walker_core.robot_parameters import load_walker_parameters
from walker_supervisor.core.plan_requests import TRAJECTORY_TYPES, planner_request
from walker_supervisor.core.sequencer import TrajectoryRequest

KINEMATICS = WalkerKinematics.from_parameters(load_walker_parameters())
START = np.array([-math.pi / 2, 0.9, 1.3, 0.9, -math.pi / 2])  # roles, base b
GOAL = np.array([0.0, 0.8, 1.5, 0.8, 0.0])


def request(purpose, sweep=0.0):
    start_point = KINEMATICS.forward(START)[:3]
    goal_point = KINEMATICS.forward(GOAL)[:3]
    return TrajectoryRequest(purpose, START, GOAL, start_point, goal_point, sweep, 'b')


@pytest.mark.parametrize('purpose', sorted(TRAJECTORY_TYPES))
def test_every_purpose_asks_for_its_trajectory_type_in_physical_order(purpose):
    planned = planner_request(request(purpose), KINEMATICS)
    type_name, cartesian = TRAJECTORY_TYPES[purpose]
    assert planned.trajectory_type == type_name and planned.base_gripper == 'b'
    if cartesian:
        assert planned.goal == pytest.approx(KINEMATICS.forward(GOAL)[:3])
        assert len(planned.start_joints) == 5
        assert planned.start == pytest.approx(KINEMATICS.forward(START)[:3], abs=1e-9)
    else:
        assert planned.start == pytest.approx(roles_to_physical(START, 'b'))
        assert planned.goal == pytest.approx(roles_to_physical(GOAL, 'b'))
        assert planned.start_joints == ()


@pytest.mark.parametrize('sweep, direction', [(math.pi, 1), (-math.pi, -1),
                                              (math.pi / 2, 0)])
def test_a_half_turn_names_its_direction(sweep, direction):
    assert planner_request(request('coarse', sweep), KINEMATICS).sweep_direction == direction


def test_the_node_sends_the_same_request():
    from walker_supervisor.trajectory_requests import plan_request

    for purpose in TRAJECTORY_TYPES:
        planned = planner_request(request(purpose, math.pi), KINEMATICS)
        sent = plan_request(request(purpose, math.pi), KINEMATICS)
        assert sent.trajectory_type == planned.trajectory_type
        assert sent.base_gripper == planned.base_gripper
        assert tuple(sent.start) == planned.start and tuple(sent.goal) == planned.goal
        assert tuple(sent.start_joints) == planned.start_joints
        assert sent.sweep_direction == planned.sweep_direction
