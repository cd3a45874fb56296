"""The bag writer: a rosbag2 bag in MCAP storage, written as ROS 2 Jazzy's recorder writes it.

A bag is a directory ``<name>/`` holding its storage files ``<name>_0.mcap``, ``<name>_1.mcap``,
... (:mod:`walker_bag.core.mcap_file`: the ``ros2`` MCAP profile exactly as Jazzy's
``rosbag2_storage_mcap`` writes it) and ``metadata.yaml``. A bag goes on in a new file when
its current one reaches a size or a duration, and may keep only its newest files
(:class:`~walker_bag.core.bag_split.SplitPolicy`, as ``ros2 bag record --max-bag-size /
--max-bag-duration``); a finished file has its summary and footer, so every reader opens it.

What this writer adds for crash safety: received messages are written out in complete chunks
whenever a chunk is full *or* :meth:`BagWriter.flush` is called (the recorder calls it
periodically), and every flush replaces ``metadata.yaml`` atomically with what the files then
hold. A process killed at any moment therefore leaves files whose complete chunks hold every
message up to the last flush, and a ``metadata.yaml`` that describes exactly those messages.
The writer holds a lock on the bag directory (:class:`~walker_bag.core.bag_files.BagLock`)
while it writes, which ends with its process: :mod:`walker_bag.core.bag_recovery` completes
the last file of a bag whose writer is gone, in place, and a writer opened with ``append``
does that first, then continues the bag in a new file (a recorder started again after a
crash).

Not implemented (not needed by the walker): compression.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from pathlib import Path

from walker_bag.core.bag_files import (
    BagLock, StoredTopic, combine_summaries, file_index, storage_files, summarize_file)
from walker_bag.core.bag_metadata import (
    ROS_DISTRO, BagMetadata, FileInformation, TopicMetadata, write_metadata)
from walker_bag.core.bag_recovery import recover_file
from walker_bag.core.bag_split import NO_SPLIT, SplitPolicy
from walker_bag.core.errors import (
    BagClosedError, BagError, BagExistsError, BagPathError, TopicConflictError,
    UnknownTopicError)
from walker_bag.core.mcap_file import (
    DEFAULT_CHUNK_SIZE, LIBRARY, MCAP_PROFILE, McapFile, check_times)
from walker_bag.core.message_definitions import MessageDefinition

__all__ = ['DEFAULT_CHUNK_SIZE', 'MCAP_PROFILE', 'LIBRARY', 'BagWriter']


@dataclasses.dataclass(frozen=True)
class _FinishedFile:
    information: FileInformation
    counts: Mapping[str, int]


class BagWriter:
    """Write a rosbag2 bag (MCAP storage, metadata version 9) that survives a crash.

    Parameters
    ----------
    bag_dir : str or Path
        The bag directory to create; its parents are created as needed. It must not exist,
        unless ``append``.
    max_chunk_size : int
        A chunk is written out when its messages reach this many bytes [bytes].
    custom_data : mapping of str to str, optional
        rosbag2's ``custom_data``: free key-value pairs stored in the metadata.
    ros_distro : str
        The ``ros_distro`` of the metadata.
    split : SplitPolicy
        When the bag goes on in a new file, and how many files it keeps.
    append : bool
        Continue an existing bag in a new file (after completing its last file, if its writer
        was killed); a bag that does not exist yet is created.

    Raises
    ------
    BagExistsError
        If ``bag_dir`` exists and not ``append`` (a bag is never overwritten).
    BagPathError
        If the directory or its files cannot be created, or another process writes the bag.
    BagError
        If ``max_chunk_size`` is not a positive integer or ``custom_data`` not string pairs.

    Notes
    -----
    Not thread-safe: call it from one thread (the recorder's executor). Use it as a context
    manager, or call :meth:`close` in a ``finally``; closing twice is harmless.
    """

    def __init__(self, bag_dir: str | Path, *, max_chunk_size: int = DEFAULT_CHUNK_SIZE,
                 custom_data: Mapping[str, str] | None = None,
                 ros_distro: str = ROS_DISTRO, split: SplitPolicy = NO_SPLIT,
                 append: bool = False) -> None:
        if isinstance(max_chunk_size, bool) or not isinstance(max_chunk_size, int) \
                or max_chunk_size <= 0:
            raise BagError(f'max_chunk_size must be a positive integer [bytes], '
                           f'got {max_chunk_size!r}')
        custom_data = dict(custom_data or {})
        if not all(isinstance(k, str) and isinstance(v, str) for k, v in custom_data.items()):
            raise BagError('custom_data must map strings to strings')
        if not isinstance(split, SplitPolicy):
            raise BagError(f'split must be a SplitPolicy, got {type(split).__name__}')
        self._dir = Path(bag_dir)
        if not self._dir.name or self._dir.name in ('.', '..'):
            raise BagPathError(f'{str(bag_dir)!r} does not name a bag directory')
        self._max_chunk_size = max_chunk_size
        self._ros_distro = ros_distro
        self._split = split
        self._topics: dict[str, StoredTopic] = {}
        self._finished: list[_FinishedFile] = []
        self._custom_data: dict[str, str] = {}
        self._metadata_changed = False
        if append and self._dir.is_dir():
            self._lock = self._take_lock()
            self._continue_bag()
        else:
            self._lock = self._create_bag()
        self._custom_data.update(custom_data)
        self._closed = False
        self._current: McapFile | None = None
        try:
            self._current = self._open_file()
        except BaseException:
            self._lock.release()
            raise
        write_metadata(self._dir, self._metadata(flushed_only=True))

    # -- properties -------------------------------------------------------------------------

    @property
    def path(self) -> Path:
        """The bag directory."""
        return self._dir

    @property
    def storage_file(self) -> Path:
        """The MCAP file being written now."""
        return self._current.path

    @property
    def files(self) -> list[str]:
        """The bag's storage files now, oldest first (relative to the bag directory)."""
        return [f.information.path for f in self._finished] + [self._current.name]

    @property
    def closed(self) -> bool:
        """True once :meth:`close` has run."""
        return self._closed

    @property
    def message_count(self) -> int:
        """Messages in the bag's files (including those not yet flushed)."""
        return sum(f.information.message_count for f in self._finished) \
            + self._current.written.count

    @property
    def flushed_message_count(self) -> int:
        """Messages written out to the files (what survives a crash now)."""
        return sum(f.information.message_count for f in self._finished) \
            + self._current.flushed.count

    @property
    def topics(self) -> dict[str, TopicMetadata]:
        """The topics added so far, by name."""
        return {name: stored.metadata for name, stored in self._topics.items()}

    @property
    def earlier_files(self) -> list[tuple[FileInformation, Mapping[str, int]]]:
        """The files this writer found and continued (``append``): information and counts."""
        return [(f.information, dict(f.counts)) for f in self._finished]

    @property
    def custom_data(self) -> dict[str, str]:
        """rosbag2's ``custom_data`` (a copy)."""
        return dict(self._custom_data)

    def message_counts(self) -> dict[str, int]:
        """Messages per topic in the bag's files (including those not yet flushed)."""
        return self._counts(flushed_only=False)

    # -- writing ----------------------------------------------------------------------------

    def add_topic(self, topic: TopicMetadata, definition: MessageDefinition | None) -> bool:
        """Add a topic (MCAP schema and channel) before writing its messages.

        Parameters
        ----------
        topic : TopicMetadata
            Name, type, offered QoS and type hash.
        definition : MessageDefinition or None
            The type's schema; ``None`` when it is unknown (the schema is then empty, and
            readers need the type from elsewhere).

        Returns
        -------
        bool
            True if added, False if the same topic with the same type was already there.

        Raises
        ------
        TopicConflictError
            If the topic exists with another type, the name is not absolute, the format is not
            ``cdr``, or the definition is of another type.
        """
        self._check_open()
        if not isinstance(topic, TopicMetadata):
            raise TopicConflictError(f'expected a TopicMetadata, got {type(topic).__name__}')
        if not topic.name.startswith('/'):
            raise TopicConflictError(f'topic name {topic.name!r} must be fully qualified '
                                     f'(start with /)')
        if topic.serialization_format != 'cdr':
            raise TopicConflictError(f'topic {topic.name}: serialization format '
                                     f'{topic.serialization_format!r} is not cdr')
        known = self._topics.get(topic.name)
        if known is not None:
            if known.metadata.type != topic.type:
                raise TopicConflictError(
                    f'topic {topic.name} is recorded as {known.metadata.type}; it cannot also '
                    f'be {topic.type}')
            return False
        self._current.add_topic(topic, definition)
        self._topics[topic.name] = StoredTopic(topic, definition)
        return True

    def write(self, topic_name: str, data: bytes | bytearray | memoryview, log_time_ns: int,
              publish_time_ns: int | None = None, sequence: int = 0) -> None:
        """Write one serialized (CDR) message.

        Parameters
        ----------
        topic_name : str
            A topic added with :meth:`add_topic`.
        data : bytes-like
            The CDR bytes, as received.
        log_time_ns : int
            Receive time [ns]: the time messages are ordered and played back by.
        publish_time_ns : int, optional
            The publisher's source time [ns]; the log time when not given (MCAP's rule).
        sequence : int
            The publisher's sequence number (stored modulo 2**32, as MCAP's field is 32 bits).

        Raises
        ------
        UnknownTopicError
            If the topic was not added.
        BagError
            If a time is not a non-negative integer or ``data`` is not bytes.
        BagClosedError
            If the bag is closed.
        """
        self._check_open()
        if topic_name not in self._topics:
            raise UnknownTopicError(f'topic {topic_name!r} was not added to the bag; add it '
                                    f'with add_topic() before writing')
        publish_time_ns = log_time_ns if publish_time_ns is None else publish_time_ns
        check_times(log_time_ns, publish_time_ns)
        if not isinstance(data, (bytes, bytearray, memoryview)):
            raise BagError(f'message data must be bytes, got {type(data).__name__}')
        current = self._current
        if self._split.split_due(current.size, current.written.start
                                 if current.written.count else None, log_time_ns):
            self.split()
        self._current.write(topic_name, bytes(data), log_time_ns, publish_time_ns, sequence)
        if self._current.chunk_full:
            self.flush()

    def set_custom_data(self, key: str, value: str) -> None:
        """Set one ``custom_data`` entry; it reaches ``metadata.yaml`` at the next flush."""
        if not isinstance(key, str) or not isinstance(value, str):
            raise BagError('custom_data must map strings to strings')
        if self._custom_data.get(key) != value:
            self._custom_data[key] = value
            self._metadata_changed = True

    def flush(self) -> None:
        """Write out the chunk in progress and replace ``metadata.yaml`` to match the files.

        After it returns, every message written so far is in the files (in the operating
        system's hands: it survives the process being killed). Does nothing when nothing was
        written (nor custom data set) since the last flush.
        """
        self._check_open()
        if self._current.flush() or self._metadata_changed:
            self._metadata_changed = False
            write_metadata(self._dir, self._metadata(flushed_only=True))

    def split(self) -> None:
        """Finish the current file and go on in the next one (then keep ``max_files``)."""
        self._check_open()
        finished, self._current = self._current, None
        finished.finish()
        self._finished.append(_FinishedFile(finished.information(flushed_only=False),
                                            dict(finished.counts)))
        self._current = self._open_file()
        total = len(self._finished) + 1
        for _ in range(min(self._split.files_to_delete(total), len(self._finished))):
            oldest = self._finished.pop(0)
            (self._dir / oldest.information.path).unlink(missing_ok=True)
        write_metadata(self._dir, self._metadata(flushed_only=True))

    def close(self) -> BagMetadata:
        """Finish the bag: last chunk, metadata record, summary, footer, ``metadata.yaml``.

        Returns the final metadata. Closing a closed bag returns the metadata again.
        """
        if self._closed:
            return self._metadata(flushed_only=False)
        self._closed = True
        if self._current is not None:
            self._current.finish()
        metadata = self._metadata(flushed_only=False)
        write_metadata(self._dir, metadata)
        self._lock.release()
        return metadata

    def __enter__(self) -> 'BagWriter':
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    # -- internals --------------------------------------------------------------------------

    def _check_open(self) -> None:
        if self._closed:
            raise BagClosedError(f'the bag {self._dir} is closed')

    def _create_bag(self) -> BagLock:
        if self._dir.exists() or self._dir.is_symlink():
            raise BagExistsError(f'bag directory {self._dir} already exists; a recording never '
                                 f'overwrites a bag: choose another name')
        try:
            self._dir.mkdir(parents=True)
        except OSError as error:
            raise BagPathError(
                f'cannot create the bag directory {self._dir}: {error.strerror}') from None
        self._next_index = 0
        return self._take_lock()

    def _take_lock(self) -> BagLock:
        lock = BagLock.take(self._dir)
        if lock is None:
            raise BagPathError(f'{self._dir} is being written by another process')
        return lock

    def _continue_bag(self) -> None:
        """Take in the files of an existing bag, completing a cut one first."""
        try:
            files = storage_files(self._dir)
            for path in files:
                recover_file(path)
            summaries = [summarize_file(path) for path in files]
        except BaseException:
            self._lock.release()
            raise
        for summary in summaries:
            self._finished.append(_FinishedFile(summary.information, summary.counts))
            self._custom_data.update(summary.custom_data)
            for stored in summary.topics:
                self._topics.setdefault(stored.metadata.name, stored)
        self._next_index = file_index(files[-1].name) + 1 if files else 0

    def _open_file(self) -> McapFile:
        path = self._dir / f'{self._dir.name}_{self._next_index}.mcap'
        self._next_index += 1
        current = McapFile(path, self._max_chunk_size,
                           lambda: self._metadata(flushed_only=False).dump(root=False))
        for stored in self._topics.values():
            current.add_topic(stored.metadata, stored.definition)
        return current

    def _counts(self, flushed_only: bool) -> dict[str, int]:
        counts = dict.fromkeys(self._topics, 0)
        for finished in self._finished:
            for name, count in finished.counts.items():
                counts[name] = counts.get(name, 0) + count
        current = self._current.flushed_counts if flushed_only else self._current.counts
        for name, count in current.items():
            counts[name] = counts.get(name, 0) + count
        return counts

    def _metadata(self, flushed_only: bool) -> BagMetadata:
        current = self._current
        files = [f.information for f in self._finished]
        if current is not None:
            files.append(current.information(flushed_only))
            counts = self._counts(flushed_only)
        else:
            counts = dict.fromkeys(self._topics, 0)
        return combine_summaries(files, [(stored.metadata, counts.get(name, 0))
                                         for name, stored in self._topics.items()],
                                 self._custom_data, self._ros_distro)
