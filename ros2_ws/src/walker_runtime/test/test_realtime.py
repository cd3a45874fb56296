"""Real-time scheduling requests: refusals of bad priorities, and what a granted one does.

The requests run in child processes, so the test process keeps its own scheduling.
"""

import os
import subprocess
import sys
import threading

import pytest

from walker_runtime.realtime import (
    log_realtime_request, request_realtime_priority, request_thread_priority)


@pytest.mark.parametrize('priority', [-1, 100, 1.5, True, '50', None])
def test_a_priority_outside_0_to_99_is_refused_and_nothing_changes(priority):
    before = os.sched_getscheduler(0)
    with pytest.raises(ValueError, match='0..99'):
        request_realtime_priority(priority)
    assert os.sched_getscheduler(0) == before


@pytest.mark.parametrize('priority', [-1, 100, 1.5, True, '50', None])
def test_a_thread_priority_outside_0_to_99_is_refused_and_nothing_changes(priority):
    before = os.sched_getscheduler(0)
    with pytest.raises(ValueError, match='0..99'):
        request_thread_priority(threading.get_native_id(), priority)
    assert os.sched_getscheduler(0) == before


_THREAD_CHILD = """
import os, threading
from walker_runtime.realtime import request_realtime_priority, request_thread_priority
started, done = threading.Event(), threading.Event()
def work():
    started.set(); done.wait(10.0)
worker = threading.Thread(target=work); worker.start(); started.wait()
print(*request_realtime_priority(5))
granted, report = request_thread_priority(worker.native_id, 9)
tasks = [int(task) for task in os.listdir(f'/proc/{os.getpid()}/task')]
policies = {t: (os.sched_getscheduler(t), os.sched_getparam(t).sched_priority) for t in tasks}
done.set(); worker.join()
others = {value for task, value in policies.items() if task != worker.native_id}
print(granted, policies[worker.native_id] == (os.SCHED_FIFO, 9), others == {(os.SCHED_FIFO, 5)})
print(report)
"""


def test_one_thread_is_moved_above_the_rest_of_its_process():
    """The process at 5, then one of its threads at 9: that thread alone, the others stay.

    Refused (no privilege): the report says why.
    """
    child = subprocess.run([sys.executable, '-c', _THREAD_CHILD], capture_output=True,
                           text=True, env=os.environ, timeout=60)
    assert child.returncode == 0, child.stderr
    process, first, report = child.stdout.splitlines()[:3]
    granted, moved, others_stay = first.split()
    if process.startswith('True'):
        assert (granted, moved, others_stay) == ('True', 'True', 'True'), child.stdout
        assert report.startswith('SCHED_FIFO priority 9 on thread ')
    else:
        assert granted == 'False' and 'refused' in report, child.stdout


def test_priority_0_leaves_the_scheduling_alone():
    before = os.sched_getscheduler(0), os.sched_getparam(0).sched_priority
    assert request_realtime_priority(0) == (False, 'default scheduling (real-time priority 0)')
    assert (os.sched_getscheduler(0), os.sched_getparam(0).sched_priority) == before


_CHILD = """
import os, threading
from walker_runtime.realtime import request_realtime_priority
listed = threading.Event()  # the threads live until they have been looked at, however slow
early = threading.Thread(target=listed.wait); early.start()
granted, report = request_realtime_priority(7)
late = threading.Thread(target=listed.wait); late.start()
policies = set()
for task in os.listdir(f'/proc/{os.getpid()}/task'):
    policies.add((os.sched_getscheduler(int(task)), os.sched_getparam(int(task)).sched_priority))
listed.set(); early.join(); late.join()
print(granted, sorted(policies) == [(os.SCHED_FIFO, 7)], sorted(policies) == [(os.SCHED_OTHER, 0)])
print(report)
"""


def test_a_granted_request_moves_every_thread_and_a_refused_one_none():
    """A granted request moves every thread; a refused one none, and says why.

    Threads started before and after the request all run under SCHED_FIFO when it is granted;
    when it is refused (no privilege), none does.
    """
    child = subprocess.run([sys.executable, '-c', _CHILD], capture_output=True, text=True,
                           env=os.environ, timeout=60)
    assert child.returncode == 0, child.stderr
    first, report = child.stdout.splitlines()[:2]
    granted, all_fifo, all_default = first.split()
    if granted == 'True':
        assert all_fifo == 'True', child.stdout
        assert report == f'SCHED_FIFO priority 7 on {report.split()[-2]} threads'
    else:
        assert all_default == 'True', child.stdout
        assert 'refused' in report and 'default scheduling' in report


class _Logger:
    def __init__(self):
        self.lines = []

    def info(self, text):
        self.lines.append(('info', text))

    def warning(self, text):
        self.lines.append(('warning', text))


def test_the_outcome_is_logged_and_priority_0_is_not_a_warning():
    logger = _Logger()
    assert log_realtime_request(logger, 0) is False
    assert logger.lines == [('info', 'default scheduling (real-time priority 0)')]


def test_a_request_refused_part_way_puts_the_threads_it_moved_back(monkeypatch):
    """Refused on the second of three threads: the first is back as it was, nothing half-applied.

    The scheduler calls are replaced, so the test process's own scheduling is not touched.
    """
    import walker_runtime.realtime as realtime

    policies = {1: (os.SCHED_OTHER, 0), 2: (os.SCHED_OTHER, 0), 3: (os.SCHED_BATCH, 0)}

    def set_scheduler(thread, policy, param):
        if policy == os.SCHED_FIFO and thread == 2:
            raise PermissionError('not permitted')
        policies[thread] = (policy, param.sched_priority)

    monkeypatch.setattr(realtime, '_threads', lambda pid: [1, 2, 3])
    monkeypatch.setattr(realtime.os, 'sched_setscheduler', set_scheduler)
    monkeypatch.setattr(realtime.os, 'sched_getscheduler', lambda thread: policies[thread][0])
    monkeypatch.setattr(realtime.os, 'sched_getparam',
                        lambda thread: os.sched_param(policies[thread][1]))
    granted, report = request_realtime_priority(50)
    assert not granted and 'no permission' in report and 'default scheduling' in report
    assert policies == {1: (os.SCHED_OTHER, 0), 2: (os.SCHED_OTHER, 0),
                        3: (os.SCHED_BATCH, 0)}
