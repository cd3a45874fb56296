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
import time
from pathlib import Path
from collections.abc import Iterator

__all__ = ['REPO_ROOT', 'isolated_domain', 'ros_environment', 'NodeProcess']

REPO_ROOT = Path(__file__).resolve().parents[1]
# Domain ids that map to valid DDS ports on Linux (0 is left to interactive use).
_DOMAIN_IDS = range(1, 102)


@contextlib.contextmanager
def isolated_domain() -> Iterator[int]:
    """Reserve a ROS domain id no other test run on this machine is using."""
    lock_dir = Path(tempfile.gettempdir())
    for domain in _DOMAIN_IDS:
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
    raise RuntimeError('every ROS domain id 1..101 is in use by other test runs')


def ros_environment(domain_id: int) -> dict[str, str]:
    """Return the current environment with an isolated domain and loopback-only discovery."""
    env = dict(os.environ)
    env['ROS_DOMAIN_ID'] = str(domain_id)
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    # ROS logs and the supervisor's step file of this run stay apart from other runs'
    env['ROS_HOME'] = str(Path(tempfile.gettempdir()) / f'walker-ros-home-{domain_id}')
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
