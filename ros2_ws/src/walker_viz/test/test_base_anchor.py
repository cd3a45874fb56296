"""Where the tree sits in the truss: the base's node and heading, and no jump when it changes."""

import math

import numpy as np
import pytest

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_core.kinematics import WalkerKinematics
from walker_core.robot_parameters import load_walker_parameters
from walker_core.truss import Truss
from walker_core.urdf import description_urdf
from walker_viz.core.base_anchor import BaseTracker
from walker_viz.core.robot_tree import RobotTree

PARAMS = load_walker_parameters()
KIN = WalkerKinematics.from_parameters(PARAMS)
TRUSS = Truss.from_parameters(PARAMS)
TREE = RobotTree(description_urdf(PARAMS))
# [m, rad] the URDF's 9 significant digits against the kinematics' exact numbers


def stance(base_node: str, other_node: str, heading: float = 0.0) -> dict[str, float]:
    """Joint angles (gripper a as base) whose tip is exactly on ``other_node``.

    The base frame turned by ``heading``: the tip's direction in it is the nodes' direction
    turned back by ``heading``.
    """
    d = TRUSS.position(other_node) - TRUSS.position(base_node)
    c, s = math.cos(heading), math.sin(heading)
    local = [c * d[0] + s * d[1], -s * d[0] + c * d[1], 0.0, 0.0, 0.3]
    theta = KIN.inverse(local)
    return dict(zip(PHYSICAL_JOINT_NAMES, theta, strict=True))


def link_poses(tracker: BaseTracker, angles) -> dict[str, np.ndarray]:
    root = tracker.root_pose(angles)
    return {link: root @ TREE.link_in_root(link, angles) for link in TREE.links}


def test_both_grippers_are_drawn_on_their_nodes_in_a_closed_stance():
    angles = stance('n1_1', 'n2_1', heading=0.4)
    tracker = BaseTracker(TREE, TRUSS)
    tracker.set_attached({'a': 'n1_1', 'b': 'n2_1'})
    poses = link_poses(tracker, angles)
    assert np.allclose(poses['gripper_a'][:3, 3], TRUSS.position('n1_1'), atol=1e-8)
    assert np.allclose(poses['gripper_b'][:3, 3], TRUSS.position('n2_1'), atol=1e-8)
    assert math.isclose(tracker.anchor(angles).heading, 0.4, abs_tol=1e-8)


def test_switching_the_base_moves_no_link():
    """The supervisor hands the base to gripper b with both screwed in: no frame jumps."""
    angles = stance('n1_1', 'n2_1', heading=-0.7)
    tracker = BaseTracker(TREE, TRUSS)
    tracker.set_attached({'a': 'n1_1', 'b': 'n2_1'})
    tracker.set_base('a')
    before = link_poses(tracker, angles)
    assert tracker.set_base('b')
    after = link_poses(tracker, angles)
    assert tracker.anchor(angles).gripper == 'b'
    for link in TREE.links:
        assert np.allclose(before[link], after[link], atol=1e-8), link


def test_the_heading_is_kept_while_the_other_gripper_is_free():
    angles = stance('n1_1', 'n2_1', heading=0.25)
    tracker = BaseTracker(TREE, TRUSS)
    tracker.set_attached({'a': 'n1_1', 'b': 'n2_1'})
    held = link_poses(tracker, angles)
    tracker.set_attached({'a': 'n1_1'})  # b unscrewed, and it moves
    moved = dict(angles, a_yaw_joint=angles['a_yaw_joint'] + 0.3)
    assert math.isclose(tracker.anchor(moved).heading, 0.25, abs_tol=1e-8)
    assert np.allclose(link_poses(tracker, moved)['gripper_a'], held['gripper_a'])


def test_a_walk_of_steps_keeps_every_held_gripper_on_its_node():
    """Three steps, the base handed over at each: no error builds up from step to step."""
    route = ['n1_1', 'n2_1', 'n2_2', 'n3_2']
    tracker = BaseTracker(TREE, TRUSS)
    base = 'a'
    for step, (held, other) in enumerate(zip(route, route[1:], strict=False)):
        angles = stance(held, other, heading=0.1 * step)
        if base == 'b':  # the same stance seen from gripper b: the roles reversed
            angles = dict(zip(PHYSICAL_JOINT_NAMES, list(angles.values())[::-1], strict=True))
        tracker.set_base(base)
        tracker.set_attached({base: held, 'b' if base == 'a' else 'a': other})
        poses = link_poses(tracker, angles)
        moving = 'b' if base == 'a' else 'a'
        assert np.allclose(poses[f'gripper_{base}'][:3, 3], TRUSS.position(held), atol=1e-8)
        assert np.allclose(poses[f'gripper_{moving}'][:3, 3], TRUSS.position(other),
                           atol=1e-8)
        base = moving


def test_nothing_is_anchored_while_the_base_is_not_held():
    tracker = BaseTracker(TREE, TRUSS)
    assert tracker.root_pose(stance('n1_1', 'n2_1')) is None
    tracker.set_attached({'b': 'n2_1', 'a': 'n99_99'})  # a node of no truss is no anchor
    assert tracker.base == 'b'  # the only one screwed in, before the supervisor says


@pytest.mark.parametrize('name', ['c', 'base'])
def test_an_unknown_base_name_is_refused(name):
    tracker = BaseTracker(TREE, TRUSS)
    with pytest.raises(ValueError, match='unknown gripper'):
        tracker.set_base(name)
    assert tracker.base == 'a'
