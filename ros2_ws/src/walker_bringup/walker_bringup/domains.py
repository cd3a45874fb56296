"""ROS domain ids reserved for one graph at a time on this machine (a lock file per id).

A graph that runs beside others (a test, a campaign's walk on a worker) takes a domain no other
user of this module holds, so their nodes never cross-talk; the lock is held for as long as the
graph runs and freed when its holder ends, however it ends.
"""

from __future__ import annotations

import contextlib
import fcntl
import tempfile
from collections.abc import Iterator
from pathlib import Path

__all__ = ['DOMAIN_IDS', 'isolated_domain']

#: Domain ids that map to valid DDS ports on Linux (0 is left to interactive use).
DOMAIN_IDS = range(1, 102)


@contextlib.contextmanager
def isolated_domain() -> Iterator[int]:
    """Reserve a ROS domain id no other holder on this machine is using.

    Raises
    ------
    RuntimeError
        Every id is taken.
    """
    lock_dir = Path(tempfile.gettempdir())
    for domain in DOMAIN_IDS:
        handle = open(lock_dir / f'walker-ros-domain-{domain}.lock', 'w')
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            handle.close()
            continue
        try:
            yield domain
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)
            handle.close()
        return
    raise RuntimeError(f'every ROS domain id {DOMAIN_IDS.start}..{DOMAIN_IDS.stop - 1} is in '
                       'use by other graphs on this machine')
