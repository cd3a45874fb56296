"""walkerctl status: the text, and where a free gripper's hole is in its own frame."""

import math

import numpy as np
import pytest

from walker_core.robot_parameters import default_parameter_file, load_walker_parameters
from walker_core.truss import Truss
from walker_teleop.core.status import (
    PHASE_NAMES, GripperView, StatusView, format_status, hole_offset, name_of,
    rotation_from_quaternion)

TRUSS = Truss.from_parameters(load_walker_parameters(default_parameter_file()))
UPRIGHT = (0.0, 0.0, 0.0, 1.0)  # quaternion (x, y, z, w): the gripper frame is the truss frame


def _about_z(angle):
    return (0.0, 0.0, math.sin(angle / 2), math.cos(angle / 2))


@pytest.mark.parametrize('quaternion', [UPRIGHT, _about_z(0.7), (0.1, -0.2, 0.3, 0.9),
                                        (0.0, 1.0, 0.0, 0.0)])
def test_a_rotation_from_a_quaternion_is_a_proper_rotation(quaternion):
    rotation = rotation_from_quaternion(quaternion)
    np.testing.assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(rotation) == pytest.approx(1.0)


def test_the_hole_offset_is_the_jog_that_brings_the_gripper_to_the_hole():
    hole = TRUSS.position('n2_1')
    position = hole + np.array([0.01, -0.02, 0.03])
    np.testing.assert_allclose(hole_offset(position, UPRIGHT, hole), [-0.01, 0.02, -0.03])
    # turned a quarter turn about z: the gripper's x axis is the truss's y axis
    np.testing.assert_allclose(hole_offset(position, _about_z(math.pi / 2), hole),
                               [0.02, 0.01, -0.03], atol=1e-12)


def test_the_status_names_the_phase_the_grippers_the_joints_and_the_nearest_hole():
    hole = TRUSS.position('n2_1')
    view = StatusView(
        namespace='/walker', phase='SAFE_HOLD', reason='hold requested by an operator',
        base_gripper='a', mode='HOLD', mode_base='a',
        grippers=(GripperView('a', 'attached', 'n1_1'),
                  GripperView('b', 'free', '', hole + np.array([0.0, 0.0, 0.03]), UPRIGHT)),
        joints=(('a_yaw_joint', -math.pi / 2), ('vertex_joint', 1.0)))
    text = format_status(view, TRUSS)
    assert 'SAFE_HOLD, base gripper a (hold requested by an operator)' in text
    assert 'gripper a    attached at n1_1' in text
    assert 'the hole of n2_1 is at (+0.0, +0.0, -30.0) mm in its frame' in text
    assert 'tilted 0.0 deg from vertical' in text
    assert 'a_yaw_joint    -1.5708 rad ( -90.00 deg)' in text


def test_the_status_says_what_was_not_received():
    text = format_status(StatusView(namespace='/walker', phase=None))
    assert 'no phase received: is the supervisor running?' in text
    assert 'no gripper_states received' in text
    assert 'no joint_states received' in text
    assert 'HOLD (no mode commanded yet)' in text


@pytest.mark.parametrize('value, name', [(0, 'IDLE'), (5, 'SAFE_HOLD'), (9, 'unknown (9)'),
                                         (-1, 'unknown (-1)')])
def test_message_constants_have_names(value, name):
    assert name_of(value, PHASE_NAMES) == name
