"""Real-time scheduling of the control-loop processes (the plant and the joint controllers).

On a machine shared with other work, a controller that is ready to answer a joint state waits
for the scheduler: on the 2-core development machine that wait, not the control law, makes
most of the control loop's p99 round trip (docs/performance.md). Like ``ros2_control``'s
controller manager (its ``thread_priority``), a loop process may ask the kernel for the
``SCHED_FIFO`` policy, under which it runs as soon as it is ready, ahead of every ordinary
process. Every thread of the process is moved, the middleware's receive threads included, and
threads started later inherit the policy, and so would processes it started (the node
processes start none). The nodes therefore ask in their executables' ``main``, for the process
they own: a node built inside another process (a composed graph, a test) leaves that process's
scheduling alone, since every process started from it afterwards would inherit the priority.
(``SCHED_RESET_ON_FORK`` is no way out: it also resets the threads the process starts later.)

The request needs the privilege to set real-time priorities (root, ``CAP_SYS_NICE``, or an
``rtprio`` limit in ``/etc/security/limits.conf``); without it the process keeps the default
policy and says so, as ``ros2_control`` does. The kernel's real-time throttling
(``/proc/sys/kernel/sched_rt_runtime_us``, by default 95 % of each second) keeps a busy
real-time process from locking the machine up.

This module talks to the operating system only; it does not import rclpy.
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ['MAX_PRIORITY', 'request_realtime_priority', 'request_thread_priority',
           'log_realtime_request']

#: Highest ``SCHED_FIFO`` priority Linux accepts.
MAX_PRIORITY = 99


def _threads(pid: int) -> list[int]:
    try:
        return sorted(int(entry.name) for entry in Path(f'/proc/{pid}/task').iterdir())
    except OSError:
        return [pid]


def request_realtime_priority(priority: int) -> tuple[bool, str]:
    """Run every thread of this process under ``SCHED_FIFO`` at ``priority``, if permitted.

    Parameters
    ----------
    priority : int
        1..99: the ``SCHED_FIFO`` priority; 0: leave the scheduling as it is.

    Returns
    -------
    tuple of (bool, str)
        Whether the process now runs under ``SCHED_FIFO``, and a one-line report for the log
        (why not, when it does not).

    Raises
    ------
    ValueError
        For a priority outside 0..99; nothing changes.
    """
    refused = _unavailable(priority)
    if refused:
        return False, refused
    param = os.sched_param(priority)
    moved: list[tuple[int, int, int]] = []  # (thread, policy, priority) before the change
    for thread in _threads(os.getpid()):
        try:
            before = (thread, os.sched_getscheduler(thread),
                      os.sched_getparam(thread).sched_priority)
            os.sched_setscheduler(thread, os.SCHED_FIFO, param)
            moved.append(before)
        except ProcessLookupError:  # a thread that ended meanwhile
            continue
        except OSError as error:
            _restore(moved)  # refused part-way: every thread back as it was
            return False, (f'SCHED_FIFO priority {priority} refused ({_why_refused(error)}); '
                           f'default scheduling')
    return True, f'SCHED_FIFO priority {priority} on {len(moved)} threads'


def request_thread_priority(thread: int, priority: int) -> tuple[bool, str]:
    """Run one thread of this process under ``SCHED_FIFO`` at ``priority``, if permitted.

    For a thread whose work has deadlines the rest of its process does not have (the planner's
    setpoint stream, which the controllers wait for every control period).

    Parameters
    ----------
    thread : int
        The thread's native id (``threading.Thread.native_id``).
    priority : int
        As :func:`request_realtime_priority`.

    Returns
    -------
    tuple of (bool, str)
        Whether the thread now runs under ``SCHED_FIFO`` at ``priority``, and a report.

    Raises
    ------
    ValueError
        For a priority outside 0..99; nothing changes.
    """
    refused = _unavailable(priority)
    if refused:
        return False, refused
    try:
        os.sched_setscheduler(thread, os.SCHED_FIFO, os.sched_param(priority))
    except OSError as error:
        return False, (f'SCHED_FIFO priority {priority} for thread {thread} refused '
                       f'({_why_refused(error)})')
    return True, f'SCHED_FIFO priority {priority} on thread {thread}'


def _why_refused(error: OSError) -> str:
    return ('no permission: needs root, CAP_SYS_NICE or an rtprio limit'
            if isinstance(error, PermissionError) else str(error))


def _unavailable(priority: int) -> str:
    """Why ``priority`` is not to be asked for ('' when it is); ValueError when invalid."""
    if isinstance(priority, bool) or not isinstance(priority, int) \
            or not 0 <= priority <= MAX_PRIORITY:
        raise ValueError(f'real-time priority must be an integer 0..{MAX_PRIORITY} '
                         f'(0: the default scheduler), got {priority!r}')
    if priority == 0:
        return 'default scheduling (real-time priority 0)'
    if not hasattr(os, 'sched_setscheduler'):
        return 'real-time priority not available on this platform; default scheduling'
    return ''


def _restore(moved: list[tuple[int, int, int]]) -> None:
    """Put threads back under the policy and priority they had (lowering is always allowed)."""
    for thread, policy, priority in moved:
        try:
            os.sched_setscheduler(thread, policy, os.sched_param(priority))
        except OSError:  # a thread that ended meanwhile
            continue


def log_realtime_request(logger, priority: int) -> bool:
    """Request ``priority`` (:func:`request_realtime_priority`) and log the outcome.

    ``logger`` is anything with ``info`` and ``warning`` methods (a node's logger). A refused
    request is a warning, not an error: the process runs on under the default policy.
    Returns whether the process now runs under ``SCHED_FIFO``.
    """
    granted, report = request_realtime_priority(priority)
    (logger.info if granted or priority == 0 else logger.warning)(report)
    return granted
