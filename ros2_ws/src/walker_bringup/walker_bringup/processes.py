"""Start, watch and stop the node processes of a graph, leaving nothing behind.

Each node runs in a process group of its own with its output in a log file. A child that dies
is reported at the next :meth:`ProcessGroup.poll_deaths`. Stopping sends SIGINT (the clean
shutdown every node handles), then SIGTERM, SIGABRT and SIGKILL to whatever is left, and
removes the Fast DDS shared-memory files that killed children leave in ``/dev/shm`` (only files
created during the run and mapped by no live process). Children run with Python's fault
handler on, so a native crash, or a hang ended by SIGABRT, leaves each thread's stack in the
node's log; before that SIGABRT the native stacks of a hung node's threads are written there too
when ``gdb`` is on the PATH (a hang inside the middleware shows only as a Python line).
Children write their logs in append mode, so the notes this module adds are never overwritten.
The process id of each node's newest process is kept in ``<log_dir>/pids.json`` (rewritten
atomically at every start), so a tool outside (a chaos driver, a debugger) finds a node's
process from the bring-up itself rather than by matching command lines.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import os
import shutil
import signal
import subprocess
import time
from pathlib import Path

from walker_bringup.graph import NodeSpec

__all__ = ['ManagedProcess', 'ProcessGroup', 'STOP_TIMEOUT', 'PID_FILE', 'read_pids',
           'fastdds_shm_files', 'stale_shared_memory_files']

_SHM = Path('/dev/shm')
#: The file in a group's log directory that names each node's newest process id.
PID_FILE = 'pids.json'
#: [s] wall-clock time a node is given to stop cleanly after each signal. A graph of eight
#: Python nodes shutting down together on a loaded 2-core machine was seen to take 4.7 s.
STOP_TIMEOUT = 10.0
#: [s] a hung node is given to write its threads' stacks after SIGABRT, before SIGKILL.
_ABORT_WAIT = 5.0
#: [s] longest wait for gdb to write a hung node's native stacks
_NATIVE_STACKS_WAIT = 30.0


@dataclasses.dataclass
class ManagedProcess:
    """A started node process."""

    spec: NodeSpec
    popen: subprocess.Popen
    log_path: Path
    started_at: float
    reported_dead: bool = False
    #: the command line it was started with (None: its spec's installed executable)
    command: list[str] | None = None

    @property
    def alive(self) -> bool:
        """True while the process runs."""
        return self.popen.poll() is None

    def log_tail(self, lines: int = 15) -> str:
        """Last lines of the process's output."""
        try:
            text = self.log_path.read_text(errors='replace')
        except OSError:
            return ''
        return '\n'.join(text.splitlines()[-lines:])


def fastdds_shm_files() -> set[Path]:
    """Return the Fast DDS files in /dev/shm now."""
    if not _SHM.is_dir():
        return set()
    return {p for p in _SHM.iterdir() if 'fastrtps' in p.name or 'fastdds' in p.name}


def _mapped_shared_memory() -> set[str]:
    mapped: set[str] = set()
    for maps in Path('/proc').glob('[0-9]*/maps'):
        with contextlib.suppress(OSError):
            for line in maps.read_text().splitlines():
                if '/dev/shm/' in line:
                    mapped.add(line.split('/dev/shm/', 1)[1].split(' ')[0])
    return mapped


def stale_shared_memory_files(before: set[Path], min_age: float = 10.0) -> list[Path]:
    """Fast DDS files in /dev/shm created since ``before`` that no live process uses.

    A file is in use when a live process maps it; a segment's lock file (``<segment>_el``),
    which is never mapped, is in use with its segment. The lock file matters most: Fast DDS
    takes a segment whose lock file is gone for a dead process's and deletes it, and another
    graph on the same machine (another domain, another test run) then loses its messages.
    Files younger than ``min_age`` seconds are left too: a process that is starting may have
    created a file it has not mapped yet.
    """
    candidates = fastdds_shm_files() - before  # listed before the mappings are read
    mapped = _mapped_shared_memory()
    now = time.time()

    def in_use(path: Path) -> bool:
        name = path.name.removeprefix('sem.')
        return name in mapped or name.removesuffix('_el') in mapped

    def young(path: Path) -> bool:
        try:
            return now - path.stat().st_mtime < min_age
        except OSError:
            return True  # gone already
    return sorted(p for p in candidates if not in_use(p) and not young(p))


def read_pids(log_dir: Path) -> dict[str, int]:
    """Return node name -> id of its newest process, as a group in ``log_dir`` last wrote it.

    Empty when no group has started a process there.
    """
    try:
        return {name: int(pid) for name, pid in
                json.loads((Path(log_dir) / PID_FILE).read_text()).items()}
    except FileNotFoundError:
        return {}


class ProcessGroup:
    """The processes of one graph run.

    Parameters
    ----------
    log_dir : Path
        Directory for one ``<node>.log`` per process.
    env : dict
        Environment of the children (it must keep DDS discovery on loopback).
    """

    def __init__(self, log_dir: Path, env: dict[str, str]) -> None:
        if env.get('ROS_AUTOMATIC_DISCOVERY_RANGE') != 'LOCALHOST':
            raise ValueError('refusing to start nodes without '
                             'ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST')
        self.log_dir = Path(log_dir)
        self.log_dir.mkdir(parents=True, exist_ok=True)
        # A native crash (a segfault in the ROS layers) writes every thread's Python stack to
        # the node's log, so the log says where it happened.
        self.env = {**env, 'PYTHONFAULTHANDLER': '1'}
        self.processes: list[ManagedProcess] = []
        self._shm_before = fastdds_shm_files()

    def start(self, spec: NodeSpec, command: list[str] | None = None,
              append_log: bool = False) -> ManagedProcess:
        """Start a node (its installed executable, or ``command``)."""
        log_path = self.log_dir / f'{spec.name}.log'
        if not append_log:
            log_path.write_bytes(b'')
        # Append mode: the child's writes go to the end of the file, after this module's notes
        # (with an offset of its own, its fault handler's dump overwrote the note that a
        # SIGABRT was sent, and the log looked like a crash of its own).
        with open(log_path, 'a') as log:
            popen = subprocess.Popen(command or spec.command(), env=self.env, stdout=log,
                                     stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                     start_new_session=True)
        process = ManagedProcess(spec, popen, log_path, time.monotonic(), command=command)
        self.processes.append(process)
        self._write_pids()
        return process

    def _write_pids(self) -> None:
        """Name each node's newest process id in ``pids.json`` (a new file renamed over)."""
        pids = {p.spec.name: p.popen.pid for p in self.processes}  # the newest last
        path = self.log_dir / PID_FILE
        partial = path.with_suffix('.json.partial')
        partial.write_text(json.dumps(pids, indent=1) + '\n')
        partial.replace(path)

    def restart(self, process: ManagedProcess, command: list[str] | None = None
                ) -> ManagedProcess:
        """Start a node again (after it died or was killed), its log continuing in its file.

        A process still alive is stopped first. The new process joins the group; the old one
        is not reported by :meth:`poll_deaths` any more. Without ``command``, the command line
        the process was started with.
        """
        if process.alive:
            self.stop(process)
        process.reported_dead = True
        with open(process.log_path, 'a') as log:
            log.write(f'--- restarted (the previous process ended with code '
                      f'{process.popen.returncode}) ---\n')
        return self.start(process.spec, command or process.command, append_log=True)

    def poll_deaths(self) -> list[ManagedProcess]:
        """Return the processes that have exited since the last call (each reported once)."""
        dead = [p for p in self.processes if not p.alive and not p.reported_dead]
        for process in dead:
            process.reported_dead = True
        return dead

    def stop(self, process: ManagedProcess, timeout: float = STOP_TIMEOUT,
             interrupted: bool = False) -> int | None:
        """Stop one process: SIGINT, then SIGTERM, SIGABRT and SIGKILL; return its exit code.

        ``interrupted``: SIGINT was sent already (it is not sent twice: a second interrupt
        would break the clean shutdown the first one started). Each escalation is noted at the
        end of the process's log, so that a node that does not stop on SIGINT in ``timeout``
        seconds is seen as such. SIGABRT makes a hung Python node's fault handler write where
        each of its threads is stuck into the log before it ends (``_ABORT_WAIT``).
        """
        signals = (signal.SIGTERM, signal.SIGABRT, signal.SIGKILL) if interrupted else (
            signal.SIGINT, signal.SIGTERM, signal.SIGABRT, signal.SIGKILL)
        waits = {signal.SIGABRT: _ABORT_WAIT, signal.SIGKILL: 10.0}
        for sig in signals:
            if not process.alive:
                break
            if sig != signal.SIGINT:
                self._note(process, f'--- still running {timeout:g} s after the last signal: '
                                    f'sending {sig.name} ---')
            if sig == signal.SIGABRT:
                self._write_native_stacks(process)
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.killpg(process.popen.pid, sig)
            try:
                process.popen.wait(timeout=waits.get(sig, timeout))
            except subprocess.TimeoutExpired:
                continue
        return process.popen.returncode

    @staticmethod
    def _write_native_stacks(process: ManagedProcess) -> None:
        """Append every thread's native stack of a hung process to its log (with gdb)."""
        gdb = shutil.which('gdb')
        if gdb is None:
            return
        with contextlib.suppress(OSError, subprocess.SubprocessError), \
                open(process.log_path, 'a') as log:
            log.write(f'--- native stacks of pid {process.popen.pid} (gdb) ---\n')
            log.flush()
            subprocess.run([gdb, '-p', str(process.popen.pid), '-batch', '-nx',
                            '-ex', 'thread apply all bt'], stdout=log, stderr=subprocess.STDOUT,
                           stdin=subprocess.DEVNULL, timeout=_NATIVE_STACKS_WAIT, check=False)

    @staticmethod
    def _note(process: ManagedProcess, line: str) -> None:
        with contextlib.suppress(OSError), open(process.log_path, 'a') as log:
            log.write(line + '\n')

    def stop_all(self, timeout: float = STOP_TIMEOUT, last: tuple[str, ...] = ('recorder',),
                 first: tuple[str, ...] = ('supervisor', 'planner', 'plant')
                 ) -> dict[str, int | None]:
        """Stop every process, one at a time; return the exit code of each node's newest one.

        The nodes named in ``first`` go first, in that order: the deciders, then the plant, so
        that nothing moves while the controllers go. The others follow, newest first, and
        those named in ``last`` (the recorder, which records to the end) at the end. Each is
        interrupted only once the one before has ended (or been escalated to its end,
        :meth:`stop`). Stopped together, nodes hung now and then in Fast DDS while deleting
        their participant as a peer left at the same moment (a plant waited in
        ``destroy_participant`` for a discovery callback of a peer's reader going away, which
        waited for a lock behind it, until SIGABRT). A node stops on SIGINT within a fraction
        of a second, so a graph takes a few seconds.
        """
        newest_first = list(reversed(self.processes))
        ordered = [p for name in first for p in newest_first if p.spec.name == name] + \
            [p for p in newest_first if p.spec.name not in first + last] + \
            [p for p in newest_first if p.spec.name in last]
        codes: dict[str, int | None] = {}
        for process in ordered:
            if process.alive:
                with contextlib.suppress(ProcessLookupError, PermissionError):
                    os.killpg(process.popen.pid, signal.SIGINT)
                started = time.monotonic()
                with contextlib.suppress(subprocess.TimeoutExpired):
                    process.popen.wait(timeout=timeout)
                if not process.alive:
                    self._note(process, f'--- stopped on SIGINT with code '
                                        f'{process.popen.returncode} within '
                                        f'{time.monotonic() - started:.1f} s ---')
            code = self.stop(process, timeout, interrupted=True)
            codes.setdefault(process.spec.name, code)  # the newest process of each node
        for path in stale_shared_memory_files(self._shm_before):
            with contextlib.suppress(OSError):
                path.unlink()
        return codes

    def __enter__(self) -> 'ProcessGroup':
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.stop_all()
