"""One storage file of a bag: an MCAP file written as ROS 2 Jazzy's ``rosbag2_storage_mcap`` does.

The file follows the ``ros2`` profile:

- one *schema* per message type: name ``pkg/msg/Type``, encoding ``ros2msg``, data the
  concatenated ``.msg`` text (:mod:`walker_bag.core.message_definitions`);
- one *channel* per topic: message encoding ``cdr`` and the metadata keys
  ``offered_qos_profiles`` (the publishers' QoS, version-9 YAML text) and ``topic_type_hash``
  (``RIHS01_...``);
- *messages* holding the CDR bytes exactly as received, with log time = receive time and
  publish time = the publisher's source time [ns];
- a ``rosbag2`` metadata record with key ``serialized_metadata`` (the bag's metadata as YAML),
  written when the file opens and again when it is finished, and on finishing the summary
  section (schemas, channels, statistics, chunk and metadata indexes) and footer;
- chunks without compression (Jazzy's default), up to ``max_chunk_size`` bytes each, with
  message indexes.

For crash safety a chunk is written out as soon as it is full *or* :meth:`McapFile.flush` is
called: a process killed at any moment leaves every message up to the last flush in complete
chunks (:mod:`walker_bag.core.bag_recovery` completes such a file).
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable
from pathlib import Path

from mcap import __version__ as mcap_version
from mcap.writer import CompressionType, Writer

from walker_bag.core.bag_metadata import NO_MESSAGE_TIME_NS, FileInformation, TopicMetadata
from walker_bag.core.errors import BagError, BagPathError, TopicConflictError
from walker_bag.core.message_definitions import MessageDefinition
from walker_bag.core.qos import qos_profiles_to_yaml

__all__ = ['DEFAULT_CHUNK_SIZE', 'MCAP_PROFILE', 'LIBRARY', 'Span', 'McapFile', 'check_times']

#: Chunk size of ROS 2 Jazzy's MCAP writer (libmcap's default) [bytes].
DEFAULT_CHUNK_SIZE = 768 * 1024
MCAP_PROFILE = 'ros2'
#: The MCAP header's library string: who wrote the file.
LIBRARY = f'walker_bag 0.1.0 (mcap-python {mcap_version})'
_MESSAGE_RECORD_OVERHEAD = 1 + 8 + 2 + 4 + 8 + 8  # opcode, length, channel, sequence, 2 times
_RECORD_OVERHEAD = 64  # opcode, length, ids and string lengths of a schema or channel record
_UINT32 = 2**32


@dataclasses.dataclass
class Span:
    """Message count and log-time span of a set of messages [ns]."""

    count: int = 0
    start: int = NO_MESSAGE_TIME_NS
    end: int = 0

    def add(self, log_time: int) -> None:
        """Count one message logged at ``log_time`` [ns]."""
        self.count += 1
        self.start = min(self.start, log_time)
        self.end = max(self.end, log_time)

    @property
    def duration(self) -> int:
        """From the first to the last message [ns] (0 for none or one)."""
        return self.end - self.start if self.count else 0


class McapFile:
    """An MCAP storage file being written (see the module docstring).

    Parameters
    ----------
    path : Path
        The file to create; it must not exist.
    max_chunk_size : int
        A chunk is written out when its messages reach this many bytes [bytes].
    serialized_metadata : callable
        Returns the bag's metadata as YAML text (without the root key), for the ``rosbag2``
        metadata record written on opening and on finishing.

    Raises
    ------
    BagPathError
        If the file cannot be created.
    """

    def __init__(self, path: Path, max_chunk_size: int,
                 serialized_metadata: Callable[[], str]) -> None:
        self.path = Path(path)
        try:
            self._stream = open(self.path, 'xb')
        except OSError as error:
            raise BagPathError(f'cannot create {self.path}: {error.strerror}') from None
        self._max_chunk_size = max_chunk_size
        self._serialized_metadata = serialized_metadata
        # Chunks are cut here, not by the library, so that every write-out is known.
        self._mcap = Writer(self._stream, chunk_size=2**62, compression=CompressionType.NONE)
        self._channels: dict[str, int] = {}
        self._schemas: dict[str, int] = {}
        self._pending_bytes = 0
        self.written = Span()
        self.flushed = Span()
        self.counts: dict[str, int] = {}  # messages written per topic
        self.flushed_counts: dict[str, int] = {}
        self.finished = False
        self._mcap.start(profile=MCAP_PROFILE, library=LIBRARY)
        self._write_metadata_record()
        self._stream.flush()

    @property
    def name(self) -> str:
        """The file's name (its path relative to the bag directory)."""
        return self.path.name

    @property
    def size(self) -> int:
        """Bytes written to the file, and buffered for it [bytes]."""
        return self._stream.tell() + self._pending_bytes

    def add_topic(self, topic: TopicMetadata, definition: MessageDefinition | None) -> None:
        """Register a topic's schema (once per type) and channel; a known topic is left alone.

        Raises
        ------
        TopicConflictError
            If the definition is of another type than the topic's.
        """
        if topic.name in self._channels:
            return
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
        self._channels[topic.name] = self._mcap.register_channel(
            topic.name, topic.serialization_format, schema_id, channel_metadata)
        self._pending_bytes += len(topic.name) + sum(
            len(k) + len(v) for k, v in channel_metadata.items()) + _RECORD_OVERHEAD
        self.counts.setdefault(topic.name, 0)
        self.flushed_counts.setdefault(topic.name, 0)

    def write(self, topic_name: str, data: bytes, log_time_ns: int, publish_time_ns: int,
              sequence: int) -> None:
        """Write one message of a registered topic (times checked by the caller).

        The caller flushes once :attr:`chunk_full`.
        """
        self._mcap.add_message(self._channels[topic_name], log_time=log_time_ns, data=data,
                               publish_time=publish_time_ns, sequence=sequence % _UINT32)
        self.counts[topic_name] += 1
        self.written.add(log_time_ns)
        self._pending_bytes += len(data) + _MESSAGE_RECORD_OVERHEAD

    @property
    def chunk_full(self) -> bool:
        """True when the chunk in progress has reached ``max_chunk_size``: flush it."""
        return self._pending_bytes >= self._max_chunk_size

    def flush(self) -> bool:
        """Write out the chunk in progress; return False when there was nothing new.

        Afterwards every message written so far is in the operating system's hands: it
        survives the process being killed.
        """
        if self.flushed.count == self.written.count:
            return False
        self._mcap.flush()
        self._pending_bytes = 0
        self.flushed = dataclasses.replace(self.written)
        self.flushed_counts = dict(self.counts)
        return True

    def finish(self) -> None:
        """Finish the file: last chunk, metadata record, summary, footer; sync and close it."""
        if self.finished:
            return
        self.finished = True
        self._mcap.flush()
        self.flushed = dataclasses.replace(self.written)
        self.flushed_counts = dict(self.counts)
        self._write_metadata_record()
        self._mcap.finish()
        self._stream.flush()
        os.fsync(self._stream.fileno())
        self._stream.close()

    def information(self, flushed_only: bool) -> FileInformation:
        """Return the file's entry in the metadata: what is flushed, or all that is written."""
        span = self.flushed if flushed_only else self.written
        start = span.start if span.count else NO_MESSAGE_TIME_NS
        return FileInformation(self.name, start, span.duration, span.count)

    def _write_metadata_record(self) -> None:
        """Write the ``rosbag2`` metadata record, as Jazzy's plugin does on open and close."""
        self._mcap.add_metadata('rosbag2', {'serialized_metadata': self._serialized_metadata()})


def check_times(log_time_ns: int, publish_time_ns: int) -> None:
    """Refuse a time that is not a non-negative integer [ns] below 2**64."""
    for name, value in (('log_time_ns', log_time_ns), ('publish_time_ns', publish_time_ns)):
        if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value < 2**64:
            raise BagError(f'{name} must be a non-negative integer [ns], got {value!r}')
