"""Deaf readers on demand: the probe's talker and listener, and the faults that deafen them.

Shared by ``tests/integration/test_deaf_readers.py`` and ``benchmarks/transport_benchmark.py``.
A :class:`ProbePair` runs :mod:`walker_bringup.transport_probe`'s talker and listener as two
processes of one environment (a ROS domain of the caller's, the rmw default transport or the
UDP-on-loopback profile) and injects the faults a graph meets: ``SIGKILL`` and a restart of
either, ``SIGSTOP``/``SIGCONT`` of either, and the removal of the Fast DDS shared-memory files
a live process holds (what a clean-up of "leftover" files in ``/dev/shm`` does to a process it
took for dead). :meth:`ProbePair.hears_again` says whether, and how soon, the listener hears
both topics again.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import time
from pathlib import Path

from ros_test_support import NodeProcess

from walker_bringup.transport_probe import parse_heard

__all__ = ['SHM', 'fastdds_files', 'shared_memory_files_of', 'remove_shared_memory_files',
           'ProbePair']

SHM = Path('/dev/shm')
_POLL = 0.05  # [s]


def fastdds_files() -> set[Path]:
    """Return every Fast DDS file in /dev/shm now (every user's)."""
    if not SHM.is_dir():
        return set()
    return {p for p in SHM.iterdir() if 'fastrtps' in p.name or 'fastdds' in p.name}


def shared_memory_files_of(pid: int) -> list[Path]:
    """Return the Fast DDS files in /dev/shm that process ``pid`` holds.

    A participant holds a lock (``/proc/locks``) on the ``_el`` file of its data segment
    (``fastrtps_<id>``) and of each port it listens on (``fastrtps_port<n>``); each such lock
    file comes with the segment or port it guards.
    """
    inodes = set()
    with contextlib.suppress(OSError):
        for line in Path('/proc/locks').read_text().splitlines():
            fields = line.split()
            if len(fields) > 5 and fields[4] == str(pid):
                inodes.add(int(fields[5].rsplit(':', 1)[1]))
    held = []
    for entry in SHM.iterdir() if SHM.is_dir() else ():
        if 'fastrtps' not in entry.name and 'fastdds' not in entry.name:
            continue
        with contextlib.suppress(OSError):
            if entry.stat().st_ino in inodes:
                held.append(entry)
                guarded = SHM / entry.name.removesuffix('_el')
                if entry.name.endswith('_el') and guarded.exists():
                    held.append(guarded)
    return sorted(set(held))


def remove_shared_memory_files(pid: int) -> list[str]:
    """Remove the Fast DDS files process ``pid`` holds (a mistaken clean-up); their names."""
    removed = []
    for path in shared_memory_files_of(pid):
        with contextlib.suppress(OSError):
            path.unlink()
            removed.append(path.name)
    return removed


class ProbePair:
    """A probe talker and listener in ``env`` (see the module docstring); a context manager.

    Parameters
    ----------
    env : dict
        The environment of both processes.
    renew_after : float
        [s] the listener's ``--renew-after`` (0: plain subscriptions).
    rate : float
        [Hz] the talker's rate.
    latencies : Path, optional
        Where the listener writes its latencies as it ends.
    talker : bool
        Start a talker (False: a second listener of another pair's talker).
    """

    def __init__(self, env: dict[str, str], renew_after: float, rate: float = 500.0,
                 latencies: Path | None = None, talker: bool = True) -> None:
        self._env = env
        self._rate = rate
        listen = ['listen', '--renew-after', str(renew_after)]
        if latencies is not None:
            listen += ['--latencies', str(latencies)]
        self.listener = self._start(listen, 'transport_listener')
        self.talker = self._start(['talk', '--rate', str(rate)], 'transport_talker') \
            if talker else None
        self._ended: list[NodeProcess] = []

    def _start(self, arguments: list[str], name: str) -> NodeProcess:
        return NodeProcess([sys.executable, '-m', 'walker_bringup.transport_probe',
                            *arguments], self._env, name)

    def heard(self) -> list[tuple[float, int, int, int]]:
        """Return the listener's ``heard`` lines so far (:func:`parse_heard`)."""
        return parse_heard(self.listener.output)

    def hears_again(self, since: float, within: float) -> float | None:
        """Seconds from ``since`` (steady) until both topics' counts grew; None if not ``within``.

        The counts are compared with the listener's first line at or after ``since``.
        """
        deadline = time.monotonic() + within
        while True:
            rows = [row for row in self.heard() if row[0] >= since]
            grown = [row for row in rows[1:] if row[1] > rows[0][1] and row[2] > rows[0][2]]
            if grown:
                return grown[0][0] - since
            if time.monotonic() >= deadline or self.listener.process.poll() is not None:
                return None
            time.sleep(_POLL)

    @property
    def renewals(self) -> int:
        """How many times the listener made its subscriptions anew so far."""
        rows = self.heard()
        return rows[-1][3] if rows else 0

    def kill_and_restart(self, which: str) -> float:
        """``SIGKILL`` the ``'talker'`` or the ``'listener'`` and start it again; steady time."""
        old = getattr(self, which)
        os.kill(old.process.pid, signal.SIGKILL)
        old.process.wait()
        self._ended.append(old)
        started = time.monotonic()
        if which == 'talker':
            self.talker = self._start(['talk', '--rate', str(self._rate)], 'transport_talker')
        else:
            arguments = old.process.args[3:]
            self.listener = self._start(arguments, 'transport_listener')
        return started

    def freeze(self, which: str, seconds: float) -> float:
        """``SIGSTOP`` the ``'talker'`` or ``'listener'`` for ``seconds``; steady time after."""
        pid = getattr(self, which).process.pid
        os.kill(pid, signal.SIGSTOP)
        try:
            time.sleep(seconds)
        finally:
            os.kill(pid, signal.SIGCONT)
        return time.monotonic()

    def __enter__(self) -> 'ProbePair':
        return self

    def __exit__(self, *exc_info: object) -> None:
        for process in (self.talker, self.listener, *self._ended):
            if process is not None:
                process.__exit__(None, None, None)
