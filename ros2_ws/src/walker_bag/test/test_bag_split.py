"""A bag split into files by size and duration, the oldest rotated away, continued after a crash.

Every finished file has its summary and footer: the standard MCAP reader and rosbags open each
one and the bag as a whole, and ``metadata.yaml`` lists the files with their counts.
"""

import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from mcap.reader import make_reader
from rosbags.highlevel import AnyReader

from walker_bag.core.bag_metadata import read_metadata
from walker_bag.core.bag_split import SplitPolicy
from walker_bag.core.bag_writer import BagWriter
from walker_bag.core.errors import BagError, BagPathError

from walker_bag_samples import WALK_TOPICS, add_walk_topics, write_walk

HERE = Path(__file__).resolve().parent
ROUND_NS = len(WALK_TOPICS) * 1_000_000  # write_walk: one message per topic, 1 ms apart


def standard_reader_count(path: Path) -> int:
    with open(path, 'rb') as stream:
        return sum(1 for _ in make_reader(stream).iter_messages())


def test_a_bag_goes_on_in_a_new_file_at_the_duration(tmp_path, typestore):
    path = tmp_path / 'timed'
    split = SplitPolicy(max_file_duration_ns=10 * ROUND_NS)
    with BagWriter(path, split=split) as writer:
        add_walk_topics(writer)
        written = write_walk(writer, typestore, 35)
    metadata = read_metadata(path)
    assert metadata.relative_file_paths == tuple(f'timed_{i}.mcap' for i in range(4))
    assert [f.message_count for f in metadata.files] == [60, 60, 60, 30]
    assert all(f.duration_ns < 10 * ROUND_NS for f in metadata.files)
    assert metadata.message_count == len(written) == 210
    assert {t.topic_metadata.name: t.message_count
            for t in metadata.topics_with_message_count} == {n: 35 for n, _, _ in WALK_TOPICS}
    for f in metadata.files:
        assert standard_reader_count(path / f.path) == f.message_count
    with AnyReader([path]) as reader:
        assert [raw for _, _, raw in reader.messages()] == [m.data for m in written]


def test_a_bag_goes_on_in_a_new_file_at_the_size_and_keeps_its_newest_files(tmp_path,
                                                                             typestore):
    path = tmp_path / 'rotated'
    header = 20_000  # [B] about what a file holds before its first message: the definitions
    split = SplitPolicy(max_file_size=header + 10_000, max_files=3)
    with BagWriter(path, split=split, max_chunk_size=4096) as writer:
        add_walk_topics(writer)
        written = write_walk(writer, typestore, 200, flush_every=5)
    metadata = read_metadata(path)
    names = sorted(p.name for p in path.glob('*.mcap'))
    assert len(names) == 3 and tuple(sorted(metadata.relative_file_paths)) == tuple(names)
    assert int(names[0].split('_')[1].split('.')[0]) > 0  # the oldest were deleted
    kept = sum(f.message_count for f in metadata.files)
    assert metadata.message_count == kept < len(written)
    # a file is finished once it holds the limit; its summary repeats the definitions
    assert all((path / name).stat().st_size < 2 * header + 10_000 + 2 * 4096
               for name in names[:-1])
    with AnyReader([path]) as reader:
        assert [raw for _, _, raw in reader.messages()] == [m.data for m in written[-kept:]]


def test_appending_continues_the_bag_in_its_next_file(tmp_path, typestore):
    path = tmp_path / 'continued'
    with BagWriter(path, custom_data={'clock': 'sim_time'}) as writer:
        add_walk_topics(writer)
        first = write_walk(writer, typestore, 5)
    with BagWriter(path, append=True) as writer:
        assert writer.files == ['continued_0.mcap', 'continued_1.mcap']
        add_walk_topics(writer)  # known topics are kept as they are
        second = write_walk(writer, typestore, 4, start_ns=2 * 10**18)
    metadata = read_metadata(path)
    assert [f.message_count for f in metadata.files] == [30, 24]
    assert metadata.custom_data == {'clock': 'sim_time'}
    with AnyReader([path]) as reader:
        assert [raw for _, _, raw in reader.messages()] == [m.data for m in first + second]


KILLED_SPLIT_WRITER = textwrap.dedent(f"""
    import os, signal, sys
    sys.path.insert(0, {str(HERE)!r})
    from walker_bag.core.bag_reader import walker_typestore
    from walker_bag.core.bag_split import SplitPolicy
    from walker_bag.core.bag_writer import BagWriter
    from walker_bag_samples import add_walk_topics, write_walk
    typestore = walker_typestore()
    writer = BagWriter(sys.argv[1], split=SplitPolicy(max_file_duration_ns={10 * ROUND_NS}))
    add_walk_topics(writer)
    write_walk(writer, typestore, 15)
    writer.flush()
    write_walk(writer, typestore, 2, start_ns=2 * 10**18)
    os.kill(os.getpid(), signal.SIGKILL)
""")


def test_appending_to_a_bag_whose_writer_was_killed_completes_its_last_file_first(tmp_path,
                                                                                  typestore):
    path = tmp_path / 'killed'
    run = subprocess.run([sys.executable, '-c', KILLED_SPLIT_WRITER, str(path)])
    assert run.returncode == -signal.SIGKILL
    with pytest.raises(Exception, match='end magic'):
        AnyReader([path]).open()
    with BagWriter(path, append=True) as writer:
        write_walk(writer, typestore, 1, start_ns=3 * 10**18)
    # the kill came after the third file had begun, with nothing flushed into it yet
    assert (path / 'killed_2.mcap.incomplete').exists()
    metadata = read_metadata(path)
    assert [f.message_count for f in metadata.files] == [60, 30, 0, 6]
    assert [standard_reader_count(path / f.path) for f in metadata.files] == [60, 30, 0, 6]


def test_a_bag_being_written_is_not_written_by_a_second_writer(tmp_path):
    path = tmp_path / 'busy'
    with BagWriter(path):
        with pytest.raises(BagPathError, match='is being written by another process'):
            BagWriter(path, append=True)


@pytest.mark.parametrize('field', ['max_file_size', 'max_file_duration_ns', 'max_files'])
@pytest.mark.parametrize('value', [-1, 1.5, True])
def test_a_split_limit_must_be_a_non_negative_integer(field, value):
    with pytest.raises(BagError, match=f'{field} must be a non-negative integer'):
        SplitPolicy(**{field: value})
