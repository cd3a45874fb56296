"""What the benchmarks share: the machine, process CPU and memory from /proc, statistics.

Every figure here comes from the operating system (``/proc/<pid>/stat``, ``status``, ``fd``)
or from the monotonic clock; nothing is estimated. Percentiles are numpy's (linear
interpolation).
"""

from __future__ import annotations

import dataclasses
import datetime
import json
import os
import platform
import subprocess
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
RESULTS = REPO / 'benchmarks' / 'results'
NOISE_NOTE = ('2-core virtual machine shared with other work: timings are noisy and '
              'pessimistic; compare runs by their load averages, rerun on a quiet machine')

__all__ = ['REPO', 'RESULTS', 'NOISE_NOTE', 'machine_info', 'commit', 'percentiles_ms',
           'ProcessStats', 'process_stats', 'CpuMeter', 'write_json', 'fastdds_shm_files',
           'load_events', 'loop_statistics']


def machine_info() -> dict:
    """CPU count, load average, Python and pybullet versions, date and commit."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        pybullet = version('pybullet')
    except PackageNotFoundError:
        pybullet = None
    return {'cpus': os.cpu_count(), 'python': platform.python_version(),
            'pybullet': pybullet, 'machine': platform.machine(),
            'date': datetime.datetime.now(datetime.UTC).isoformat(timespec='seconds'),
            'commit': commit(), 'load_average_1_5_15': [round(x, 2) for x in os.getloadavg()]}


def commit() -> str:
    """Short hash of the checked-out commit ('' outside git), '+' when the tree is dirty."""
    def git(*args: str) -> str:
        return subprocess.run(['git', *args], cwd=REPO, capture_output=True,
                              text=True).stdout.strip()

    head = git('rev-parse', '--short', 'HEAD')
    return head + ('+' if head and git('status', '--porcelain', '--untracked-files=no') else '')


def percentiles_ms(values_ns) -> dict:
    """Count, median, p99 and max of nanosecond values, in milliseconds."""
    import numpy as np

    values = np.asarray(values_ns, dtype=float)
    if values.size == 0:
        return {'count': 0}
    ms = values / 1e6
    return {'count': int(ms.size), 'median_ms': round(float(np.median(ms)), 4),
            'p99_ms': round(float(np.percentile(ms, 99)), 4), 'max_ms': round(float(ms.max()), 4)}


@dataclasses.dataclass(frozen=True)
class ProcessStats:
    """One reading of a process from /proc."""

    cpu_seconds: float      # user + system time so far [s]
    rss_bytes: int          # resident set size now
    peak_rss_bytes: int     # VmHWM: the largest resident set so far
    open_files: int         # entries in /proc/<pid>/fd


def process_stats(pid: int) -> ProcessStats | None:
    """Read a process's CPU time, memory and open files; None once it has exited."""
    try:
        stat = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()
        status = Path(f'/proc/{pid}/status').read_text().splitlines()
        fds = len(os.listdir(f'/proc/{pid}/fd'))
    except (FileNotFoundError, ProcessLookupError, PermissionError):
        return None
    fields = {line.split(':', 1)[0]: line.split(':', 1)[1].split() for line in status
              if ':' in line}

    def kilobytes(name: str) -> int:
        return int(fields.get(name, ['0'])[0]) * 1024

    ticks = os.sysconf('SC_CLK_TCK')
    return ProcessStats((int(stat[11]) + int(stat[12])) / ticks, kilobytes('VmRSS'),
                        kilobytes('VmHWM'), fds)


class CpuMeter:
    """CPU time of a set of processes over a window: ``start()``, then ``stop()``.

    Parameters
    ----------
    pids : dict
        Process name -> pid.
    """

    def __init__(self, pids: dict[str, int]) -> None:
        self.pids = dict(pids)
        self._before: dict[str, float] = {}
        self._started = 0.0

    def start(self) -> None:
        """Take the first reading."""
        import time

        self._started = time.monotonic()
        self._before = {name: s.cpu_seconds for name, pid in self.pids.items()
                        if (s := process_stats(pid)) is not None}

    def stop(self) -> dict:
        """Return the CPU use of each process over the window, and its peak memory.

        CPU as a fraction of one core; peak memory is VmHWM; with the window's wall time.
        """
        import time

        wall = time.monotonic() - self._started
        cpu, peak = {}, {}
        for name, pid in self.pids.items():
            stats = process_stats(pid)
            if stats is None or name not in self._before:
                continue
            cpu[name] = round((stats.cpu_seconds - self._before[name]) / wall, 4)
            peak[name] = stats.peak_rss_bytes
        return {'wall_s': round(wall, 3), 'cpu_fraction': cpu,
                'cpu_fraction_total': round(sum(cpu.values()), 4),
                'peak_rss_bytes': peak, 'peak_rss_bytes_total': sum(peak.values())}


def fastdds_shm_files() -> int:
    """Count the Fast DDS shared-memory files in /dev/shm (all users' runs)."""
    shm = Path('/dev/shm')
    if not shm.is_dir():
        return 0
    return sum(1 for p in shm.iterdir() if 'fastrtps' in p.name or 'fastdds' in p.name)


def write_json(path: Path, document: dict) -> None:
    """Write a result file (indented JSON, NaN written as null)."""
    import math

    def clean(value):
        if type(value).__module__ == 'numpy' and hasattr(value, 'item'):
            value = value.item()  # numpy scalars
        if isinstance(value, float) and not math.isfinite(value):
            return None
        if isinstance(value, dict):
            return {k: clean(v) for k, v in value.items()}
        if isinstance(value, (list, tuple)):
            return [clean(v) for v in value]
        return value

    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(clean(document), indent=1) + '\n')


def load_events(path: Path) -> dict:
    """Read the probe file :mod:`loop_probe` writes (numpy arrays by name)."""
    import numpy as np

    with np.load(path) as data:
        return {name: data[name] for name in data.files}


def loop_statistics(events: dict, start_ns: int, end_ns: int, period_ns: int) -> dict:
    """Latencies, missed periods and sim-time progress of the states published in a window.

    Parameters
    ----------
    events : dict
        The probe's arrays (:func:`load_events`).
    start_ns, end_ns : int
        The window, on the monotonic clock [ns]: states whose publishing started in it count.
    period_ns : int
        The control period [ns].

    Returns
    -------
    dict
        ``effort_latency``: from the plant starting to publish a state to each effort answering
        it reaching the plant's callback; ``all_five_latency``: to the last of the five (the
        loop's round trip); ``missed_periods``: states whose five efforts had not all reached
        the plant before its next timer tick (real time; in sim time the plant waits for them,
        so none is missed and the round trip sets the pace instead); ``plant_step``: from the
        fifth effort of one state to the start of publishing the next (the plant's own part of
        a lock-stepped period: physics and publishing); ``sim_seconds`` advanced in the window
        and ``real_time_factor`` (sim time); the plant's own counters over the window.
    """
    import numpy as np

    stamps, sent = events['publish_stamp'], events['publish_time']
    inside = np.flatnonzero((sent >= start_ns) & (sent < end_ns))
    wall_s = (end_ns - start_ns) / 1e9
    result: dict = {'window_s': round(wall_s, 3), 'states_published': int(inside.size),
                    'expected_periods': int(round(wall_s * 1e9 / period_ns))}
    if inside.size == 0:
        return result
    # First publication of each stamp (a lock-stepped plant may re-send the first state).
    order = np.argsort(stamps, kind='stable')
    unique_stamps, first = np.unique(stamps[order], return_index=True)
    first_sent = sent[order][first]
    effort_stamp, effort_time = events['effort_stamp'], events['effort_time']
    effort_count = events['effort_count']
    slot = np.searchsorted(unique_stamps, effort_stamp)
    slot = np.clip(slot, 0, max(0, unique_stamps.size - 1))
    known = unique_stamps[slot] == effort_stamp
    window_stamps = np.unique(stamps[inside])
    in_window = known & np.isin(effort_stamp, window_stamps)
    latency = effort_time[in_window] - first_sent[slot[in_window]]
    # The round trip: the arrival that completes the five joints of a state.
    joints = np.zeros(unique_stamps.size, dtype=np.int64)
    np.add.at(joints, slot[in_window], effort_count[in_window])
    last = np.full(unique_stamps.size, -1, dtype=np.int64)
    np.maximum.at(last, slot[in_window], effort_time[in_window])
    w = np.searchsorted(unique_stamps, window_stamps)
    complete = joints[w] >= 5
    round_trip = last[w][complete] - first_sent[w][complete]
    ticks = events['tick']
    if ticks.size:
        following = np.searchsorted(ticks, first_sent[w], side='right')
        has_next = following < ticks.size
        deadline = np.where(has_next, ticks[np.minimum(following, ticks.size - 1)], 0)
        in_time = complete & has_next & (last[w] <= deadline)
        missed = int(w.size - np.count_nonzero(in_time))
    else:
        missed = 0
    # Plant's part of a lock-stepped period: fifth effort of state k -> publishing state k+1.
    next_sent = first_sent[w[:-1] + 1] if w.size > 1 else np.zeros(0, dtype=np.int64)
    step = next_sent - last[w[:-1]]
    step = step[complete[:-1] & (step > 0)]
    sim_seconds = (window_stamps[-1] - window_stamps[0]) / 1e9 if window_stamps.size > 1 else 0.0

    def delta(name: str) -> int:
        values = events[name]
        return int(values[inside[-1]] - values[inside[0]]) if values.size else 0

    result.update({
        'effort_latency': percentiles_ms(latency),
        'all_five_latency': percentiles_ms(round_trip),
        'missed_periods': missed, 'missed_fraction': round(missed / max(1, w.size), 4),
        'states_without_all_five': int(w.size - np.count_nonzero(complete)),
        'plant_step': percentiles_ms(step),
        'sim_seconds': round(float(sim_seconds), 3),
        'real_time_factor': round(float(sim_seconds / wall_s), 4),
        'plant_counted_missed_joint_periods': delta('plant_missed'),
        'plant_overrun_periods': delta('overruns'),
        'lockstep_timeouts': delta('lockstep_timeouts'),
    })
    return result
