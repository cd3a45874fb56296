"""Truss grid geometry and the physical-joint / role mapping."""

import numpy as np
import pytest

from walker_core.joint_roles import (
    PHYSICAL_JOINT_NAMES, joint_of_role, other_gripper, physical_to_roles, role_of_joint,
    roles_to_physical)
from walker_core.truss import Truss, UnknownNodeError

TRUSS = Truss(spacing=0.9, columns=5, rows=4)


def test_nodes_positions_and_neighbours():
    assert len(TRUSS.node_names) == 20
    np.testing.assert_allclose(TRUSS.position('n2_1'), [1.8, 0.9, 0.0])
    assert TRUSS.neighbors('n0_0') == ['n1_0', 'n0_1']
    assert sorted(TRUSS.neighbors('n2_1')) == ['n1_1', 'n2_0', 'n2_2', 'n3_1']
    assert TRUSS.nearest_node([1.79, 0.92, 0.1]) == ('n2_1', pytest.approx(0.0224, abs=1e-3))


@pytest.mark.parametrize('name, words', [
    ('n5_0', 'not on the truss'), ('n0_4', 'not on the truss'), ('node7', 'not a node name'),
    ('', 'not a node name'), (None, 'not a node name'), ('n-1_0', 'not a node name'),
    # one spelling per node: no leading zeros, no trailing newline, ASCII digits only
    ('n4_03', 'not a node name'), ('n04_3', 'not a node name'), ('n4_3\n', 'not a node name'),
    (' n4_3', 'not a node name'), ('n\u0664_3', 'not a node name'),
])
def test_unknown_nodes_are_refused(name, words):
    with pytest.raises(UnknownNodeError, match=words):
        TRUSS.position(name)


def test_roles_mirror_when_the_base_swaps():
    q = np.array([0.1, 0.2, 0.3, 0.4, 0.5])
    np.testing.assert_array_equal(physical_to_roles(q, 'a'), q)
    np.testing.assert_array_equal(physical_to_roles(q, 'b'), q[::-1])
    np.testing.assert_array_equal(roles_to_physical(physical_to_roles(q, 'b'), 'b'), q)
    assert role_of_joint('a_yaw_joint', 'a') == 1
    assert role_of_joint('a_yaw_joint', 'b') == 5
    assert role_of_joint('b_pitch_joint', 'b') == 2
    assert joint_of_role(3, 'b') == 'vertex_joint'
    for base in 'ab':
        for name in PHYSICAL_JOINT_NAMES:
            assert joint_of_role(role_of_joint(name, base), base) == name
    assert other_gripper('a') == 'b'


@pytest.mark.parametrize('call', [
    lambda: other_gripper('c'), lambda: role_of_joint('elbow', 'a'),
    lambda: joint_of_role(6, 'a'), lambda: physical_to_roles([1, 2, 3], 'a'),
])
def test_bad_names_and_shapes_are_refused(call):
    with pytest.raises(ValueError):
        call()
