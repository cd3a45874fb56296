"""Sample running node processes with py-spy and say where their CPU time goes.

py-spy (``pip install py-spy``; a sampling profiler that attaches to a running Python process
and unwinds both the Python and the native stacks) records each process for a few seconds
(``--native``, raw collapsed stacks); :func:`categorise` then assigns every sample to one of a
few categories by the innermost frame that says what it is:

* ``idle``: waiting (condition variables, semaphores, epoll): not CPU time;
* ``physics``: Bullet and pybullet;
* ``dds``: Fast DDS, the rmw layer and rcl (publishing, taking, transport, waking readers);
* ``message conversion``: rosidl's Python <-> C conversion of message fields;
* ``executor``: rclpy's C++ executor and the rest of its binding (``_rclpy_pybind11``);
* ``rclpy (Python)``: rclpy's own Python code (executor loop, publishers, clocks, timers);
* ``message classes (Python)``: the generated message classes' Python (constructors, setters);
* ``node and core code``: the walker's packages (``walker_*``);
* ``numpy``, ``python interpreter``: the rest.

Shares are of the samples that are not idle (the process's CPU time); py-spy samples at
100 Hz, so a 10 s record of a busy process holds about 1000 samples.
"""

from __future__ import annotations

import collections
import shutil
import subprocess
import sys
from pathlib import Path

__all__ = ['py_spy', 'record', 'categorise', 'top_functions', 'CATEGORIES']

CATEGORIES = ('physics', 'dds', 'message conversion', 'executor', 'rclpy (Python)',
              'message classes (Python)', 'node and core code', 'numpy', 'python interpreter',
              'other native')
_IDLE = ('pthread_cond_timedwait', 'pthread_cond_wait', 'sem_timedwait', 'sem_wait',
         'epoll_wait', '__futex', 'futex_wait', 'nanosleep', 'clock_nanosleep', 'poll ',
         '__select', 'do_futex_wait', 'select (')


def py_spy() -> str | None:
    """Path of the py-spy executable (next to this Python, or on the PATH), or None."""
    beside = Path(sys.executable).with_name('py-spy')
    return str(beside) if beside.exists() else shutil.which('py-spy')


def record(pid: int, seconds: float, output: Path, rate: int = 100) -> subprocess.Popen:
    """Start recording a process (native and Python stacks, raw format); return the recorder.

    Wait for the returned process to end before reading ``output``.
    """
    executable = py_spy()
    if executable is None:
        raise FileNotFoundError('py-spy is not installed (pip install py-spy)')
    return subprocess.Popen(
        [executable, 'record', '--pid', str(pid), '--duration', str(max(1, round(seconds))),
         '--rate', str(rate), '--native', '--format', 'raw', '--output', str(output)],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def _idle(frames: list[str]) -> bool:
    # The innermost frames of a wait are often unnamed libc addresses under the wait call.
    return any(word in frame for frame in frames[-3:] for word in _IDLE)


def _stacks(path: Path):
    for line in Path(path).read_text().splitlines():
        stack, _, count = line.rpartition(' ')
        if stack and count.isdigit():
            yield stack.split(';'), int(count)


def _category(frame: str) -> str | None:
    if any(word in frame for word in ('(libBullet', 'bt', 'b3', 'pybullet')) and (
            'pybullet' in frame or '.cpp' in frame or '.h:' in frame or 'libBullet' in frame):
        return 'physics'
    if any(word in frame for word in ('eprosima', 'libfastrtps', 'libfastcdr', 'rmw_',
                                      'librcl.so', 'rcl_', 'librcutils', 'rcutils_')):
        return 'dds'
    if 'convert_from_py' in frame or 'convert_to_py' in frame or 'rosidl_generator_py' in frame:
        return 'message conversion'
    if '_rclpy_pybind11' in frame:
        return 'executor'
    if '(rclpy/' in frame:
        return 'rclpy (Python)'
    if '/msg/_' in frame or '/srv/_' in frame or '/action/_' in frame:
        return 'message classes (Python)'
    if '(walker_' in frame:
        return 'node and core code'
    if 'numpy' in frame:
        return 'numpy'
    if 'libpython' in frame or '<frozen' in frame:
        return 'python interpreter'
    return None


def categorise(path: Path) -> dict:
    """Shares of the non-idle samples per category, and the idle share of all samples."""
    counts: collections.Counter = collections.Counter()
    total = idle = 0
    for frames, count in _stacks(path):
        total += count
        if _idle(frames):
            idle += count
            continue
        category = next((c for f in reversed(frames) if (c := _category(f))), 'other native')
        counts[category] += count
    busy = total - idle
    return {'samples': total, 'idle_share': round(idle / total, 3) if total else None,
            'busy_samples': busy,
            'shares': {c: round(counts[c] / busy, 3) for c in CATEGORIES if busy and counts[c]}}


def top_functions(path: Path, count: int = 12) -> list[tuple[str, float]]:
    """List the walker functions whose frames (with what they call) take most busy samples."""
    inclusive: collections.Counter = collections.Counter()
    busy = 0
    for frames, samples in _stacks(path):
        if _idle(frames):
            continue
        busy += samples
        names = {f.split(' (')[0] + ' (' + f.split(' (')[1].split(':')[0] + ')'
                 for f in frames if '.py:' in f and '(walker_' in f}
        for name in names:
            inclusive[name] += samples
    return [(name, round(n / busy, 3)) for name, n in inclusive.most_common(count)] if busy \
        else []
