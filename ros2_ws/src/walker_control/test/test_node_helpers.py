"""Pieces of the node that need no running graph: naming, and modes matching the messages."""

import pytest
from walker_msgs.msg import ControllerState, ControlMode

from walker_control.core.modes import Mode
from walker_control.joint_controller_node import default_node_name


@pytest.mark.parametrize('name', ['OFF', 'HOLD', 'COARSE', 'FINE'])
def test_modes_have_the_values_of_the_messages(name):
    assert Mode[name] == getattr(ControlMode, name) == getattr(ControllerState, name)


@pytest.mark.parametrize('argv, expected', [
    (['node', '--ros-args', '-p', 'joint_name:=a_yaw_joint'], 'controller_a_yaw'),
    (['node', '--ros-args', '--param', 'joint_name:=vertex_joint'], 'controller_vertex'),
    (['node', '--ros-args', '-p', 'joint_name:=elbow'], 'joint_controller'),
    (['node'], 'joint_controller'),
])
def test_the_node_is_named_after_its_joint(argv, expected):
    assert default_node_name(argv) == expected
