"""The record of the messages lost on the way to the recorder."""

from walker_bag.core.losses import LossLedger


def test_nothing_lost_is_said_and_stored_as_zero():
    ledger = LossLedger()
    assert ledger.total == 0 and ledger.summary() == 'no message lost'
    assert ledger.custom_data() == {'messages_lost': '0'}
    assert ledger.lost('/walker/phase', 0, True, 5) == ''


def test_each_loss_is_counted_per_topic_and_named_with_its_cause():
    ledger = LossLedger()
    line = ledger.lost('/walker/joint_states', 1709, False, 10)
    assert line == ('/walker/joint_states: 1709 messages lost (best effort, dropped before the '
                    'recorder took it); 1709 in all on this topic, 1709 on every topic')
    line = ledger.lost('/walker/gripper_states', 1, True, 20)
    assert "1 message lost (overwritten in the publisher's history" in line
    ledger.lost('/walker/gripper_states', 33, True, 30)
    assert ledger.total == 1743
    assert ledger.topics['/walker/gripper_states'].first_ns == 20
    assert ledger.topics['/walker/gripper_states'].last_ns == 30
    assert ledger.summary() == ('1743 messages lost: /walker/gripper_states 34 (reliable), '
                                '/walker/joint_states 1709 (best effort)')
    assert ledger.custom_data() == {'messages_lost': '1743',
                                    'messages_lost /walker/gripper_states': '34',
                                    'messages_lost /walker/joint_states': '1709'}
