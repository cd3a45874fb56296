"""When the plant's slower outputs are due, and when its gripper states have changed."""

import pytest

from walker_sim.core.outputs import StampedRate, gripper_states_key

MS = 1_000_000


def test_an_output_is_due_at_the_first_stamp_then_once_a_period():
    rate = StampedRate(100.0)  # every 10 ms
    due = [stamp for stamp in range(0, 50 * MS, 2 * MS) if rate.due(stamp)]
    assert due == [0, 10 * MS, 20 * MS, 30 * MS, 40 * MS]


def test_an_output_is_due_at_once_when_forced_or_when_the_stamps_go_back():
    rate = StampedRate(100.0)
    assert rate.due(100 * MS) and not rate.due(102 * MS)
    assert rate.due(104 * MS, force=True)  # a stop of the plant at a decision
    assert not rate.due(106 * MS) and rate.due(114 * MS)
    assert rate.due(0)  # a reset


def test_a_rate_must_be_positive():
    with pytest.raises(ValueError, match='rate'):
        StampedRate(0.0)


def test_the_gripper_states_change_with_a_mode_a_node_a_message_or_the_base(make_plant):
    plant = make_plant()
    before = gripper_states_key(plant.state())
    assert gripper_states_key(plant.state()) == before  # alignment moves, the key does not
    plant.unscrew('b')
    assert gripper_states_key(plant.state()) != before
