"""The reading helper later tools use: decoded messages of chosen topics, in time order."""

import pytest

from walker_bag.core.bag_metadata import TopicMetadata
from walker_bag.core.bag_reader import BagReader, read_messages, walker_typestore
from walker_bag.core.bag_writer import BagWriter
from walker_bag.core.errors import BagPathError, UnknownTopicError

from walker_bag_samples import WALK_TOPICS, build_message, index_of


def test_messages_come_decoded_with_their_times_in_log_time_order(walk_bag):
    path, written = walk_bag
    read = read_messages(path)
    assert [(m.topic, m.type, m.log_time_ns) for m in read] == [
        (w.topic, w.type, w.log_time_ns) for w in written]
    assert [index_of(m.type, m.message) for m in read] == [w.index for w in written]


def test_custom_walker_types_decode_field_by_field(walk_bag):
    path, _ = walk_bag
    phases = read_messages(path, ['/walker/phase'])
    assert [p.message.step_index for p in phases] == list(range(20))
    first = phases[0].message
    assert (first.phase, first.base_gripper, first.from_node, first.to_node) == (
        2, 'a', 'n0_0', 'n1_0')
    grippers = read_messages(path, ['/walker/gripper_states'])[3].message
    assert [g.name for g in grippers.grippers] == ['a', 'b']
    assert grippers.grippers[0].node == 'n0_0'


def test_a_topic_filter_reads_only_those_topics(walk_bag):
    path, written = walk_bag
    wanted = ['/walker/joint_states', '/walker/controllers/a_yaw_joint/state']
    read = read_messages(path, wanted)
    assert {m.topic for m in read} == set(wanted)
    assert len(read) == sum(1 for w in written if w.topic in wanted)


def test_an_unknown_topic_is_named_with_what_the_bag_has(walk_bag):
    path, _ = walk_bag
    with pytest.raises(UnknownTopicError, match=r'/walker/nothing.*it has .*/walker/phase'):
        read_messages(path, ['/walker/phase', '/walker/nothing'])


def test_the_reader_summarizes_topics_counts_and_span(walk_bag):
    path, written = walk_bag
    with BagReader(path) as reader:
        assert reader.topics == {name: type_name for name, type_name, _ in WALK_TOPICS}
        assert reader.message_counts == {name: 20 for name, _, _ in WALK_TOPICS}
        assert reader.message_count == len(written)
        assert reader.start_time_ns == written[0].log_time_ns
        assert reader.end_time_ns == written[-1].log_time_ns + 1


def test_a_directory_that_is_not_a_bag_is_refused(tmp_path):
    with pytest.raises(BagPathError, match='not a bag directory'):
        BagReader(tmp_path / 'missing')
    (tmp_path / 'empty').mkdir()
    with pytest.raises(BagPathError, match='cannot read the bag'):
        BagReader(tmp_path / 'empty')


def test_a_bag_without_definitions_decodes_with_the_installed_walker_types(tmp_path):
    typestore = walker_typestore()
    path = tmp_path / 'bare'
    name, type_name, qos = WALK_TOPICS[2]  # walker_msgs/msg/GripperStates
    with BagWriter(path) as writer:
        writer.add_topic(TopicMetadata(name, type_name, (qos,)), None)
        writer.write(name, bytes(typestore.serialize_cdr(build_message(typestore, type_name, 4),
                                                         type_name)), 1)
    (message,) = read_messages(path)
    assert index_of(type_name, message.message) == 4


def test_every_walker_message_type_is_in_the_fallback_typestore():
    """Bags without stored definitions decode every walker_msgs message, step reports too."""
    from walker_bag.core.message_definitions import interface_prefixes

    installed = {f'walker_msgs/msg/{path.stem}' for prefix in interface_prefixes()
                 for path in (prefix / 'share' / 'walker_msgs' / 'msg').glob('*.msg')}
    assert installed, 'walker_msgs is not installed'
    assert installed <= set(walker_typestore().types)
