"""The bag writer: a rosbag2 bag in MCAP storage, written as ROS 2 Jazzy's recorder writes it.

A bag is a new directory ``<name>/`` holding ``<name>_0.mcap`` and ``metadata.yaml``. The MCAP
file follows the ``ros2`` profile exactly as Jazzy's ``rosbag2_storage_mcap`` writes it:

- one *schema* per message type: name ``pkg/msg/Type``, encoding ``ros2msg``, data the
  concatenated ``.msg`` text (:mod:`walker_bag.core.message_definitions`);
- one *channel* per topic: message encoding ``cdr`` and the metadata keys
  ``offered_qos_profiles`` (the publishers' QoS, version-9 YAML text) and ``topic_type_hash``
  (``RIHS01_...``);
- *messages* holding the CDR bytes exactly as received, with log time = receive time and
  publish time = the publisher's source time [ns];
- a ``rosbag2`` metadata record with key ``serialized_metadata`` (the bag's metadata as YAML),
  written when the bag opens and again when it closes, and on close the summary section
  (schemas, channels, statistics, chunk and metadata indexes) and footer;
- chunks without compression (Jazzy's default), up to ``max_chunk_size`` bytes each
  (768 KiB by default, the chunk size of Jazzy's writer), with message indexes.

What this writer adds for crash safety: a chunk is written out as soon as it is full *or*
:meth:`BagWriter.flush` is called (the recorder calls it periodically), and every flush
replaces ``metadata.yaml`` atomically with the counts of the messages written out so far. A
process killed at any moment therefore leaves an MCAP file whose complete chunks hold every
message up to the last flush (a streaming MCAP reader reads them; the summary and footer are
missing), and a ``metadata.yaml`` that describes exactly those messages.
:func:`walker_bag.core.bag_recovery.recover_bag` turns such a file into a complete bag.

Not implemented (not needed by the walker): splitting into several files, compression.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Mapping
from pathlib import Path

from mcap import __version__ as mcap_version
from mcap.writer import CompressionType, Writer

from walker_bag.core.bag_metadata import (
    BagMetadata, FileInformation, NO_MESSAGE_TIME_NS, ROS_DISTRO, TopicInformation,
    TopicMetadata, write_metadata)
from walker_bag.core.errors import (
    BagClosedError, BagError, BagExistsError, BagPathError, TopicConflictError,
    UnknownTopicError)
from walker_bag.core.message_definitions import MessageDefinition
from walker_bag.core.qos import qos_profiles_to_yaml

__all__ = ['DEFAULT_CHUNK_SIZE', 'MCAP_PROFILE', 'LIBRARY', 'BagWriter']

#: Chunk size of ROS 2 Jazzy's MCAP writer (libmcap's default) [bytes].
DEFAULT_CHUNK_SIZE = 768 * 1024
MCAP_PROFILE = 'ros2'
#: The MCAP header's library string: who wrote the file.
LIBRARY = f'walker_bag 0.1.0 (mcap-python {mcap_version})'
_MESSAGE_RECORD_OVERHEAD = 1 + 8 + 2 + 4 + 8 + 8  # opcode, length, channel, sequence, 2 times
_RECORD_OVERHEAD = 64  # opcode, length, ids and string lengths of a schema or channel record
_UINT32 = 2**32


@dataclasses.dataclass
class _TopicState:
    metadata: TopicMetadata
    channel_id: int
    written: int = 0
    flushed: int = 0


@dataclasses.dataclass
class _Span:
    """Message count and log-time span of a set of messages [ns]."""

    count: int = 0
    start: int = NO_MESSAGE_TIME_NS
    end: int = 0

    def add(self, log_time: int) -> None:
        self.count += 1
        self.start = min(self.start, log_time)
        self.end = max(self.end, log_time)

    @property
    def duration(self) -> int:
        return self.end - self.start if self.count else 0


class BagWriter:
    """Write a rosbag2 bag (MCAP storage, metadata version 9) that survives a crash.

    Parameters
    ----------
    bag_dir : str or Path
        The bag directory to create; its parents are created as needed. It must not exist.
    max_chunk_size : int
        A chunk is written out when its messages reach this many bytes [bytes].
    custom_data : mapping of str to str, optional
        rosbag2's ``custom_data``: free key-value pairs stored in the metadata.
    ros_distro : str
        The ``ros_distro`` of the metadata.

    Raises
    ------
    BagExistsError
        If ``bag_dir`` exists (a bag is never overwritten).
    BagPathError
        If the directory or its files cannot be created.
    BagError
        If ``max_chunk_size`` is not a positive integer or ``custom_data`` not string pairs.

    Notes
    -----
    Not thread-safe: call it from one thread (the recorder's executor). Use it as a context
    manager, or call :meth:`close` in a ``finally``; closing twice is harmless.
    """

    def __init__(self, bag_dir: str | Path, *, max_chunk_size: int = DEFAULT_CHUNK_SIZE,
                 custom_data: Mapping[str, str] | None = None,
                 ros_distro: str = ROS_DISTRO) -> None:
        if isinstance(max_chunk_size, bool) or not isinstance(max_chunk_size, int) \
                or max_chunk_size <= 0:
            raise BagError(f'max_chunk_size must be a positive integer [bytes], '
                           f'got {max_chunk_size!r}')
        custom_data = dict(custom_data or {})
        if not all(isinstance(k, str) and isinstance(v, str) for k, v in custom_data.items()):
            raise BagError('custom_data must map strings to strings')
        self._dir = Path(bag_dir)
        if self._dir.exists() or self._dir.is_symlink():
            raise BagExistsError(f'bag directory {self._dir} already exists; a recording never '
                                 f'overwrites a bag: choose another name')
        if not self._dir.name or self._dir.name in ('.', '..'):
            raise BagPathError(f'{str(bag_dir)!r} does not name a bag directory')
        try:
            self._dir.mkdir(parents=True)
        except OSError as error:
            raise BagPathError(
                f'cannot create the bag directory {self._dir}: {error.strerror}') from None
        self._file_name = f'{self._dir.name}_0.mcap'
        try:
            self._stream = open(self._dir / self._file_name, 'xb')
        except OSError as error:
            self._dir.rmdir()
            raise BagPathError(f'cannot create {self._dir / self._file_name}: '
                               f'{error.strerror}') from None
        self._max_chunk_size = max_chunk_size
        self._custom_data = custom_data
        self._ros_distro = ros_distro
        # Chunks are cut here, not by the library, so that every write-out is known.
        self._mcap = Writer(self._stream, chunk_size=2**62, compression=CompressionType.NONE)
        self._topics: dict[str, _TopicState] = {}
        self._schemas: dict[str, int] = {}
        self._pending_bytes = 0
        self._written = _Span()
        self._flushed = _Span()
        self._closed = False
        self._mcap.start(profile=MCAP_PROFILE, library=LIBRARY)
        self._write_metadata_record()
        self._stream.flush()
        write_metadata(self._dir, self._metadata(flushed_only=True))

    # -- properties -------------------------------------------------------------------------

    @property
    def path(self) -> Path:
        """The bag directory."""
        return self._dir

    @property
    def storage_file(self) -> Path:
        """The MCAP file inside the bag directory."""
        return self._dir / self._file_name

    @property
    def closed(self) -> bool:
        """True once :meth:`close` has run."""
        return self._closed

    @property
    def message_count(self) -> int:
        """Messages written so far (including those not yet flushed)."""
        return self._written.count

    @property
    def flushed_message_count(self) -> int:
        """Messages written out to the file (what survives a crash now)."""
        return self._flushed.count

    @property
    def topics(self) -> dict[str, TopicMetadata]:
        """The topics added so far, by name."""
        return {name: state.metadata for name, state in self._topics.items()}

    def message_counts(self) -> dict[str, int]:
        """Messages written so far per topic."""
        return {name: state.written for name, state in self._topics.items()}

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
        if definition is not None and definition.type_name != topic.type:
            raise TopicConflictError(f'topic {topic.name} has type {topic.type} but the '
                                     f'definition given is of {definition.type_name}')
        schema_id = self._schemas.get(topic.type)
        if schema_id is None:
            encoding, text = ('', '') if definition is None else (definition.encoding,
                                                                  definition.text)
            schema_id = self._mcap.register_schema(topic.type, encoding, text.encode())
            self._schemas[topic.type] = schema_id
            self._pending_bytes += len(text) + len(topic.type) + _RECORD_OVERHEAD
        channel_metadata = {
            'offered_qos_profiles': qos_profiles_to_yaml(topic.offered_qos_profiles),
            'topic_type_hash': topic.type_description_hash}
        channel_id = self._mcap.register_channel(
            topic.name, topic.serialization_format, schema_id, channel_metadata)
        self._pending_bytes += len(topic.name) + sum(
            len(k) + len(v) for k, v in channel_metadata.items()) + _RECORD_OVERHEAD
        self._topics[topic.name] = _TopicState(topic, channel_id)
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
        state = self._topics.get(topic_name)
        if state is None:
            raise UnknownTopicError(f'topic {topic_name!r} was not added to the bag; add it '
                                    f'with add_topic() before writing')
        publish_time_ns = log_time_ns if publish_time_ns is None else publish_time_ns
        for name, value in (('log_time_ns', log_time_ns), ('publish_time_ns', publish_time_ns)):
            if isinstance(value, bool) or not isinstance(value, int) or not (
                    0 <= value < 2**64):
                raise BagError(f'{name} must be a non-negative integer [ns], got {value!r}')
        if not isinstance(data, (bytes, bytearray, memoryview)):
            raise BagError(f'message data must be bytes, got {type(data).__name__}')
        data = bytes(data)
        self._mcap.add_message(state.channel_id, log_time=log_time_ns, data=data,
                               publish_time=publish_time_ns, sequence=sequence % _UINT32)
        state.written += 1
        self._written.add(log_time_ns)
        self._pending_bytes += len(data) + _MESSAGE_RECORD_OVERHEAD
        if self._pending_bytes >= self._max_chunk_size:
            self.flush()

    def flush(self) -> None:
        """Write out the chunk in progress and replace ``metadata.yaml`` to match the file.

        After it returns, every message written so far is in the file (in the operating
        system's hands: it survives the process being killed). Does nothing when nothing was
        written since the last flush.
        """
        self._check_open()
        if self._flushed.count == self._written.count:
            return
        self._mcap.flush()
        self._pending_bytes = 0
        self._flushed = dataclasses.replace(self._written)
        for state in self._topics.values():
            state.flushed = state.written
        write_metadata(self._dir, self._metadata(flushed_only=True))

    def close(self) -> BagMetadata:
        """Finish the bag: last chunk, metadata record, summary, footer, ``metadata.yaml``.

        Returns the final metadata. Closing a closed bag returns the metadata again.
        """
        if self._closed:
            return self._metadata(flushed_only=False)
        self._closed = True
        self._flushed = dataclasses.replace(self._written)
        for state in self._topics.values():
            state.flushed = state.written
        metadata = self._metadata(flushed_only=False)
        self._mcap.flush()
        self._write_metadata_record()
        self._mcap.finish()
        self._stream.flush()
        os.fsync(self._stream.fileno())
        self._stream.close()
        write_metadata(self._dir, metadata)
        return metadata

    def __enter__(self) -> 'BagWriter':
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    # -- internals --------------------------------------------------------------------------

    def _check_open(self) -> None:
        if self._closed:
            raise BagClosedError(f'the bag {self._dir} is closed')

    def _metadata(self, flushed_only: bool) -> BagMetadata:
        span = self._flushed if flushed_only else self._written
        topics = tuple(
            TopicInformation(state.metadata, state.flushed if flushed_only else state.written)
            for state in self._topics.values())
        start = span.start if span.count else NO_MESSAGE_TIME_NS
        files = (FileInformation(self._file_name, start, span.duration, span.count),)
        return BagMetadata(relative_file_paths=(self._file_name,), files=files,
                           topics_with_message_count=topics, message_count=span.count,
                           starting_time_ns=start, duration_ns=span.duration,
                           custom_data=self._custom_data, ros_distro=self._ros_distro)

    def _write_metadata_record(self) -> None:
        """Write the ``rosbag2`` metadata record, as Jazzy's plugin does on open and close."""
        self._mcap.add_metadata('rosbag2', {
            'serialized_metadata': self._metadata(flushed_only=False).dump(root=False)})
