"""The bag writer: readable by rosbags and the mcap ROS 2 decoder, complete, Jazzy's layout.

What it writes opens with rosbags and with the mcap ROS 2 decoder, holds everything written,
and has the layout and metadata of a bag recorded by ROS 2 Jazzy.
"""

import os

import pytest
import yaml
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.highlevel import AnyReader

from walker_bag.core.bag_metadata import NO_MESSAGE_TIME_NS, read_metadata
from walker_bag.core.bag_writer import BagWriter
from walker_bag.core.errors import (
    BagClosedError, BagError, BagExistsError, BagPathError, TopicConflictError,
    UnknownTopicError)
from walker_bag.core.bag_metadata import TopicMetadata
from walker_bag.core.message_definitions import message_definition, type_description_hash
from walker_bag.core.qos import qos_profiles_from_yaml

from walker_bag_samples import WALK_TOPICS, add_walk_topics, index_of, write_walk


def mcap_file(bag_dir):
    return bag_dir / f'{bag_dir.name}_0.mcap'


def test_rosbags_reads_every_message_back_decoded(walk_bag):
    path, written = walk_bag
    with AnyReader([path]) as reader:
        assert {c.topic: c.msgtype for c in reader.connections} == {
            name: type_name for name, type_name, _ in WALK_TOPICS}
        read = [(c.topic, t, index_of(c.msgtype, reader.deserialize(raw, c.msgtype)), raw)
                for c, t, raw in reader.messages()]
    assert read == [(m.topic, m.log_time_ns, m.index, m.data) for m in written]


def test_rosbags_checks_each_stored_type_hash_against_its_definition(walk_bag):
    path, _ = walk_bag
    with AnyReader([path]) as reader:
        digests = {c.msgtype: c.digest for c in reader.connections}
    assert digests == {t: type_description_hash(t) for _, t, _ in WALK_TOPICS}


def test_the_mcap_ros2_decoder_reads_every_message_with_both_times(walk_bag):
    path, written = walk_bag
    with open(mcap_file(path), 'rb') as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        read = [(channel.topic, message.log_time, message.publish_time, message.sequence,
                 index_of(schema.name, decoded))
                for schema, channel, message, decoded in reader.iter_decoded_messages()]
    assert read == [(m.topic, m.log_time_ns, m.publish_time_ns, m.index + 1, m.index)
                    for m in written]


def test_the_mcap_file_has_the_layout_of_jazzys_mcap_plugin(walk_bag):
    path, written = walk_bag
    with open(mcap_file(path), 'rb') as stream:
        reader = make_reader(stream)
        assert reader.get_header().profile == 'ros2'
        summary = reader.get_summary()
        records = list(reader.iter_metadata())
    schemas = {s.id: s for s in summary.schemas.values()}
    for channel in summary.channels.values():
        schema = schemas[channel.schema_id]
        topic = next(t for t in WALK_TOPICS if t[0] == channel.topic)
        assert schema.name == topic[1]
        assert schema.encoding == 'ros2msg'
        assert schema.data.decode() == message_definition(topic[1]).text
        assert channel.message_encoding == 'cdr'
        assert set(channel.metadata) == {'offered_qos_profiles', 'topic_type_hash'}
        assert qos_profiles_from_yaml(channel.metadata['offered_qos_profiles']) == (topic[2],)
        assert channel.metadata['topic_type_hash'] == type_description_hash(topic[1])
    assert len(schemas) == len({t for _, t, _ in WALK_TOPICS})
    assert summary.statistics.message_count == len(written)
    assert all(index.compression == '' for index in summary.chunk_indexes)
    # The rosbag2 metadata record, written on open and on close: the last one is the bag's.
    assert [r.name for r in records] == ['rosbag2', 'rosbag2']
    stored = yaml.safe_load(records[-1].metadata['serialized_metadata'])
    assert stored['message_count'] == len(written)
    assert stored == read_metadata(path).to_yaml()


def test_metadata_yaml_has_every_field_of_version_9_with_its_type(walk_bag):
    path, written = walk_bag
    root = yaml.safe_load((path / 'metadata.yaml').read_text())
    info = root['rosbag2_bagfile_information']
    assert list(info) == ['version', 'storage_identifier', 'duration', 'starting_time',
                          'message_count', 'topics_with_message_count', 'compression_format',
                          'compression_mode', 'relative_file_paths', 'files', 'custom_data',
                          'ros_distro']
    assert info['version'] == 9
    assert info['storage_identifier'] == 'mcap'
    assert info['ros_distro'] == 'jazzy'
    assert info['compression_format'] == '' and info['compression_mode'] == ''
    first, last = written[0].log_time_ns, written[-1].log_time_ns
    assert info['starting_time'] == {'nanoseconds_since_epoch': first}
    assert info['duration'] == {'nanoseconds': last - first}
    assert info['message_count'] == len(written)
    assert info['relative_file_paths'] == ['walk_0.mcap']
    assert (path / 'walk_0.mcap').is_file()
    assert info['files'] == [{'path': 'walk_0.mcap',
                              'starting_time': {'nanoseconds_since_epoch': first},
                              'duration': {'nanoseconds': last - first},
                              'message_count': len(written)}]
    assert info['custom_data'] == {'robot': 'walker'}
    topics = {t['topic_metadata']['name']: t for t in info['topics_with_message_count']}
    assert set(topics) == {name for name, _, _ in WALK_TOPICS}
    for name, type_name, qos in WALK_TOPICS:
        entry = topics[name]
        assert entry['message_count'] == sum(1 for m in written if m.topic == name)
        meta = entry['topic_metadata']
        assert list(meta) == ['name', 'type', 'serialization_format', 'offered_qos_profiles',
                              'type_description_hash']
        assert meta['type'] == type_name
        assert meta['serialization_format'] == 'cdr'
        assert meta['offered_qos_profiles'] == [qos.to_yaml()]  # a list, not a YAML string
        assert meta['type_description_hash'] == type_description_hash(type_name)


def test_an_empty_bag_is_a_valid_bag(tmp_path):
    path = tmp_path / 'empty'
    BagWriter(path).close()
    metadata = read_metadata(path)
    assert metadata.message_count == 0
    assert metadata.starting_time_ns == NO_MESSAGE_TIME_NS
    assert metadata.duration_ns == 0
    assert yaml.safe_load((path / 'metadata.yaml').read_text())[
        'rosbag2_bagfile_information']['custom_data'] is None
    with AnyReader([path]) as reader:
        assert reader.message_count == 0


def test_metadata_yaml_follows_each_flush_and_never_runs_ahead_of_the_file(tmp_path, typestore):
    path = tmp_path / 'flushed'
    writer = BagWriter(path)
    add_walk_topics(writer)
    assert read_metadata(path).message_count == 0
    write_walk(writer, typestore, 3)
    assert read_metadata(path).message_count == 0  # still in the chunk being built
    assert writer.flushed_message_count == 0
    size_before = mcap_file(path).stat().st_size
    writer.flush()
    assert read_metadata(path).message_count == 3 * len(WALK_TOPICS)
    assert writer.flushed_message_count == writer.message_count
    assert mcap_file(path).stat().st_size > size_before
    writer.close()


def test_a_full_chunk_is_written_out_without_waiting_for_a_flush(tmp_path, typestore):
    path = tmp_path / 'chunked'
    with BagWriter(path, max_chunk_size=2048) as writer:
        add_walk_topics(writer)
        flushed_counts, written = [], []
        for i in range(30):
            written += write_walk(writer, typestore, 1, start_ns=10**18 + i * 10**9)
            flushed_counts.append(writer.flushed_message_count)
            assert read_metadata(path).message_count == writer.flushed_message_count
        assert flushed_counts[-1] > 0  # chunks went out although flush() was never called
        assert flushed_counts == sorted(flushed_counts)
    with open(mcap_file(path), 'rb') as stream:
        summary = make_reader(stream).get_summary()
    assert len(summary.chunk_indexes) > 1
    # A chunk ends with the message that fills it (the first also holds the schemas).
    largest = max(len(m.data) for m in written) + 64
    assert all(index.uncompressed_size < 2048 + largest
               for index in summary.chunk_indexes[1:])


def test_an_existing_directory_is_never_overwritten(tmp_path):
    path = tmp_path / 'taken'
    path.mkdir()
    (path / 'keep.txt').write_text('precious')
    with pytest.raises(BagExistsError, match='taken'):
        BagWriter(path)
    assert [p.name for p in path.iterdir()] == ['keep.txt']
    assert (path / 'keep.txt').read_text() == 'precious'


def test_a_directory_that_cannot_be_created_is_refused_and_nothing_is_made(tmp_path):
    blocker = tmp_path / 'a_file'
    blocker.write_text('')
    with pytest.raises(BagPathError, match='cannot create'):
        BagWriter(blocker / 'bag')
    assert sorted(p.name for p in tmp_path.iterdir()) == ['a_file']


@pytest.mark.parametrize('size', [0, -1, 1.5, True])
def test_a_bad_chunk_size_is_refused_before_anything_is_made(tmp_path, size):
    with pytest.raises(BagError, match='max_chunk_size'):
        BagWriter(tmp_path / 'bag', max_chunk_size=size)
    assert not (tmp_path / 'bag').exists()


def test_writing_to_a_topic_not_added_is_refused_and_changes_nothing(tmp_path):
    with BagWriter(tmp_path / 'bag') as writer:
        with pytest.raises(UnknownTopicError, match='/walker/nothing'):
            writer.write('/walker/nothing', b'\x00\x01\x00\x00', 1)
        assert writer.message_count == 0


def test_topics_are_added_once_and_never_change_type(tmp_path):
    name, type_name, qos = WALK_TOPICS[0]
    topic = TopicMetadata(name, type_name, (qos,), type_description_hash(type_name))
    with BagWriter(tmp_path / 'bag') as writer:
        assert writer.add_topic(topic, message_definition(type_name))
        assert not writer.add_topic(topic, message_definition(type_name))
        other = TopicMetadata(name, 'walker_msgs/msg/StepPhase', (qos,))
        with pytest.raises(TopicConflictError, match=name):
            writer.add_topic(other, message_definition('walker_msgs/msg/StepPhase'))
        with pytest.raises(TopicConflictError, match='fully qualified'):
            writer.add_topic(TopicMetadata('joint_states', type_name), None)
        with pytest.raises(TopicConflictError, match='definition'):
            writer.add_topic(TopicMetadata('/walker/x', type_name),
                             message_definition('walker_msgs/msg/StepPhase'))
        with pytest.raises(TopicConflictError, match='cdr'):
            writer.add_topic(TopicMetadata('/walker/y', type_name,
                                           serialization_format='ros1'), None)
        assert list(writer.topics) == [name]


@pytest.mark.parametrize('log_time, publish_time, data', [
    (-1, None, b'\x00\x01\x00\x00'), (1.5, None, b'\x00\x01\x00\x00'),
    (True, None, b'\x00\x01\x00\x00'), (1, -5, b'\x00\x01\x00\x00'), (1, None, 'text'),
])
def test_bad_times_and_data_are_refused(tmp_path, log_time, publish_time, data):
    name, type_name, qos = WALK_TOPICS[0]
    with BagWriter(tmp_path / 'bag') as writer:
        writer.add_topic(TopicMetadata(name, type_name, (qos,)), None)
        with pytest.raises(BagError):
            writer.write(name, data, log_time, publish_time)
        assert writer.message_count == 0


def test_a_closed_bag_refuses_writes_and_closes_again_harmlessly(tmp_path):
    writer = BagWriter(tmp_path / 'bag')
    first = writer.close()
    assert writer.close() == first
    with pytest.raises(BagClosedError):
        writer.write('/walker/joint_states', b'', 1)
    with pytest.raises(BagClosedError):
        writer.flush()


def test_a_topic_without_a_definition_gets_an_empty_schema(tmp_path, typestore):
    """As when a type's .msg is not installed: rosbags and mcap still open the bag."""
    path = tmp_path / 'nodef'
    name, type_name, qos = WALK_TOPICS[1]
    with BagWriter(path) as writer:
        writer.add_topic(TopicMetadata(name, type_name, (qos,)), None)
        writer.write(name, b'\x00\x01\x00\x00' + bytes(60), 5)
    with open(mcap_file(path), 'rb') as stream:
        schema = next(iter(make_reader(stream).get_summary().schemas.values()))
    assert (schema.name, schema.encoding, schema.data) == (type_name, '', b'')
    with AnyReader([path], default_typestore=typestore) as reader:
        assert reader.message_count == 1


def test_the_file_is_synced_on_close(tmp_path, typestore, monkeypatch):
    synced = []
    real_fsync = os.fsync
    monkeypatch.setattr(os, 'fsync', lambda fd: (synced.append(fd), real_fsync(fd)))
    with BagWriter(tmp_path / 'bag') as writer:
        add_walk_topics(writer)
        write_walk(writer, typestore, 1)
        before = len(synced)
    assert len(synced) > before
