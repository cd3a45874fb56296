"""A bag cut short by a crash is readable up to its last flush and recovers into a whole bag.

Which readers open a cut file: a streaming MCAP reader does; rosbags (like every reader that
starts from the footer) refuses it until it is recovered.
"""

import shutil
import signal
import struct
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from mcap.exceptions import EndOfFile
from mcap.reader import make_reader
from mcap.records import Chunk, Message
from mcap.stream_reader import StreamReader, breakup_chunk
from rosbags.highlevel import AnyReader

from walker_bag.core.bag_metadata import read_metadata
from walker_bag.core.bag_reader import BagReader
from walker_bag.core.bag_recovery import recover_abandoned_bags, recover_bag, recover_in_place
from walker_bag.core.bag_writer import BagWriter
from walker_bag.core.errors import BagExistsError, BagPathError

from walker_bag_samples import WALK_TOPICS, add_walk_topics

HERE = Path(__file__).resolve().parent
FLUSHED_ROUNDS = 7
UNFLUSHED_ROUNDS = 3

# A writer that flushes, writes more, and is killed before it can close the bag.
KILLED_WRITER = textwrap.dedent(f"""
    import os, signal, sys
    sys.path.insert(0, {str(HERE)!r})
    from walker_bag.core.bag_reader import walker_typestore
    from walker_bag.core.bag_writer import BagWriter
    from walker_bag_samples import add_walk_topics, write_walk
    typestore = walker_typestore()
    writer = BagWriter(sys.argv[1])
    add_walk_topics(writer)
    write_walk(writer, typestore, {FLUSHED_ROUNDS})
    writer.flush()
    write_walk(writer, typestore, {UNFLUSHED_ROUNDS}, start_ns=2 * 10**18)
    os.kill(os.getpid(), signal.SIGKILL)
""")


def stream_messages(path):
    """Messages a streaming reader yields before the file ends, and whether it ended early."""
    messages = []
    with open(path, 'rb') as stream:
        try:
            for record in StreamReader(stream, validate_crcs=True).records:
                if isinstance(record, Message):
                    messages.append((record.channel_id, record.log_time, record.data))
        except (EndOfFile, struct.error):
            return messages, True
    return messages, False


@pytest.fixture
def killed_bag(tmp_path):
    path = tmp_path / 'killed'
    result = subprocess.run([sys.executable, '-c', KILLED_WRITER, str(path)])
    assert result.returncode == -signal.SIGKILL
    return path


def test_a_killed_writer_leaves_everything_up_to_the_last_flush(killed_bag):
    flushed = FLUSHED_ROUNDS * len(WALK_TOPICS)
    metadata = read_metadata(killed_bag)
    assert metadata.message_count == flushed
    assert {t.topic_metadata.name: t.message_count
            for t in metadata.topics_with_message_count} == {
        name: FLUSHED_ROUNDS for name, _, _ in WALK_TOPICS}
    messages, cut = stream_messages(killed_bag / 'killed_0.mcap')
    assert cut
    assert len(messages) == flushed
    assert all(log_time < 2 * 10**18 for _, log_time, _ in messages)


def test_rosbags_refuses_the_cut_file_with_a_clear_reason(killed_bag):
    with pytest.raises(BagPathError, match='cannot read the bag .*end magic'):
        BagReader(killed_bag)


def test_recovery_writes_a_complete_bag_and_leaves_the_cut_one_untouched(killed_bag):
    original = (killed_bag / 'killed_0.mcap').read_bytes()
    report = recover_bag(killed_bag)
    assert report.destination == killed_bag.with_name('killed_recovered')
    assert not report.complete and 'EndOfFile' in report.stopped_at
    assert report.message_count == FLUSHED_ROUNDS * len(WALK_TOPICS)
    assert (killed_bag / 'killed_0.mcap').read_bytes() == original
    with BagReader(report.destination) as reader:
        counts = reader.message_counts
        decoded = list(reader.messages())
    assert counts == {name: FLUSHED_ROUNDS for name, _, _ in WALK_TOPICS}
    assert len(decoded) == report.message_count
    recovered = read_metadata(report.destination)
    before = read_metadata(killed_bag)
    assert [t.topic_metadata for t in recovered.topics_with_message_count] == [
        t.topic_metadata for t in before.topics_with_message_count]


def test_recovery_of_a_complete_bag_copies_it_whole(walk_bag, tmp_path):
    path, written = walk_bag
    report = recover_bag(path, tmp_path / 'copy')
    assert report.complete and report.stopped_at == ''
    with AnyReader([path]) as a, AnyReader([tmp_path / 'copy']) as b:
        assert [(c.topic, t, raw) for c, t, raw in a.messages()] == [
            (c.topic, t, raw) for c, t, raw in b.messages()]
    assert read_metadata(tmp_path / 'copy').custom_data == {'robot': 'walker'}


def test_a_file_cut_anywhere_recovers_exactly_the_messages_of_its_complete_chunks(
        walk_bag, tmp_path):
    source, written = walk_bag
    path = tmp_path / 'small_chunks'
    # Rewrite with small chunks so that cuts fall between and inside many chunks.
    with BagWriter(path, max_chunk_size=1500) as writer:
        add_walk_topics(writer)
        for m in written:
            writer.write(m.topic, m.data, m.log_time_ns, m.publish_time_ns)
    data = (path / 'small_chunks_0.mcap').read_bytes()
    with open(path / 'small_chunks_0.mcap', 'rb') as stream:
        chunks = make_reader(stream).get_summary().chunk_indexes
    with open(path / 'small_chunks_0.mcap', 'rb') as stream:
        per_chunk = [sum(isinstance(r, Message) for r in breakup_chunk(record))
                     for record in StreamReader(stream, emit_chunks=True).records
                     if isinstance(record, Chunk)]
    assert len(chunks) == len(per_chunk) > 5
    for k, cut in enumerate(range(40, len(data), 1499)):
        cut_dir = tmp_path / f'cut{k}'
        cut_dir.mkdir()
        shutil.copy(path / 'metadata.yaml', cut_dir)
        (cut_dir / 'small_chunks_0.mcap').write_bytes(data[:cut])
        expected = sum(count for c, count in zip(chunks, per_chunk, strict=True)
                       if c.chunk_start_offset + c.chunk_length <= cut)
        report = recover_bag(cut_dir, tmp_path / f'recovered{k}')
        assert report.message_count == expected, (cut, report)
        with AnyReader([tmp_path / f'recovered{k}']) as reader:
            got = [(c.topic, t, raw) for c, t, raw in reader.messages()]
        assert got == [(m.topic, m.log_time_ns, m.data) for m in written[:expected]]


def test_recovery_refuses_an_existing_destination_and_non_bags(walk_bag, tmp_path):
    path, _ = walk_bag
    (tmp_path / 'taken').mkdir()
    with pytest.raises(BagExistsError, match='taken'):
        recover_bag(path, tmp_path / 'taken')
    with pytest.raises(BagPathError, match='not a bag directory'):
        recover_bag(tmp_path / 'nothing_here')


def test_recovery_in_place_opens_the_killed_bag_to_every_reader_and_keeps_the_cut_file(
        killed_bag):
    flushed = FLUSHED_ROUNDS * len(WALK_TOPICS)
    original = (killed_bag / 'killed_0.mcap').read_bytes()
    report = recover_in_place(killed_bag)
    assert report.destination == killed_bag and not report.complete
    assert report.message_count == flushed
    assert (killed_bag / 'killed_0.mcap.incomplete').read_bytes() == original
    with open(killed_bag / 'killed_0.mcap', 'rb') as stream:
        assert len(list(make_reader(stream).iter_messages())) == flushed
    with AnyReader([killed_bag]) as reader:
        assert len(list(reader.messages())) == flushed
    assert read_metadata(killed_bag).message_count == flushed
    again = recover_in_place(killed_bag)  # nothing left to do
    assert again.complete and again.files == () and again.message_count == flushed


def test_a_file_cut_inside_a_chunk_is_recovered_in_place(killed_bag):
    """A kill in the middle of a write: the standard reader reads nothing of the cut file."""
    path = killed_bag / 'killed_0.mcap'
    data = path.read_bytes()
    path.write_bytes(data + data[len(data) // 2:len(data) // 2 + 5000])  # half a chunk more
    with pytest.raises(Exception), open(path, 'rb') as stream:  # noqa: B017
        list(make_reader(stream).iter_messages())
    report = recover_in_place(killed_bag)
    assert report.message_count == FLUSHED_ROUNDS * len(WALK_TOPICS)
    with open(path, 'rb') as stream:
        assert len(list(make_reader(stream).iter_messages())) == report.message_count


def test_a_bag_being_written_is_left_alone_and_cut_ones_beside_it_are_recovered(
        killed_bag, tmp_path):
    with BagWriter(tmp_path / 'live') as live:
        assert recover_in_place(live.path) is None
        reports = recover_abandoned_bags(tmp_path)
        assert [r.source for r in reports] == [killed_bag]
        assert not (live.path / 'live_0.mcap.incomplete').exists()
    assert recover_abandoned_bags(tmp_path) == []
