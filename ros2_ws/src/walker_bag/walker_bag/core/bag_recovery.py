"""Recovering a bag cut short by a crash: its files completed, everything that reached the disk.

A recorder that is killed (SIGKILL, power cut, a fault in the process) leaves its current MCAP
file without its summary and footer. Its complete chunks, everything up to the last flush, are
intact, but every reader that starts from the footer refuses the file: ``mcap``'s
``make_reader(...).iter_messages()``, rosbags, ``ros2 bag play``. :func:`recover_file` reads
such a file as a stream up to the first incomplete record and writes it again, complete, with
the same topics (types, definitions, offered QoS, type hashes), messages (log and publish
times, sequence numbers) and custom data; the cut original is kept beside it as
``<file>.incomplete``. :func:`recover_in_place` does that for every cut file of a bag whose
writer is gone (no process holds its lock) and writes its ``metadata.yaml`` again from the
files; the recorder calls it on the bags of its directory when it starts, and ``run_all.py``
on its bags when the graph is down. :func:`recover_bag` makes a recovered copy instead.
"""

from __future__ import annotations

import dataclasses
import os
import shutil
import struct
from collections.abc import Iterator
from pathlib import Path
from typing import BinaryIO

import yaml
from mcap.exceptions import McapError
from mcap.records import Channel, McapRecord, Message, Metadata, Schema
from mcap.stream_reader import StreamReader

from walker_bag.core.bag_files import (
    BagLock, combine_summaries, is_complete, storage_files, summarize_file)
from walker_bag.core.bag_metadata import (
    METADATA_FILE, ROS_DISTRO, BagMetadata, TopicMetadata, write_metadata)
from walker_bag.core.errors import BagExistsError, BagPathError
from walker_bag.core.mcap_file import DEFAULT_CHUNK_SIZE, McapFile
from walker_bag.core.message_definitions import MessageDefinition
from walker_bag.core.qos import qos_profiles_from_yaml

__all__ = ['INCOMPLETE_SUFFIX', 'FileRecovery', 'RecoveryReport', 'recover_file',
           'recover_in_place', 'recover_bag', 'recover_abandoned_bags']

#: Suffix of a cut file kept beside its recovered version.
INCOMPLETE_SUFFIX = '.incomplete'
_RECOVERING_SUFFIX = '.recovering'


@dataclasses.dataclass(frozen=True)
class FileRecovery:
    """One cut file made complete: its path, the messages kept, and why reading stopped."""

    path: Path
    message_count: int
    stopped_at: str


@dataclasses.dataclass(frozen=True)
class RecoveryReport:
    """What :func:`recover_in_place` or :func:`recover_bag` found and wrote.

    Attributes
    ----------
    source, destination : Path
        The bag recovered and the bag written (the same bag when recovered in place).
    message_count : int
        Messages in the recovered bag.
    complete : bool
        True when every file ended with its footer (nothing was damaged).
    stopped_at : str
        Why reading the cut file stopped early (``''`` when complete; the first one's).
    files : tuple of FileRecovery
        The cut files completed.
    """

    source: Path
    destination: Path
    message_count: int
    complete: bool
    stopped_at: str
    files: tuple[FileRecovery, ...] = ()


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


def _stored_topic(channel: Channel, schema: Schema | None
                  ) -> tuple[TopicMetadata, MessageDefinition | None]:
    type_name = schema.name if schema is not None else ''
    definition = None
    if schema is not None and schema.encoding:
        definition = MessageDefinition(type_name, schema.encoding, schema.data.decode())
    return TopicMetadata(
        name=channel.topic, type=type_name,
        offered_qos_profiles=qos_profiles_from_yaml(
            channel.metadata.get('offered_qos_profiles', '')),
        type_description_hash=channel.metadata.get('topic_type_hash', ''),
        serialization_format=channel.message_encoding), definition


def _rewrite(source: Path, destination: Path) -> tuple[int, str]:
    """Write the intact records of ``source`` into a complete ``destination``.

    Returns the messages written and why reading stopped (``''`` at a footer).
    """
    schemas: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    stored: dict = {'custom_data': {}, 'ros_distro': ROS_DISTRO}
    topics: dict[str, list] = {}  # per topic: its metadata, its messages written

    def serialized() -> str:  # the file's own metadata, for its rosbag2 metadata record
        files = [target.information(flushed_only=False)] if target is not None else []
        return combine_summaries(files, [tuple(t) for t in topics.values()],
                                 stored['custom_data'], stored['ros_distro']).dump(root=False)

    target = None
    target = McapFile(destination, DEFAULT_CHUNK_SIZE, serialized)
    with open(source, 'rb') as stream:
        records = _IntactRecords(stream)
        for record in records:
            if isinstance(record, Schema):
                schemas[record.id] = record
            elif isinstance(record, Channel):
                channels[record.id] = record
                metadata, definition = _stored_topic(record, schemas.get(record.schema_id))
                target.add_topic(metadata, definition)
                topics.setdefault(record.topic, [metadata, 0])
            elif isinstance(record, Metadata) and record.name == 'rosbag2':
                kept = yaml.safe_load(record.metadata.get('serialized_metadata', '')) or {}
                if isinstance(kept, dict):
                    stored['custom_data'] = dict(kept.get('custom_data') or {})
                    stored['ros_distro'] = kept.get('ros_distro', ROS_DISTRO)
            elif isinstance(record, Message) and record.channel_id in channels:
                topic = channels[record.channel_id].topic
                target.write(topic, record.data, record.log_time, record.publish_time,
                             record.sequence)
                topics[topic][1] += 1
                if target.chunk_full:
                    target.flush()
    target.finish()
    return target.written.count, records.stopped_at


def recover_file(path: Path) -> FileRecovery | None:
    """Complete a cut MCAP file in place, keeping the original as ``<file>.incomplete``.

    Returns None when the file is complete. At every moment the file's own name holds either
    the cut file or the complete one: the complete copy is written beside it, then renamed
    over it.
    """
    path = Path(path)
    if is_complete(path):
        return None
    temporary = path.with_name(path.name + _RECOVERING_SUFFIX)
    temporary.unlink(missing_ok=True)  # a recovery interrupted before
    count, stopped_at = _rewrite(path, temporary)
    kept = path.with_name(path.name + INCOMPLETE_SUFFIX)
    kept.unlink(missing_ok=True)
    os.link(path, kept)
    os.replace(temporary, path)
    return FileRecovery(path, count, stopped_at)


def _reindex(bag_dir: Path, keep_custom_data: bool = True) -> BagMetadata:
    """Write ``metadata.yaml`` again from the bag's (complete) files; return it."""
    summaries = [summarize_file(path) for path in storage_files(bag_dir)]
    custom_data: dict[str, str] = {}
    topics: dict[str, list] = {}
    for summary in summaries:
        custom_data.update(summary.custom_data if keep_custom_data else {})
        for stored in summary.topics:
            entry = topics.setdefault(stored.metadata.name, [stored.metadata, 0])
            entry[1] += summary.counts.get(stored.metadata.name, 0)
    distro = summaries[-1].ros_distro if summaries else ROS_DISTRO
    metadata = combine_summaries([s.information for s in summaries],
                                 [tuple(t) for t in topics.values()], custom_data, distro)
    write_metadata(bag_dir, metadata)
    return metadata


def recover_in_place(bag_dir: str | Path) -> RecoveryReport | None:
    """Complete every cut file of a bag whose writer is gone, and its ``metadata.yaml``.

    Returns None when a live process writes the bag (it holds its lock), a report otherwise
    (``complete`` when nothing needed recovery; the metadata is then left as it is).

    Raises
    ------
    BagPathError
        If ``bag_dir`` is not a bag directory with MCAP files.
    """
    bag_dir = Path(bag_dir)
    files = storage_files(bag_dir) if bag_dir.is_dir() else []
    if not files:
        raise BagPathError(f'{bag_dir} is not a bag directory (no <name>_<index>.mcap file)')
    lock = BagLock.take(bag_dir)
    if lock is None:
        return None
    try:
        recovered = tuple(r for r in (recover_file(path) for path in files) if r is not None)
        if recovered or not (bag_dir / METADATA_FILE).exists():
            count = _reindex(bag_dir).message_count
        else:
            count = sum(summarize_file(path).information.message_count for path in files)
    finally:
        lock.release()
    return RecoveryReport(bag_dir, bag_dir, count, not recovered,
                          recovered[0].stopped_at if recovered else '', recovered)


def recover_bag(bag_dir: str | Path, destination: str | Path | None = None) -> RecoveryReport:
    """Write a recovered copy of a (possibly crash-truncated) bag, leaving it untouched.

    Parameters
    ----------
    bag_dir : str or Path
        The bag directory.
    destination : str or Path, optional
        The new bag directory; default ``<bag_dir>_recovered``. It must not exist.

    Raises
    ------
    BagPathError
        If ``bag_dir`` is not a bag directory with MCAP files, or another process writes it.
    BagExistsError
        If the destination exists.
    """
    source = Path(bag_dir)
    files = storage_files(source) if source.is_dir() else []
    if not files:
        raise BagPathError(f'{source} is not a bag directory (no <name>_<index>.mcap file)')
    destination = Path(destination) if destination is not None else source.with_name(
        source.name + '_recovered')
    if destination.exists():
        raise BagExistsError(f'{destination} already exists; recovery never overwrites a bag')
    destination.mkdir(parents=True)
    recovered = []
    for path in files:
        copy = destination / f'{destination.name}_{path.name.rsplit("_", 1)[1]}'
        if is_complete(path):
            shutil.copyfile(path, copy)
        else:
            count, stopped_at = _rewrite(path, copy)
            recovered.append(FileRecovery(copy, count, stopped_at))
    count = _reindex(destination).message_count
    return RecoveryReport(source, destination, count, not recovered,
                          recovered[0].stopped_at if recovered else '', tuple(recovered))


def recover_abandoned_bags(directory: str | Path) -> list[RecoveryReport]:
    """Recover, in place, every bag directly under ``directory`` that a killed writer left cut.

    Bags written by a live process (locked) and complete bags are left alone.
    """
    reports = []
    directory = Path(directory)
    if not directory.is_dir():
        return reports
    for bag_dir in sorted(p for p in directory.iterdir() if p.is_dir()):
        files = storage_files(bag_dir)
        if not files or all(is_complete(path) for path in files):
            continue
        report = recover_in_place(bag_dir)
        if report is not None:
            reports.append(report)
    return reports
