"""Reading a recorded walk: decoded messages of chosen topics, in time order.

Built on rosbags (``AnyReader``), the field's independent rosbag2 reader: it decodes every
message from the definitions stored in the bag itself, so the walker's custom ``walker_msgs``
types need nothing installed, and it checks each type's stored hash against the definition.
For bags that carry no definitions it falls back to the ROS 2 Jazzy types plus the installed
``walker_msgs`` types, registered from their ``.msg`` text.

Timestamps are the bag's log times (the recorder's receive times) in integer nanoseconds.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path

from rosbags.highlevel import AnyReader, AnyReaderError
from rosbags.interfaces import Connection
from rosbags.rosbag2 import ReaderError
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from walker_bag.core.errors import BagPathError, MessageDefinitionError, UnknownTopicError
from walker_bag.core.message_definitions import (
    SEPARATOR, interface_prefixes, message_definition)

__all__ = ['RecordedMessage', 'BagReader', 'read_messages', 'walker_typestore']

#: The walker's custom message types, registered for bags without stored definitions.
_WALKER_MESSAGE_TYPES = (
    'walker_msgs/msg/ControlMode', 'walker_msgs/msg/ControllerState',
    'walker_msgs/msg/GoalRejection', 'walker_msgs/msg/GripperState',
    'walker_msgs/msg/GripperStates',
    'walker_msgs/msg/JointAccelerations', 'walker_msgs/msg/JointCommand',
    'walker_msgs/msg/StepPhase', 'walker_msgs/msg/StepReport')


@dataclasses.dataclass(frozen=True)
class RecordedMessage:
    """One message of a bag.

    Attributes
    ----------
    topic : str
        Topic name.
    type : str
        Message type, ``pkg/msg/Type``.
    log_time_ns : int
        When the recorder received it [ns].
    message : object
        The decoded message (a rosbags dataclass with the message's fields).
    """

    topic: str
    type: str
    log_time_ns: int
    message: object


def walker_typestore(prefixes: Sequence[Path] | None = None) -> Typestore:
    """Return the ROS 2 Jazzy types plus the installed walker_msgs types (``.msg`` text).

    walker_msgs types that are not installed are left out.
    """
    typestore = get_typestore(Stores.ROS2_JAZZY)
    prefixes = interface_prefixes() if prefixes is None else tuple(prefixes)
    types = {}
    for type_name in _WALKER_MESSAGE_TYPES:
        try:
            definition = message_definition(type_name, prefixes)
        except MessageDefinitionError:
            continue
        root_text = definition.text.split('\n' + SEPARATOR, 1)[0]
        types.update(get_types_from_msg(root_text, type_name))
    typestore.register(types)
    return typestore


class BagReader:
    """Open a rosbag2 bag directory for reading; use as a context manager.

    Parameters
    ----------
    bag_dir : str or Path
        The bag directory (holding ``metadata.yaml``).

    Raises
    ------
    BagPathError
        If the directory is missing or is not a readable bag (the message says why: e.g. an
        MCAP file cut short by a crash; :func:`walker_bag.core.bag_recovery.recover_bag`
        makes a complete copy).
    """

    def __init__(self, bag_dir: str | Path) -> None:
        self._path = Path(bag_dir)
        if not self._path.is_dir():
            raise BagPathError(f'{self._path} is not a bag directory')
        try:
            self._reader = AnyReader([self._path], default_typestore=walker_typestore())
            self._reader.open()
        except (AnyReaderError, ReaderError, FileNotFoundError) as error:
            raise BagPathError(f'cannot read the bag {self._path}: {error}') from None

    @property
    def topics(self) -> dict[str, str]:
        """Type of every topic, by topic name."""
        return {c.topic: c.msgtype for c in self._reader.connections}

    @property
    def message_counts(self) -> dict[str, int]:
        """Number of messages of every topic."""
        counts: dict[str, int] = {}
        for connection in self._reader.connections:
            counts[connection.topic] = counts.get(connection.topic, 0) + connection.msgcount
        return counts

    @property
    def message_count(self) -> int:
        """Number of messages in the bag."""
        return self._reader.message_count

    @property
    def start_time_ns(self) -> int:
        """Log time of the first message [ns]."""
        return self._reader.start_time

    @property
    def end_time_ns(self) -> int:
        """Log time of the last message [ns] plus one, as rosbags defines the end."""
        return self._reader.end_time

    @property
    def connections(self) -> list[Connection]:
        """The rosbags connections (topic, type, definition, offered QoS) of the bag."""
        return list(self._reader.connections)

    def messages(self, topics: Iterable[str] | None = None) -> Iterator[RecordedMessage]:
        """Yield the decoded messages of the given topics (all when ``None``) by log time.

        Raises
        ------
        UnknownTopicError
            If a topic asked for is not in the bag; nothing is read.
        """
        connections = self._reader.connections
        if topics is not None:
            wanted = set(topics)
            missing = sorted(wanted - {c.topic for c in connections})
            if missing:
                raise UnknownTopicError(
                    f'the bag {self._path} has no topic {", ".join(missing)}; it has '
                    f'{", ".join(sorted(self.topics)) or "no topics"}')
            connections = [c for c in connections if c.topic in wanted]
            if not connections:
                return
        for connection, log_time, raw in self._reader.messages(connections=connections):
            yield RecordedMessage(connection.topic, connection.msgtype, log_time,
                                  self._reader.deserialize(raw, connection.msgtype))

    def close(self) -> None:
        """Close the bag's files."""
        self._reader.close()

    def __enter__(self) -> 'BagReader':
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


def read_messages(bag_dir: str | Path,
                  topics: Iterable[str] | None = None) -> list[RecordedMessage]:
    """All decoded messages of the given topics of a bag, in log-time order."""
    with BagReader(bag_dir) as reader:
        return list(reader.messages(topics))
