"""The latched topics' newest messages the Foxglove bridge sends again to late clients."""

from walker_viz.core.latched import MAX_DEPTH, LatchedMessages


def test_a_latched_topic_keeps_its_newest_messages_and_a_volatile_one_nothing():
    kept = LatchedMessages()
    kept.latch('/walker/phase', 2)
    for index in range(3):
        kept.passed_on('/walker/phase', bytes([index]), index)
        kept.passed_on('/walker/joint_states', bytes([index]), index)
    assert kept.newest('/walker/phase') == [(b'\x01', 1), (b'\x02', 2)]
    assert kept.newest('/walker/joint_states') == [] and not kept.latched('/walker/joint_states')


def test_an_unknown_or_huge_depth_is_bounded():
    kept = LatchedMessages()
    kept.latch('/walker/markers', 0)  # discovery did not tell: the newest one
    kept.latch('/walker/step_reports', 10**6)
    for index in range(MAX_DEPTH + 5):
        kept.passed_on('/walker/markers', b'm', index)
        kept.passed_on('/walker/step_reports', b's', index)
    assert len(kept.newest('/walker/markers')) == 1
    assert len(kept.newest('/walker/step_reports')) == MAX_DEPTH
