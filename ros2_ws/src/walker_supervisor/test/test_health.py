"""The supervisor's health monitor: silence and reported trouble, on the steady clock."""

import pytest

from walker_supervisor.core.health import HealthMonitor, Level


def test_silence_after_the_timeout_is_a_fault_and_trouble_a_warning():
    monitor = HealthMonitor({'plant': 0.5, 'controller': 0.5})
    assert {s.message for s in monitor.status(0.0)} == {'not heard from yet'}
    monitor.seen('plant', 1.0)
    monitor.seen('controller', 1.0, 'holding: its inputs are stale')
    status = {s.name: s for s in monitor.status(1.2)}
    assert status['plant'].level == Level.OK
    assert status['controller'].level == Level.WARN
    assert monitor.faults(1.2, include_trouble=False) == []
    assert monitor.faults(1.2, include_trouble=True) == [
        'controller: holding: its inputs are stale']
    faults = monitor.faults(1.6, include_trouble=False)
    assert len(faults) == 2 and all('silent for 0.60 s' in f for f in faults)
    monitor.seen('plant', 1.7)
    assert [f.split(':')[0] for f in monitor.faults(1.7, include_trouble=False)] == ['controller']


def test_bad_sources_and_timeouts_are_refused():
    with pytest.raises(ValueError, match='positive'):
        HealthMonitor({'plant': 0.0})
    with pytest.raises(KeyError, match='unknown source'):
        HealthMonitor({'plant': 1.0}).seen('planner', 0.0)


def test_trouble_is_a_fault_only_once_it_has_lasted_the_grace_without_a_break():
    monitor = HealthMonitor({'controller': 1.0}, trouble_grace=0.5)
    monitor.seen('controller', 10.0, 'holding: its inputs are stale')
    monitor.seen('controller', 10.3, 'holding: its inputs are stale')
    # reported, but not yet long enough: a step that just started may still clear it
    assert monitor.faults(10.3, include_trouble=True) == []
    assert monitor.status(10.3)[0].level == Level.WARN
    monitor.seen('controller', 10.4, '')  # cleared: the clock starts again
    monitor.seen('controller', 10.6, 'holding: its inputs are stale')
    assert monitor.faults(11.0, include_trouble=True) == []
    monitor.seen('controller', 11.1, 'holding: its inputs are stale')
    assert monitor.faults(11.1, include_trouble=True) == [
        'controller: holding: its inputs are stale']
    assert monitor.faults(11.1, include_trouble=False) == []


def test_a_negative_grace_is_refused():
    with pytest.raises(ValueError, match='trouble_grace'):
        HealthMonitor({'plant': 1.0}, trouble_grace=-0.1)
