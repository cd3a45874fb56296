"""The ``recorder`` section of the parameter file: where bags go, what, how often flushed.

Loaded like every section of ``walker_core/config/walker.yaml`` (``/**`` section) into a frozen
dataclass that checks each value and refuses bad ones with :class:`ParameterError` naming the
parameter (see :mod:`walker_core.parameter_schema`).
"""

from __future__ import annotations

import dataclasses
import datetime
from pathlib import Path

from walker_core.parameter_schema import ParameterError, parameter

from walker_bag.core.errors import TopicNameError
from walker_bag.core.topic_selection import TopicSelection

__all__ = ['RecorderParameters', 'RECORDER_PREFIX', 'default_bag_name']

#: Prefix of the section's parameters in the parameter file.
RECORDER_PREFIX = 'recorder.'
_BAG_NAME_FORMAT = 'walker_%Y_%m_%d-%H_%M_%S'


def default_bag_name(now: datetime.datetime) -> str:
    """``walker_YYYY_MM_DD-HH_MM_SS``, as ``ros2 bag record`` names ``rosbag2_...`` bags."""
    return now.strftime(_BAG_NAME_FORMAT)


@dataclasses.dataclass(frozen=True)
class RecorderParameters:
    """Settings of the walk recorder (``recorder.*``)."""

    directory: str = parameter(
        'directory the bags are written under (relative paths from the working directory)')
    bag_name: str = parameter(
        "name of the bag directory; '' names it walker_<YYYY_MM_DD-HH_MM_SS>")
    topics: tuple[str, ...] = parameter(
        'topics to record: names or glob patterns (* matches any characters); relative ones '
        'are resolved in the recorder namespace')
    discovery_period: float = parameter(
        'period of the search for new topics to subscribe to', 's', 0.01, 10.0)
    flush_period: float = parameter(
        'period at which received messages are written out to the file: the most a crash '
        'can lose', 's', 0.01, 60.0)
    max_chunk_size: int = parameter(
        'size at which a chunk of messages is written out before its period ends', 'B',
        1024, 64 * 1024 * 1024)
    queue_depth: int = parameter(
        'messages each subscription holds while the recorder is busy', '', 1, 100000)
    take_period: float = parameter(
        'period at which received messages are taken from the middleware, all topics at '
        'once, and handed to the bag (steady clock); in sim time their log time is the '
        'simulation clock when taken', 's', 0.001, 1.0)

    def __post_init__(self) -> None:
        if not self.directory:
            raise ParameterError("recorder.directory must not be empty (use '.' for the "
                                 'working directory)')
        if self.bag_name and (self.bag_name in ('.', '..') or '/' in self.bag_name):
            raise ParameterError(f'recorder.bag_name {self.bag_name!r} must be a single '
                                 'directory name (no /)')
        try:
            TopicSelection(self.topics)
        except TopicNameError as error:
            raise ParameterError(f'recorder.topics: {error}') from None

    def bag_path(self, now: datetime.datetime) -> Path:
        """Return the bag directory to write: ``directory/bag_name`` (or a time-stamped name)."""
        return Path(self.directory) / (self.bag_name or default_bag_name(now))
