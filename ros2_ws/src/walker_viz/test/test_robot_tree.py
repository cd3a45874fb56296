"""The TF tree from the URDF: the frames the kinematics and the plant's model agree on."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_core.kinematics import WalkerKinematics, invert_transform
from walker_core.robot_parameters import load_walker_parameters
from walker_core.urdf import GRIPPER_LINKS, description_urdf
from walker_core.rotations import quaternion_from_matrix, rotation_from_quaternion
from walker_viz.core.robot_tree import RobotTree, axis_rotation

PARAMS = load_walker_parameters()
KIN = WalkerKinematics.from_parameters(PARAMS)
TREE = RobotTree(description_urdf(PARAMS))
angle = st.floats(-1.5, 1.5)
#: The URDF writes its numbers with 9 significant digits (pi as 3.14159265).
URDF_PRECISION = 1e-8


def angles_of(theta):
    return dict(zip(PHYSICAL_JOINT_NAMES, theta, strict=True))


def test_the_tree_is_the_description_urdf_rooted_at_gripper_a():
    assert TREE.root == 'gripper_a'
    assert TREE.joint_names == PHYSICAL_JOINT_NAMES
    static = TREE.static_transforms()
    assert static, 'the bending joints of the description view are fixed'
    children = {t.child for t in static} | {j.child for j in TREE.moving_joints}
    assert children == set(TREE.links) - {'gripper_a'}  # every link reached once


@settings(max_examples=60, deadline=None)
@given(st.tuples(angle, angle, angle, angle, angle))
def test_gripper_b_in_gripper_a_is_the_forward_kinematics(theta):
    """Eq (1)'s chain, from the URDF alone: no length of the kinematics is used."""
    pose = TREE.link_in_root(GRIPPER_LINKS['b'], angles_of(theta))
    assert np.allclose(pose, KIN.forward_transform(theta), atol=URDF_PRECISION)


@settings(max_examples=30, deadline=None)
@given(st.tuples(angle, angle, angle, angle, angle))
def test_seen_from_gripper_b_the_chain_is_mirrored(theta):
    """Either gripper as base: the roles reverse (walker_core.joint_roles)."""
    a_in_b = invert_transform(TREE.link_in_root(GRIPPER_LINKS['b'], angles_of(theta)))
    assert np.allclose(a_in_b, KIN.forward_transform(theta[::-1]), atol=URDF_PRECISION)


def test_root_pose_puts_the_holding_gripper_where_it_is_held():
    theta = [0.2, 0.4, 1.2, 0.5, -0.3]
    held = np.eye(4)
    held[:3, 3] = [0.3, 0.2, 0.0]
    root = TREE.root_pose(GRIPPER_LINKS['b'], held, angles_of(theta))
    assert np.allclose(root @ TREE.link_in_root('gripper_b', angles_of(theta)), held)


@pytest.mark.parametrize('bad, text', [
    ({'a_yaw_joint': 0.0}, "no angle for joint 'a_pitch_joint'"),
    ({**angles_of([0.0] * 5), 'vertex_joint': math.nan}, "'vertex_joint' has a non-finite"),
])
def test_a_bad_joint_state_is_refused_with_the_joint_named(bad, text):
    with pytest.raises(ValueError, match=text):
        TREE.moving_transforms(bad)


@settings(max_examples=60, deadline=None)
@given(st.tuples(angle, angle, angle, angle, angle))
def test_quaternions_round_trip(theta):
    pose = TREE.link_in_root('gripper_b', angles_of(theta))
    q = quaternion_from_matrix(pose)
    assert math.isclose(np.linalg.norm(q), 1.0)
    assert np.allclose(rotation_from_quaternion(q), pose[:3, :3], atol=1e-12)


def test_a_zero_quaternion_is_refused():
    with pytest.raises(ValueError, match='must not be zero'):
        rotation_from_quaternion([0.0, 0.0, 0.0, 0.0])


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3), st.floats(-4.0, 4.0))
def test_axis_rotation_is_scipys_rotation_vector(axis, turn):
    from scipy.spatial.transform import Rotation

    axis = np.array(axis)
    if np.linalg.norm(axis) < 1e-3:
        axis = np.array([0.0, 0.0, 1.0])
    axis = axis / np.linalg.norm(axis)
    expected = Rotation.from_rotvec(turn * axis).as_matrix()
    assert np.allclose(axis_rotation(axis, turn), expected, rtol=0.0, atol=1e-12)


def test_the_poses_of_many_rows_are_each_rows_pose():
    rng = np.random.default_rng(3)
    rows = rng.uniform(-1.5, 1.5, (7, len(TREE.joint_names)))
    columns = {name: rows[:, index] for index, name in enumerate(TREE.joint_names)}
    for link in TREE.links:
        many = TREE.links_in_root(link, columns)
        for row, pose in zip(rows, many, strict=True):
            one = TREE.link_in_root(link, dict(zip(TREE.joint_names, row, strict=True)))
            assert np.allclose(pose, one, rtol=0.0, atol=1e-14)
    with pytest.raises(ValueError, match='no angle for joint'):
        TREE.links_in_root('gripper_b', {'a_yaw_joint': rows[:, 0]})
    with pytest.raises(ValueError, match='non-finite'):
        TREE.links_in_root('gripper_b', {**columns, 'vertex_joint': np.full(7, np.nan)})
    with pytest.raises(ValueError, match='different lengths'):
        TREE.links_in_root('gripper_b', {**columns, 'vertex_joint': np.zeros(3)})
    with pytest.raises(ValueError, match='no joint angles given'):
        TREE.links_in_root('gripper_b', {})
