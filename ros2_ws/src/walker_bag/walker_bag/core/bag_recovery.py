"""Recovering a bag cut short by a crash: a complete copy of everything that reached the disk.

A recorder that is killed (SIGKILL, power cut, a fault in the process) leaves an MCAP file
without its summary and footer. Its complete chunks, everything up to the last flush, are
intact: a streaming MCAP reader reads them, but readers that start from the footer (rosbags,
``ros2 bag play``'s seeking reader) refuse the file. :func:`recover_bag` reads the file as a
stream up to the first incomplete record and writes a new, complete bag with the same topics
(types, definitions, offered QoS, type hashes), messages (log and publish times, sequence
numbers) and custom data. The damaged bag is left as it is.
"""

from __future__ import annotations

import dataclasses
import struct
from collections.abc import Iterator
from pathlib import Path
from typing import BinaryIO

import yaml
from mcap.exceptions import McapError
from mcap.records import Channel, McapRecord, Message, Metadata, Schema
from mcap.stream_reader import StreamReader

from walker_bag.core.bag_metadata import ROS_DISTRO, TopicMetadata, read_metadata
from walker_bag.core.bag_writer import BagWriter
from walker_bag.core.errors import BagExistsError, BagPathError, MetadataError
from walker_bag.core.message_definitions import MessageDefinition
from walker_bag.core.qos import qos_profiles_from_yaml

__all__ = ['RecoveryReport', 'recover_bag']


@dataclasses.dataclass(frozen=True)
class RecoveryReport:
    """What :func:`recover_bag` found and wrote.

    Attributes
    ----------
    source, destination : Path
        The damaged bag and the complete copy.
    message_count : int
        Messages copied.
    complete : bool
        True when the source file ended with a footer (it was not damaged after all).
    stopped_at : str
        Why reading stopped before the end (``''`` when complete).
    """

    source: Path
    destination: Path
    message_count: int
    complete: bool
    stopped_at: str


def _storage_file(bag_dir: Path) -> Path:
    try:
        files = read_metadata(bag_dir).relative_file_paths
    except MetadataError:
        files = tuple(p.name for p in sorted(bag_dir.glob('*.mcap')))
    if len(files) != 1:
        raise BagPathError(f'{bag_dir} holds {len(files)} MCAP files; recovery handles a bag '
                           f'of exactly one')
    return bag_dir / files[0]


class _IntactRecords:
    """The records of an MCAP stream up to the first incomplete or damaged one.

    A file cut short ends inside a record: reading it fails with an MCAP error, a short read
    (``struct.error``) or a CRC or text decoding error (``ValueError``). Iteration stops there
    and :attr:`stopped_at` says why (``''`` when the file ended with its footer).
    """

    def __init__(self, stream: BinaryIO) -> None:
        self._records = StreamReader(stream, skip_magic=False, validate_crcs=True).records
        self.stopped_at = ''

    def __iter__(self) -> Iterator[McapRecord]:
        while True:
            try:
                record = next(self._records)
            except StopIteration:
                return
            except (McapError, struct.error, ValueError) as error:
                self.stopped_at = f'{type(error).__name__} {error}'.strip()
                return
            yield record


def recover_bag(bag_dir: str | Path, destination: str | Path | None = None) -> RecoveryReport:
    """Write a complete copy of a (possibly crash-truncated) MCAP rosbag2 bag.

    Parameters
    ----------
    bag_dir : str or Path
        The damaged bag directory.
    destination : str or Path, optional
        The new bag directory; default ``<bag_dir>_recovered``. It must not exist.

    Raises
    ------
    BagPathError
        If ``bag_dir`` is not an MCAP bag of one file.
    BagExistsError
        If the destination exists.
    """
    source = Path(bag_dir)
    if not source.is_dir():
        raise BagPathError(f'{source} is not a bag directory')
    mcap_file = _storage_file(source)
    destination = Path(destination) if destination is not None else source.with_name(
        source.name + '_recovered')
    if destination.exists():
        raise BagExistsError(f'{destination} already exists; recovery never overwrites a bag')
    schemas: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    custom_data: dict[str, str] = {}
    ros_distro = ROS_DISTRO
    writer: BagWriter | None = None
    count = 0
    with open(mcap_file, 'rb') as stream:
        records = _IntactRecords(stream)
        for record in records:
            if isinstance(record, Schema):
                schemas[record.id] = record
            elif isinstance(record, Channel):
                channels[record.id] = record
            elif isinstance(record, Metadata) and record.name == 'rosbag2':
                stored = yaml.safe_load(record.metadata.get('serialized_metadata', '')) or {}
                custom_data = dict(stored.get('custom_data') or {})
                ros_distro = stored.get('ros_distro', ros_distro)
            elif isinstance(record, Message):
                if writer is None:
                    writer = BagWriter(destination, custom_data=custom_data,
                                       ros_distro=ros_distro)
                channel = channels[record.channel_id]
                if channel.topic not in writer.topics:
                    _add_topic(writer, channel, schemas.get(channel.schema_id))
                writer.write(channel.topic, record.data, record.log_time, record.publish_time,
                             record.sequence)
                count += 1
    if writer is None:
        writer = BagWriter(destination, custom_data=custom_data, ros_distro=ros_distro)
    for channel in channels.values():
        _add_topic(writer, channel, schemas.get(channel.schema_id))
    writer.close()
    complete = records.stopped_at == ''
    stopped_at = records.stopped_at
    return RecoveryReport(source, destination, count, complete, stopped_at)


def _add_topic(writer: BagWriter, channel: Channel, schema: Schema | None) -> None:
    """Add a channel's topic with its stored QoS, hash and definition (if not yet added)."""
    type_name = schema.name if schema is not None else ''
    definition = None
    if schema is not None and schema.encoding:
        definition = MessageDefinition(type_name, schema.encoding, schema.data.decode())
    topic = TopicMetadata(
        name=channel.topic, type=type_name,
        offered_qos_profiles=qos_profiles_from_yaml(
            channel.metadata.get('offered_qos_profiles', '')),
        type_description_hash=channel.metadata.get('topic_type_hash', ''),
        serialization_format=channel.message_encoding)
    writer.add_topic(topic, definition)
