"""Support for tests that start real ROS 2 nodes: isolated domains, processes, clean-up.

Every integration test gets a ROS domain id of its own, held by a lock file for the duration of
the test so that parallel or leftover runs on the same machine never cross-talk, and DDS
discovery stays on loopback (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``).
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from pathlib import Path

from walker_bringup.domains import isolated_domain

__all__ = ['REPO_ROOT', 'isolated_domain', 'ros_environment', 'NodeProcess',
           'SharedMemoryGuard', 'attached_grippers', 'assert_always_attached',
           'processes_with', 'running_graph', 'realtime_permitted', 'serve_command',
           'thread_policies', 'spin_executor_until', 'set_stamp', 'write_parameter_file']

REPO_ROOT = Path(__file__).resolve().parents[1]


def ros_environment(domain_id: int) -> dict[str, str]:
    """Return the current environment with an isolated domain and loopback-only discovery."""
    env = dict(os.environ)
    env['ROS_DOMAIN_ID'] = str(domain_id)
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    # ROS logs and the supervisor's step file of this environment stay apart from every other
    # run's, also from an earlier one in the same domain (a step file left by a run that ended
    # in the middle of a step must not reach the next graph)
    env['ROS_HOME'] = tempfile.mkdtemp(prefix=f'walker-ros-home-{domain_id}-')
    env['PYTHONUNBUFFERED'] = '1'
    return env


class NodeProcess:
    """A node (or any command) run in its own process group, with captured output.

    Use as a context manager: on exit the process is sent SIGINT, then SIGTERM and SIGKILL if
    it does not end, so no test leaves a process behind.
    """

    def __init__(self, args: list[str], env: dict[str, str], name: str = '') -> None:
        self.name = name or Path(args[0]).name
        self._log = tempfile.TemporaryFile(mode='w+')
        # The child writes through the same open file (one offset) that ``output`` seeks to 0
        # to read: without O_APPEND its writes landed where the read had left the offset and
        # overwrote what it had printed (a start-up line lost, a wait_for_output that failed).
        descriptor = self._log.fileno()
        fcntl.fcntl(descriptor, fcntl.F_SETFL,
                    fcntl.fcntl(descriptor, fcntl.F_GETFL) | os.O_APPEND)
        self.process = subprocess.Popen(args, env=env, stdout=self._log,
                                        stderr=subprocess.STDOUT, start_new_session=True,
                                        cwd=REPO_ROOT)

    @classmethod
    def python(cls, code: str, env: dict[str, str], name: str = 'python') -> 'NodeProcess':
        """Run a Python snippet in the test environment's interpreter."""
        return cls([sys.executable, '-c', code], env, name)

    @property
    def output(self) -> str:
        """Everything the process printed so far."""
        self._log.flush()
        self._log.seek(0)
        return self._log.read()

    def wait_for_output(self, text: str, timeout: float) -> bool:
        """Wait until ``text`` appears in the output; False on timeout or early exit."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if text in self.output:
                return True
            if self.process.poll() is not None:
                return text in self.output
            time.sleep(0.02)
        return False

    def stop(self, timeout: float = 5.0) -> int | None:
        """Interrupt the process group and wait for it; escalate if it does not end."""
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGKILL):
            if self.process.poll() is not None:
                break
            with contextlib.suppress(ProcessLookupError):
                os.killpg(self.process.pid, sig)
            try:
                self.process.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                continue
        return self.process.returncode

    def __enter__(self) -> 'NodeProcess':
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.stop()
        self._log.close()


class SharedMemoryGuard:
    """Keep the Fast DDS shared-memory files of a graph in /dev/shm while its processes live.

    /dev/shm is shared by every test run on the machine. A run that cleans up after itself by
    deleting the Fast DDS files created during it that no process maps (older versions of
    ``walker_bringup.processes``) also deletes another graph's lock files, which are never
    mapped; Fast DDS then takes that graph's segments for a dead process's and deletes them,
    and the graph goes deaf. The guard keeps a hard link to every file that a process of the
    graph maps or locks, in a directory of its own, and links back any that disappears while
    its process lives, so the same file (and lock) is found again. Links of processes that have
    ended are dropped, so the files of a killed node go the usual way.

    Parameters
    ----------
    pids : callable
        Returns the process ids of the graph now (they change as nodes are restarted).
    period : float
        Seconds between two looks.
    """

    _SHM = Path('/dev/shm')

    def __init__(self, pids, period: float = 0.02) -> None:
        self._pids = pids
        self._period = period
        self._dir = self._SHM / f'walker-shm-guard-{os.getpid()}'
        self._links: dict[str, tuple[int, set[int]]] = {}  # name -> (inode, owner pids)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name='shm-guard', daemon=True)
        self.restored = 0
        #: every file a process of the graph was seen to own, for a check that none is left
        self.owned: set[str] = set()

    def __enter__(self) -> 'SharedMemoryGuard':
        if self._SHM.is_dir():
            self._dir.mkdir(exist_ok=True)
            self._thread.start()
        return self

    def __exit__(self, *exc_info: object) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=5.0)
        for link in self._dir.glob('*') if self._dir.is_dir() else ():
            with contextlib.suppress(OSError):
                link.unlink()
        with contextlib.suppress(OSError):
            self._dir.rmdir()

    def _run(self) -> None:
        while not self._stop.wait(self._period):
            with contextlib.suppress(Exception):  # a process ending mid-look, a file gone
                self._look()

    def _used(self, pids: set[int]) -> dict[str, set[int]]:
        """Name in /dev/shm -> the graph's processes that own it.

        A process owns the files it locks (the ``_el`` lock files of its segments and ports)
        and the segments whose lock file it holds; segments of other graphs that it merely
        maps are not the guard's business.
        """
        locked: dict[int, set[int]] = {}
        with contextlib.suppress(OSError):
            for line in Path('/proc/locks').read_text().splitlines():
                fields = line.split()
                if len(fields) > 5 and fields[4].isdigit() and int(fields[4]) in pids:
                    locked.setdefault(int(fields[5].rsplit(':', 1)[1]), set()).add(
                        int(fields[4]))
        used: dict[str, set[int]] = {}
        for entry in self._SHM.iterdir():
            if 'fastrtps' in entry.name:
                with contextlib.suppress(OSError):
                    owners = locked.get(entry.stat().st_ino)
                    if owners:
                        used[entry.name] = set(owners)
        for name in [n for n in used if n.endswith('_el')]:
            segment = name.removesuffix('_el')
            if (self._SHM / segment).exists():
                used.setdefault(segment, set()).update(used[name])
        return used

    def _look(self) -> None:
        pids = set(self._pids())
        for name, (_inode, owners) in list(self._links.items()):
            link, original = self._dir / name, self._SHM / name
            if not owners & pids:  # its processes ended: let it go
                with contextlib.suppress(OSError):
                    link.unlink()
                del self._links[name]
            elif not original.exists():
                with contextlib.suppress(OSError):
                    os.link(link, original)
                    self.restored += 1
        for name, owners in self._used(pids).items():
            if name in self._links:
                self._links[name] = (self._links[name][0], self._links[name][1] | owners)
                continue
            self.owned.add(name)
            with contextlib.suppress(OSError):
                os.link(self._SHM / name, self._dir / name)
                self._links[name] = ((self._dir / name).stat().st_ino, owners)


def write_parameter_file(path: Path, values: dict) -> Path:
    """Write flat ``{dotted name: value}`` values as a ``/**`` ``ros__parameters`` file."""
    import yaml

    nested: dict = {}
    for name, value in values.items():
        *parents, leaf = name.split('.')
        node = nested
        for part in parents:
            node = node.setdefault(part, {})
        node[leaf] = value
    path.write_text(yaml.safe_dump({'/**': {'ros__parameters': nested}}))
    return path


def spin_executor_until(executor, predicate, timeout: float) -> bool:
    """Spin ``executor`` until ``predicate()`` holds or ``timeout`` [s] passes; return it."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        executor.spin_once(timeout_sec=0.01)
    return predicate()


def set_stamp(message, stamp_ns: int):
    """Stamp ``message`` (its header) with ``stamp_ns`` [ns]; return it."""
    message.header.stamp.sec, message.header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
    return message


def attached_grippers(message) -> list[str]:
    """Names of the grippers a ``walker_msgs/GripperStates`` message reports ATTACHED."""
    from walker_msgs.msg import GripperState

    return [g.name for g in message.grippers if g.state == GripperState.ATTACHED]


def assert_always_attached(states) -> None:
    """Check the space-station rule on every ``GripperStates`` message seen: one attached."""
    assert states, 'no gripper state was received'
    for message in states:
        stamp = message.header.stamp.sec + message.header.stamp.nanosec * 1e-9
        assert attached_grippers(message), f'no gripper attached at t = {stamp:.3f} s'


def serve_command(namespace: str, out: Path, *options: str) -> list[str]:
    """Return the command line of ``run_all.py --serve --sim-time`` for a test's own graph."""
    return [sys.executable, str(REPO_ROOT / 'scripts' / 'run_all.py'), '--serve', '--sim-time',
            '--namespace', namespace, '--out', str(out), *options]


def processes_with(marker: str) -> list[int]:
    """Ids of the processes (other than this one) whose command line contains ``marker``."""
    found = []
    for cmdline in Path('/proc').glob('[0-9]*/cmdline'):
        try:
            if marker in cmdline.read_bytes().decode(errors='replace'):
                found.append(int(cmdline.parent.name))
        except OSError:
            continue
    return [pid for pid in found if pid != os.getpid()]


def realtime_permitted() -> bool:
    """Tell whether a process started from here may set SCHED_FIFO (root, CAP_SYS_NICE, rtprio).

    The trial runs in a child, so this process keeps its own scheduling.
    """
    trial = 'import os; os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(1))'
    return subprocess.run([sys.executable, '-c', trial], capture_output=True,
                          timeout=60).returncode == 0


def thread_policies(pid: int) -> set[tuple[int, int]]:
    """Return the ``(scheduling policy, priority)`` pairs of a process's threads."""
    policies = set()
    for task in Path(f'/proc/{pid}/task').iterdir():
        try:
            policies.add((os.sched_getscheduler(int(task.name)),
                          os.sched_getparam(int(task.name)).sched_priority))
        except ProcessLookupError:  # a thread that ended meanwhile
            continue
    return policies


@contextlib.contextmanager
def running_graph(make_graph, tmp: Path) -> Iterator:
    """Run a graph of node processes in a domain of its own; check how it ended.

    ``make_graph(tmp, domain)`` starts the graph; the object it returns has ``close()`` (which
    returns each process's exit code by name), ``group`` (its ``ProcessGroup``) and
    ``gripper_states`` (every ``GripperStates`` message its client saw). On leaving, every node
    must have stopped cleanly on SIGINT (a node that hangs or fails in its shutdown is a defect
    the test names, with the end of its log) and a gripper must have been attached throughout.
    """
    with isolated_domain() as domain:
        graph = make_graph(tmp, domain)
        try:
            yield graph
        finally:
            codes = graph.close()
        unclean = {name: code for name, code in codes.items() if code != 0}
        assert not unclean, _unclean_exits(graph.group, unclean)
        assert_always_attached(graph.gripper_states)


def _unclean_exits(group, unclean: dict) -> str:
    """Describe the nodes that did not exit with code 0, each with the end of its log."""
    return (f'nodes that did not stop cleanly (exit codes): {unclean}\n'
            + log_tails(group, list(unclean), lines=60))


def log_tails(group, names: list[str], lines: int = 40) -> str:
    """Return the end of the logs of the named nodes of a ``ProcessGroup`` (newest process each).

    For failure messages: CI keeps no files.
    """
    newest = {process.spec.name: process for process in group.processes}
    return '\n'.join(f'--- end of the log of {name} ---\n{newest[name].log_tail(lines)}'
                     for name in names)
