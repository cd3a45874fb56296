"""The ``metadata.yaml`` of a rosbag2 bag, version 9, as ROS 2 Jazzy writes it.

A rosbag2 bag is a directory holding its storage files and ``metadata.yaml``. ``ros2 bag info``
and ``ros2 bag play`` read the metadata first: the storage plugin, the files, the message counts
and, per topic, the type, serialization format, the offered QoS profiles (a YAML list since
version 9) and the type description hash. The root key is ``rosbag2_bagfile_information``; the
fields, in the order rosbag2 writes them::

    version, storage_identifier, duration {nanoseconds}, starting_time
    {nanoseconds_since_epoch}, message_count, topics_with_message_count [{topic_metadata
    {name, type, serialization_format, offered_qos_profiles, type_description_hash},
    message_count}], compression_format, compression_mode, relative_file_paths, files [{path,
    starting_time, duration, message_count}], custom_data, ros_distro

Before the first message rosbag2's starting time is the largest time point (2**63 - 1 ns) and
the duration 0; an empty ``custom_data`` is written as null. The same mapping, without the root
key, is what Jazzy's MCAP plugin stores in the file's ``rosbag2`` metadata record under
``serialized_metadata``. The file is replaced atomically (temporary file, then rename), so a
reader never sees half a file, even when the writer is killed.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from walker_bag.core.errors import MetadataError
from walker_bag.core.qos import QosProfile

__all__ = [
    'METADATA_FILE', 'METADATA_VERSION', 'ROS_DISTRO', 'NO_MESSAGE_TIME_NS', 'TopicMetadata',
    'TopicInformation', 'FileInformation', 'BagMetadata', 'write_metadata', 'read_metadata',
]

METADATA_FILE = 'metadata.yaml'
#: The metadata version of rosbag2 in ROS 2 Jazzy.
METADATA_VERSION = 9
ROS_DISTRO = 'jazzy'
#: rosbag2's starting time of a bag (or file) that holds no message yet.
NO_MESSAGE_TIME_NS = 2**63 - 1
_ROOT = 'rosbag2_bagfile_information'


class _Dumper(yaml.SafeDumper):
    """Indent lists inside mappings, as yaml-cpp (rosbag2's writer) lays them out."""

    def increase_indent(self, flow: bool = False, indentless: bool = False) -> None:
        return super().increase_indent(flow, False)


def _require(node: Any, key: str, kind: type | tuple[type, ...], where: str) -> Any:
    if not isinstance(node, Mapping) or key not in node:
        raise MetadataError(f'{where}: missing {key!r}')
    value = node[key]
    if not isinstance(value, kind) or (isinstance(value, bool) and kind is int):
        raise MetadataError(f'{where}.{key} has the wrong type: {value!r}')
    return value


def _time(node: Any, key: str, unit: str, where: str) -> int:
    return _require(_require(node, key, Mapping, where), unit, int, f'{where}.{key}')


@dataclasses.dataclass(frozen=True)
class TopicMetadata:
    """What a bag records about one topic.

    Attributes
    ----------
    name : str
        Fully qualified topic name, e.g. ``/walker/joint_states``.
    type : str
        Message type, e.g. ``sensor_msgs/msg/JointState``.
    offered_qos_profiles : tuple of QosProfile
        The QoS of each publisher when the topic was subscribed.
    type_description_hash : str
        ``RIHS01_<hex>``, or ``''`` when unknown.
    serialization_format : str
        ``'cdr'`` for every ROS 2 message.
    """

    name: str
    type: str
    offered_qos_profiles: tuple[QosProfile, ...] = ()
    type_description_hash: str = ''
    serialization_format: str = 'cdr'

    def to_yaml(self) -> dict[str, Any]:
        """Return the ``topic_metadata`` mapping, in rosbag2's key order."""
        return {
            'name': self.name,
            'type': self.type,
            'serialization_format': self.serialization_format,
            'offered_qos_profiles': [p.to_yaml() for p in self.offered_qos_profiles],
            'type_description_hash': self.type_description_hash,
        }

    @classmethod
    def from_yaml(cls, node: Any, where: str = 'topic_metadata') -> 'TopicMetadata':
        """Read a version-9 ``topic_metadata`` mapping."""
        profiles = _require(node, 'offered_qos_profiles', list, where)
        return cls(name=_require(node, 'name', str, where),
                   type=_require(node, 'type', str, where),
                   offered_qos_profiles=tuple(QosProfile.from_yaml(p) for p in profiles),
                   type_description_hash=_require(node, 'type_description_hash', str, where),
                   serialization_format=_require(node, 'serialization_format', str, where))


@dataclasses.dataclass(frozen=True)
class TopicInformation:
    """A topic and the number of its messages in the bag."""

    topic_metadata: TopicMetadata
    message_count: int


@dataclasses.dataclass(frozen=True)
class FileInformation:
    """One storage file of the bag: its path relative to the bag directory and its span [ns]."""

    path: str
    starting_time_ns: int
    duration_ns: int
    message_count: int

    def to_yaml(self) -> dict[str, Any]:
        """Return the ``files`` entry, in rosbag2's key order."""
        return {'path': self.path,
                'starting_time': {'nanoseconds_since_epoch': self.starting_time_ns},
                'duration': {'nanoseconds': self.duration_ns},
                'message_count': self.message_count}


@dataclasses.dataclass(frozen=True)
class BagMetadata:
    """Everything ``metadata.yaml`` says about a bag (times in integer nanoseconds).

    ``starting_time_ns`` is the log time of the earliest message and ``duration_ns`` the span
    to the latest one (rosbag2's definition: 0 for a single message).
    """

    relative_file_paths: tuple[str, ...]
    files: tuple[FileInformation, ...]
    topics_with_message_count: tuple[TopicInformation, ...]
    message_count: int = 0
    starting_time_ns: int = NO_MESSAGE_TIME_NS
    duration_ns: int = 0
    custom_data: Mapping[str, str] = dataclasses.field(default_factory=dict)
    ros_distro: str = ROS_DISTRO
    version: int = METADATA_VERSION
    storage_identifier: str = 'mcap'
    compression_format: str = ''
    compression_mode: str = ''

    def to_yaml(self) -> dict[str, Any]:
        """Return the ``rosbag2_bagfile_information`` mapping, in rosbag2's key order."""
        return {
            'version': self.version,
            'storage_identifier': self.storage_identifier,
            'duration': {'nanoseconds': self.duration_ns},
            'starting_time': {'nanoseconds_since_epoch': self.starting_time_ns},
            'message_count': self.message_count,
            'topics_with_message_count': [
                {'topic_metadata': t.topic_metadata.to_yaml(), 'message_count': t.message_count}
                for t in self.topics_with_message_count],
            'compression_format': self.compression_format,
            'compression_mode': self.compression_mode,
            'relative_file_paths': list(self.relative_file_paths),
            'files': [f.to_yaml() for f in self.files],
            'custom_data': dict(self.custom_data) or None,
            'ros_distro': self.ros_distro,
        }

    def dump(self, root: bool = True) -> str:
        """YAML text: with the root key (``metadata.yaml``) or without (the MCAP record)."""
        document = {_ROOT: self.to_yaml()} if root else self.to_yaml()
        return yaml.dump(document, Dumper=_Dumper, sort_keys=False, default_flow_style=False)

    @classmethod
    def from_yaml(cls, node: Any) -> 'BagMetadata':
        """Read a version-9 ``rosbag2_bagfile_information`` mapping.

        Raises
        ------
        MetadataError
            If a field is missing or of the wrong type, or the version is not 9.
        """
        where = _ROOT
        version = _require(node, 'version', int, where)
        if version != METADATA_VERSION:
            raise MetadataError(f'{where}.version is {version}; this reader reads version '
                                f'{METADATA_VERSION} (ROS 2 Jazzy)')
        topics = tuple(
            TopicInformation(
                TopicMetadata.from_yaml(_require(item, 'topic_metadata', Mapping, where),
                                        f'{where}.topics_with_message_count[{i}]'),
                _require(item, 'message_count', int, where))
            for i, item in enumerate(_require(node, 'topics_with_message_count', list, where)))
        files = tuple(
            FileInformation(_require(item, 'path', str, f'{where}.files'),
                            _time(item, 'starting_time', 'nanoseconds_since_epoch', where),
                            _time(item, 'duration', 'nanoseconds', where),
                            _require(item, 'message_count', int, f'{where}.files'))
            for item in _require(node, 'files', list, where))
        custom = node.get('custom_data') or {}
        if not isinstance(custom, Mapping):
            raise MetadataError(f'{where}.custom_data must be a mapping')
        return cls(
            relative_file_paths=tuple(_require(node, 'relative_file_paths', list, where)),
            files=files, topics_with_message_count=topics,
            message_count=_require(node, 'message_count', int, where),
            starting_time_ns=_time(node, 'starting_time', 'nanoseconds_since_epoch', where),
            duration_ns=_time(node, 'duration', 'nanoseconds', where),
            custom_data={str(k): str(v) for k, v in custom.items()},
            ros_distro=_require(node, 'ros_distro', str, where), version=version,
            storage_identifier=_require(node, 'storage_identifier', str, where),
            compression_format=_require(node, 'compression_format', str, where),
            compression_mode=_require(node, 'compression_mode', str, where))


def write_metadata(bag_dir: str | Path, metadata: BagMetadata) -> Path:
    """Replace ``bag_dir/metadata.yaml`` atomically; return its path.

    The text goes to a temporary file in the same directory, is flushed to the disk, and is
    renamed over the old file: a reader (or a crash) sees the old file or the new one, whole.
    """
    path = Path(bag_dir) / METADATA_FILE
    temporary = path.with_name(f'.{METADATA_FILE}.tmp')
    with open(temporary, 'w') as stream:
        stream.write(metadata.dump())
        stream.flush()
        os.fsync(stream.fileno())
    os.replace(temporary, path)
    return path


def read_metadata(bag_dir: str | Path) -> BagMetadata:
    """Read ``bag_dir/metadata.yaml``.

    Raises
    ------
    MetadataError
        If the file is missing, is not YAML, or is not version-9 rosbag2 metadata.
    """
    path = Path(bag_dir) / METADATA_FILE
    try:
        document = yaml.safe_load(path.read_text())
    except OSError as error:
        raise MetadataError(f'cannot read {path}: {error.strerror}') from None
    except yaml.YAMLError as error:
        raise MetadataError(f'{path} is not valid YAML: {error}') from None
    if not isinstance(document, Mapping) or _ROOT not in document:
        raise MetadataError(f'{path} has no {_ROOT!r} mapping: not a rosbag2 bag')
    try:
        return BagMetadata.from_yaml(document[_ROOT])
    except MetadataError as error:
        raise MetadataError(f'{path}: {error}') from None
