"""The gripper states: the names every tool writes, the message codes the nodes convert to."""

import json

import pytest

from walker_core.gripper_state import TURNING, UNKNOWN, GripperState, reported_state

NAMES = ('free', 'screwing', 'attached', 'unscrewing', 'jammed')


def test_a_state_is_its_lowercase_name_in_comparisons_text_and_json():
    for state, name in zip(GripperState, NAMES, strict=True):
        assert state == name and GripperState(name) is state
        assert f'{state}' == str(state) == name
        assert {name: 1}[state] == 1  # a mapping keyed by the plain name finds the state
    assert json.loads(json.dumps({'a': GripperState.ATTACHED})) == {'a': 'attached'}


def test_the_codes_are_the_message_constants_in_order_and_come_back():
    assert [state.code for state in GripperState] == [0, 1, 2, 3, 4]
    for state in GripperState:
        assert GripperState.of_code(state.code) is state
        assert reported_state(state.code) is state


@pytest.mark.parametrize('code', [-1, 5, None, 'attached'])
def test_a_code_the_message_does_not_define_is_refused_by_name_or_reported_unknown(code):
    with pytest.raises(ValueError, match=f'unknown gripper state code {code!r}'):
        GripperState.of_code(code)
    assert reported_state(code) == UNKNOWN
    assert UNKNOWN not in set(GripperState)


def test_a_gripper_turns_in_its_hole_only_while_screwing_in_or_unscrewing():
    assert TURNING == {'screwing', 'unscrewing'}
