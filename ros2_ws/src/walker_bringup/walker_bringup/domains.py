"""ROS domain ids reserved for one graph at a time on this machine (a lock file per id).

A graph that runs beside others (a test, a campaign's walk on a worker) takes a domain no other
user of this module holds, so their nodes never cross-talk; the lock is held for as long as the
graph runs and freed when its holder ends, however it ends. :func:`domain_environment` puts a
domain, loopback discovery and a ROS home into this process's environment for as long as a
graph started from it runs (its processes and its client read them there).
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

__all__ = ['DOMAIN_IDS', 'isolated_domain', 'domain_environment']

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


@contextlib.contextmanager
def domain_environment(domain: int, ros_home: Path, **extra: str) -> Iterator[None]:
    """Set this process's environment for a graph in ``domain``; give the old one back after.

    Parameters
    ----------
    domain : int
        ``ROS_DOMAIN_ID`` (one taken with :func:`isolated_domain`).
    ros_home : Path
        ``ROS_HOME``: the supervisor keeps the step under way in it, which must not pass to a
        later graph started in the same domain.
    **extra : str
        Further variables (e.g. ``PYTHONUNBUFFERED='1'``).

    Discovery is kept on loopback (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``). Each variable
    is given back as it was on leaving, unset if it was unset.
    """
    values = dict(ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST',
                  ROS_HOME=str(ros_home), **extra)
    before = {name: os.environ.get(name) for name in values}
    os.environ.update(values)
    try:
        yield
    finally:
        for name, value in before.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value
