"""The markers: the truss as the parameters lay it out, and the tip path of a trajectory."""

import numpy as np
import pytest

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_core.kinematics import WalkerKinematics
from walker_core.robot_parameters import load_walker_parameters
from walker_core.truss import Truss, UnknownNodeError
from walker_core.urdf import description_urdf, robot_urdf
from walker_viz.core.base_anchor import BaseAnchor
from walker_viz.core.markers import (
    MAX_PATH_POINTS, target_marker, tip_path, truss_markers)
from walker_viz.core.robot_tree import RobotTree

PARAMS = load_walker_parameters()
TRUSS = Truss.from_parameters(PARAMS)
TREE = RobotTree(description_urdf(PARAMS))
KIN = WalkerKinematics.from_parameters(PARAMS)


def test_the_truss_has_every_member_node_hole_and_label():
    markers = truss_markers(TRUSS, PARAMS.truss.hole_depth)
    by_ns = {}
    for m in markers:
        by_ns.setdefault(m.namespace, []).append(m)
    nodes = len(TRUSS.node_names)
    members = TRUSS.rows * (TRUSS.columns - 1) + TRUSS.columns * (TRUSS.rows - 1)
    assert len(by_ns['truss_members'][0].points) == 2 * members
    segments = by_ns['truss_members'][0].points.reshape(-1, 2, 3)
    assert np.allclose(np.linalg.norm(segments[:, 1] - segments[:, 0], axis=1), TRUSS.spacing)
    assert len(by_ns['truss_nodes'][0].points) == nodes
    assert len(by_ns['truss_holes']) == nodes
    assert all(h.scale[2] == PARAMS.truss.hole_depth and h.points[0][2] < 0
               for h in by_ns['truss_holes'])
    assert sorted(m.text for m in by_ns['truss_labels']) == sorted(TRUSS.node_names)


def test_the_target_is_on_its_node_and_an_unknown_node_is_refused():
    marker = target_marker(TRUSS, 'n2_1')
    assert np.allclose(marker.points[0][:2], TRUSS.position('n2_1')[:2])
    with pytest.raises(UnknownNodeError):
        target_marker(TRUSS, 'n99_99')


@pytest.mark.parametrize('tree', [TREE, RobotTree(robot_urdf(PARAMS, flexible=True,
                                                              rotors=False))])
def test_the_tip_path_follows_the_forward_kinematics_from_the_base(tree):
    """A plan is the rigid model's: a flexible tree draws it with straight links."""
    base = BaseAnchor('a', 'n1_1', TRUSS.position('n1_1'), 0.5)
    start = KIN.inverse([0.3, 0.0, 0.03, 0.0, 0.0])
    goal = KIN.inverse([0.0, 0.3, 0.03, 0.0, 0.0])
    rows = np.linspace(start, goal, 1000)
    points = tip_path(tree, base, list(PHYSICAL_JOINT_NAMES), rows)
    assert len(points) == MAX_PATH_POINTS
    c, s = np.cos(0.5), np.sin(0.5)
    for row, point in ((rows[0], points[0]), (rows[-1], points[-1])):
        x, y, z = KIN.forward(row)[:3]
        expected = TRUSS.position('n1_1') + [c * x - s * y, s * x + c * y, z]
        assert np.allclose(point, expected, atol=1e-8)  # the URDF's 9 digits


def test_a_trajectory_of_other_joints_is_refused():
    base = BaseAnchor('a', 'n1_1', TRUSS.position('n1_1'), 0.0)
    with pytest.raises(ValueError, match='has no'):
        tip_path(TREE, base, ['a_yaw_joint'], np.zeros((3, 1)))
