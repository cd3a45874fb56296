"""Gripper states in and out of ``walker_msgs/GripperState``: the codes the message defines."""

import pytest
from walker_msgs.msg import GripperState as GripperStateMessage
from walker_msgs.msg import GripperStates

from walker_core.gripper_state import UNKNOWN, GripperState
from walker_supervisor.messages import gripper_readings, gripper_state_code


@pytest.mark.parametrize('state', list(GripperState))
def test_each_state_has_the_code_of_the_message_constant_of_its_name(state):
    assert state.code == getattr(GripperStateMessage, state.name)
    assert gripper_state_code(state) == gripper_state_code(str(state)) == state.code


def test_the_runner_hears_each_gripper_state_and_node_and_unknown_for_an_undefined_code():
    message = GripperStates(grippers=[
        GripperStateMessage(name='a', state=GripperStateMessage.ATTACHED, node='n1_1'),
        GripperStateMessage(name='b', state=42, node='')])
    readings = gripper_readings(message)
    assert readings == {'a': ('attached', 'n1_1'), 'b': (UNKNOWN, '')}
    assert readings['a'][0] is GripperState.ATTACHED


def test_a_state_the_message_cannot_carry_is_sent_as_free():
    assert gripper_state_code(UNKNOWN) == GripperStateMessage.FREE
