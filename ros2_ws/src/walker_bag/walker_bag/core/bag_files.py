"""What a bag's storage files hold, read from the files themselves (as ``ros2 bag reindex``).

A complete MCAP file ends with its summary and footer: the schemas (the message definitions),
the channels (topic, offered QoS, type hash), the statistics (message counts per channel, the
log-time span) and the ``rosbag2`` metadata record (custom data, distribution). From these the
bag's ``metadata.yaml`` can be made again whatever became of it: after a file was recovered,
when a recording continues an existing bag, after old files were rotated away.

A file without a footer (its writer was killed) is *incomplete*: readers that start from the
footer refuse it. :mod:`walker_bag.core.bag_recovery` completes it.
"""

from __future__ import annotations

import dataclasses
import fcntl
import os
import re
from collections.abc import Iterable, Mapping
from pathlib import Path

import yaml
from mcap.exceptions import McapError
from mcap.reader import make_reader

from walker_bag.core.bag_metadata import (
    NO_MESSAGE_TIME_NS, ROS_DISTRO, BagMetadata, FileInformation, TopicInformation,
    TopicMetadata)
from walker_bag.core.errors import BagPathError
from walker_bag.core.message_definitions import MessageDefinition
from walker_bag.core.qos import qos_profiles_from_yaml

__all__ = ['StoredTopic', 'FileSummary', 'BagLock', 'storage_files', 'file_index', 'is_complete',
           'summarize_file', 'combine_summaries']

MAGIC = b'\x89MCAP0\r\n'
_FILE_NAME = re.compile(r'^(?P<stem>.+)_(?P<index>\d+)\.mcap$')


@dataclasses.dataclass(frozen=True)
class StoredTopic:
    """A topic as a file stores it: its metadata and its definition (None when unknown)."""

    metadata: TopicMetadata
    definition: MessageDefinition | None


@dataclasses.dataclass(frozen=True)
class FileSummary:
    """One complete storage file: its entry in the metadata, its topics and their counts.

    Attributes
    ----------
    information : FileInformation
        Path (relative to the bag directory), log-time span [ns] and message count.
    topics : tuple of StoredTopic
        Every channel of the file, in channel order.
    counts : mapping of str to int
        Messages per topic.
    custom_data : mapping of str to str
        The ``custom_data`` of the file's last ``rosbag2`` metadata record.
    ros_distro : str
        Its ``ros_distro``.
    """

    information: FileInformation
    topics: tuple[StoredTopic, ...]
    counts: Mapping[str, int]
    custom_data: Mapping[str, str]
    ros_distro: str


class BagLock:
    """An exclusive lock on a bag directory, held by whoever writes or recovers the bag.

    The lock is the operating system's (``flock`` on the directory): it ends with the process
    that holds it, however that process ends, so a bag whose lock can be taken has no live
    writer.
    """

    def __init__(self, bag_dir: Path) -> None:
        self._fd: int | None = os.open(bag_dir, os.O_RDONLY | os.O_DIRECTORY)

    @classmethod
    def take(cls, bag_dir: Path) -> 'BagLock | None':
        """Lock ``bag_dir``; None when another process holds it (a writer at work)."""
        lock = cls(bag_dir)
        try:
            fcntl.flock(lock._fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            lock.release()
            return None
        return lock

    def release(self) -> None:
        """Release the lock (idempotent)."""
        if self._fd is not None:
            os.close(self._fd)  # closing the descriptor releases the flock
            self._fd = None


def file_index(name: str) -> int | None:
    """Return the index of a storage file named ``<bag>_<index>.mcap`` (None for another name)."""
    match = _FILE_NAME.match(name)
    return int(match['index']) if match else None


def storage_files(bag_dir: Path) -> list[Path]:
    """Return the bag's MCAP files, in the order of their index."""
    files = [p for p in Path(bag_dir).glob('*.mcap') if file_index(p.name) is not None]
    return sorted(files, key=lambda p: file_index(p.name))


def is_complete(path: Path) -> bool:
    """Say whether an MCAP file ends with its footer and a summary a reader can use."""
    try:
        with open(path, 'rb') as stream:
            stream.seek(0, os.SEEK_END)
            if stream.tell() < 2 * len(MAGIC):
                return False
            stream.seek(-len(MAGIC), os.SEEK_END)
            if stream.read(len(MAGIC)) != MAGIC:
                return False
            stream.seek(0)
            return make_reader(stream).get_summary() is not None
    except (OSError, McapError, ValueError, EOFError):
        return False


def summarize_file(path: Path) -> FileSummary:
    """Read a complete MCAP file's summary.

    Raises
    ------
    BagPathError
        If the file cannot be read or has no summary (it is incomplete).
    """
    try:
        with open(path, 'rb') as stream:
            reader = make_reader(stream)
            summary = reader.get_summary()
            if summary is None or summary.statistics is None:
                raise BagPathError(f'{path} has no summary: it was cut short; recover it')
            records = [m for m in reader.iter_metadata() if m.name == 'rosbag2']
    except (OSError, McapError, ValueError, EOFError) as error:
        raise BagPathError(f'cannot read {path}: {error}') from None
    stored = yaml.safe_load(records[-1].metadata.get('serialized_metadata', '')) \
        if records else {}
    stored = stored if isinstance(stored, Mapping) else {}
    topics = []
    for channel in summary.channels.values():
        schema = summary.schemas.get(channel.schema_id)
        definition = None
        if schema is not None and schema.encoding:
            definition = MessageDefinition(schema.name, schema.encoding, schema.data.decode())
        topics.append(StoredTopic(TopicMetadata(
            name=channel.topic, type=schema.name if schema is not None else '',
            offered_qos_profiles=qos_profiles_from_yaml(
                channel.metadata.get('offered_qos_profiles', '')),
            type_description_hash=channel.metadata.get('topic_type_hash', ''),
            serialization_format=channel.message_encoding), definition))
    statistics = summary.statistics
    counts = {channel.topic: statistics.channel_message_counts.get(channel_id, 0)
              for channel_id, channel in summary.channels.items()}
    count = statistics.message_count
    start = statistics.message_start_time if count else NO_MESSAGE_TIME_NS
    duration = statistics.message_end_time - statistics.message_start_time if count else 0
    return FileSummary(FileInformation(Path(path).name, start, duration, count), tuple(topics),
                       counts, {str(k): str(v) for k, v in
                                (stored.get('custom_data') or {}).items()},
                       str(stored.get('ros_distro', ROS_DISTRO)))


def combine_summaries(files: Iterable[FileInformation],
                      topics: Iterable[tuple[TopicMetadata, int]],
                      custom_data: Mapping[str, str], ros_distro: str) -> BagMetadata:
    """Return the bag's metadata from its files' entries and its topics with their counts."""
    files = tuple(files)
    with_messages = [f for f in files if f.message_count]
    start = min((f.starting_time_ns for f in with_messages), default=NO_MESSAGE_TIME_NS)
    end = max((f.starting_time_ns + f.duration_ns for f in with_messages), default=start)
    return BagMetadata(
        relative_file_paths=tuple(f.path for f in files), files=files,
        topics_with_message_count=tuple(TopicInformation(t, n) for t, n in topics),
        message_count=sum(f.message_count for f in files), starting_time_ns=start,
        duration_ns=end - start if with_messages else 0, custom_data=dict(custom_data),
        ros_distro=ros_distro)
