"""When a bag goes on in a new storage file, and how many files it keeps.

As ``ros2 bag record --max-bag-size / --max-bag-duration`` split a recording (rosbag2's
``max_bagfile_size`` and ``max_bagfile_duration``): the bag's current file is finished
(summary, footer: every reader opens it) and the next one, ``<bag>_<index + 1>.mcap``, is
started, once the current file has reached the size, or a message would make its log-time span
reach the duration. With ``max_files`` the bag keeps only that many files, deleting the oldest
(a long operator session then uses a bounded disk); 0 keeps every file.
"""

from __future__ import annotations

import dataclasses

from walker_bag.core.errors import BagError

__all__ = ['SplitPolicy', 'NO_SPLIT']


@dataclasses.dataclass(frozen=True)
class SplitPolicy:
    """Limits of one storage file, and of the number of files kept (0: no limit).

    Attributes
    ----------
    max_file_size : int
        Bytes at which the file is finished and the next one started [B].
    max_file_duration_ns : int
        Log-time span at which the file is finished and the next one started [ns].
    max_files : int
        Files the bag keeps: beyond, the oldest is deleted.

    Raises
    ------
    BagError
        If a limit is not a non-negative integer.
    """

    max_file_size: int = 0
    max_file_duration_ns: int = 0
    max_files: int = 0

    def __post_init__(self) -> None:
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                raise BagError(f'{field.name} must be a non-negative integer (0: no limit), '
                               f'got {value!r}')

    @property
    def splits(self) -> bool:
        """True when a file has a size or duration limit."""
        return bool(self.max_file_size or self.max_file_duration_ns)

    def split_due(self, file_size: int, file_start_ns: int | None, log_time_ns: int) -> bool:
        """Say whether a message logged at ``log_time_ns`` goes into a new file.

        ``file_size`` [B] is what the current file holds; ``file_start_ns`` the log time of
        its first message (None when it holds none: an empty file is never left behind).
        """
        if file_start_ns is None:
            return False
        if self.max_file_size and file_size >= self.max_file_size:
            return True
        return bool(self.max_file_duration_ns) \
            and log_time_ns - file_start_ns >= self.max_file_duration_ns

    def files_to_delete(self, file_count: int) -> int:
        """How many of the oldest of ``file_count`` finished files to delete now."""
        return max(0, file_count - self.max_files) if self.max_files else 0


NO_SPLIT = SplitPolicy()
