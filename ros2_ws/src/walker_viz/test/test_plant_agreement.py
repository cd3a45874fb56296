"""TF's tree against the simulated plant itself: the grippers where pybullet has them.

The plant's links bend (18 rad/s out of the arm plane): a yaw torque step swings the free
gripper and bends the links by millimetres. The tree of the flexible URDF view, from the
plant's five joint angles and its bending angles (what ``flexible_joint_states`` carries),
anchored at the base gripper's node and heading, must put both
grippers where pybullet has them; straight links would not.
"""

import math

import numpy as np
import pytest

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_core.robot_parameters import load_walker_parameters
from walker_core.truss import Truss
from walker_core.urdf import GRIPPER_LINKS, flex_joints, robot_urdf
from walker_sim.core.config import StartConfiguration, load_sim_parameters
from walker_sim.core.plant import WalkerPlant
from walker_viz.core.base_anchor import BaseTracker
from walker_viz.core.robot_tree import RobotTree

PARAMS = load_walker_parameters()
SIM = load_sim_parameters()
TRUSS = Truss.from_parameters(PARAMS)
BENDS = [j.name for j in flex_joints(PARAMS.robot.flexibility.segments_per_link)]
PERIOD = 1.0 / PARAMS.timing.control_rate


def angles_of(state, bending) -> dict[str, float]:
    return {**dict(zip(PHYSICAL_JOINT_NAMES, state.position, strict=True)),
            **dict(zip(BENDS, bending, strict=True))}


@pytest.fixture(scope='module')
def swung():
    """Gripper a screwed into n1_1, b free above n2_1, swung by a yaw torque for 0.3 s."""
    start = StartConfiguration(base_gripper='a', base_node=SIM.start.base_node,
                               other_node=SIM.start.other_node, other_attached=False,
                               other_height=0.03)
    with WalkerPlant(PARAMS, SIM) as plant:
        plant.reset(start)
        limit = PARAMS.robot.drive.for_role(1).torque_limit
        samples = []
        for k in range(150):
            state = plant.step([0.5 * limit if k < 100 else -0.5 * limit, 0, 0, 0, 0],
                               PERIOD)
            samples.append((state, plant.bending()))
        yield samples


@pytest.mark.parametrize('flexible, within', [(True, 1e-5), (False, None)])
def test_the_tree_puts_each_gripper_where_the_plant_has_it(swung, flexible, within):
    tree = RobotTree(robot_urdf(PARAMS, flexible=flexible, rotors=False))
    tracker = BaseTracker(tree, TRUSS)
    tracker.set_attached({'a': SIM.start.base_node})
    worst = 0.0
    for state, bending in swung:
        angles = angles_of(state, bending)
        root = tracker.root_pose(angles)
        for gripper in ('a', 'b'):
            pose = root @ tree.link_in_root(GRIPPER_LINKS[gripper], angles)
            worst = max(worst, float(np.linalg.norm(
                pose[:3, 3] - state.poses[gripper].position)))
    bent = max(float(np.max(np.abs(b))) for _, b in swung)
    assert bent > 1e-4, 'the swing bends the links'
    if within is not None:
        assert worst < within, f'{worst * 1e3:.4f} mm'
    else:  # straight links miss the swinging gripper by more than the 1 mm a user needs
        assert worst > 1e-3, f'{worst * 1e3:.4f} mm'


def test_the_base_heading_is_the_plants_seat_yaw():
    """Both screwed in: the heading measured from the stance is the base gripper's yaw."""
    with WalkerPlant(PARAMS, SIM) as plant:
        state = plant.reset()
        tree = RobotTree(robot_urdf(PARAMS, flexible=True, rotors=False))
        tracker = BaseTracker(tree, TRUSS)
        tracker.set_attached({'a': SIM.start.base_node, 'b': SIM.start.other_node})
        anchor = tracker.anchor(angles_of(state, plant.bending()))
        rotation = state.poses['a'].matrix()[:3, :3]
        assert math.isclose(anchor.heading, math.atan2(rotation[1, 0], rotation[0, 0]),
                            abs_tol=1e-6)
