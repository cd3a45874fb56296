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

from walker_bag.core.bag_split import SplitPolicy
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
        'directory the bags are written under (relative to the working directory)',
        source='chosen: beside the other outputs of run_all.py (runs/ is not versioned)')
    bag_name: str = parameter(
        "name of the bag directory; '' names it walker_<YYYY_MM_DD-HH_MM_SS>",
        source='chosen: as ros2 bag record names rosbag2_<date-time>')
    topics: tuple[str, ...] = parameter(
        'topics to record: names or glob patterns, relative ones in the recorder namespace',
        source="chosen: the robot's namespace and the simulation clock")
    discovery_period: float = parameter(
        'period of the search for new topics to subscribe to', 's', 0.01, 10.0,
        source='chosen: a topic that appears later is recorded from a quarter of a second on')
    flush_period: float = parameter(
        'period at which received messages are written to the file: the most a crash loses',
        's', 0.01, 60.0,
        source='chosen: one small write per period')
    max_chunk_size: int = parameter(
        'size at which a chunk of messages is written out before its period ends',
        'B', 1024, 64 * 1024 * 1024,
        source="chosen: 768 KiB, the chunk size of Jazzy's MCAP writer")
    queue_depth: int = parameter(
        'messages each subscription holds while the recorder is busy', '', 1, 100000,
        source='chosen: 10 s of 500 Hz joint states while the recorder is busy or starved')
    max_bag_size: int = parameter(
        'size at which the bag goes on in its next file (--max-bag-size); 0: no split by size',
        'B', 0, 2**62,
        source='chosen: 0, one file per bag, as ros2 bag record by default')
    max_bag_duration: float = parameter(
        'log-time span at which the bag goes on in its next file (--max-bag-duration); 0: none',
        's', 0.0, 1e9,
        source='chosen: 0, no split by duration, as ros2 bag record by default')
    max_bag_files: int = parameter(
        'files the bag keeps, the oldest deleted beyond; 0: every file', '', 0, 10**6,
        source='chosen: 0, every file kept')
    append: bool = parameter(
        'continue an existing bag of the same name in its next file; false: one that exists is '
        'refused',
        source='chosen: a new bag per start; true for a recorder started again after a crash')
    take_period: float = parameter(
        'period at which received messages are taken, all topics at once (steady clock)',
        's', 0.001, 1.0,
        source='chosen: 50 times a second, not an executor turn per message (which starved the '
               'recorder)')

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

    @property
    def split(self) -> SplitPolicy:
        """The bag's split and rotation limits."""
        return SplitPolicy(self.max_bag_size, int(round(self.max_bag_duration * 1e9)),
                           self.max_bag_files)

    def bag_path(self, now: datetime.datetime) -> Path:
        """Return the bag directory to write: ``directory/bag_name`` (or a time-stamped name)."""
        return Path(self.directory) / (self.bag_name or default_bag_name(now))
