"""The supervisor's health monitor: silence and reported trouble, on the steady clock."""

import pytest

from walker_supervisor.core.health import (
    MODE_COMMAND_LATENCY, HealthMonitor, Level, ModeRepetition, SourceStatus,
    reason_naming_silent_sources, tracking_expected)


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


def test_a_hold_reason_comes_to_name_the_silent_source_behind_it():
    monitor = HealthMonitor({'plant joint states': 1.0, 'controller vertex_joint': 1.0,
                             'controller a_yaw_joint': 1.0})
    for name in monitor.names:
        monitor.seen(name, 0.0)
    monitor.seen('controller a_yaw_joint', 0.6, 'holding: its inputs are stale')
    first = 'fault: controller a_yaw_joint: holding: its inputs are stale'
    # before the watchdog's timeout, nothing is silent: the reason stays
    assert reason_naming_silent_sources(first, monitor.status(0.9)) == first
    monitor.seen('plant joint states', 1.5)
    reason = reason_naming_silent_sources(first, monitor.status(1.6))
    assert reason == first + '; then controller vertex_joint: silent for 1.60 s (timeout 1 s)'
    # named once: a later look adds nothing, whatever the silence has grown to
    assert reason_naming_silent_sources(reason, monitor.status(2.0)) == reason
    assert reason_naming_silent_sources('', [SourceStatus('plant', Level.ERROR, 'silent')]) \
        == 'plant: silent'
    never = [SourceStatus('planner', Level.ERROR, 'not heard from yet')]
    assert reason_naming_silent_sources(first, never) == first


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


def test_the_sources_not_heard_from_yet_are_listed_until_each_is_heard():
    monitor = HealthMonitor({'plant': 1.0, 'controller': 1.0})
    assert monitor.unheard() == ['plant', 'controller']
    monitor.seen('controller', 3.0)
    assert monitor.unheard() == ['plant']
    monitor.seen('plant', 3.5, 'trouble counts as heard')
    assert monitor.unheard() == []
    assert monitor.faults(10.0, include_trouble=False)  # heard once, silent since: a fault
    assert monitor.unheard() == []


def test_when_each_source_was_last_heard_is_kept_and_unknown_names_are_refused():
    monitor = HealthMonitor({'plant': 1.0, 'controller': 1.0})
    assert monitor.last_heard('plant') is None
    monitor.seen('plant', 2.0)
    monitor.seen('plant', 2.5, 'trouble')
    assert monitor.last_heard('plant') == 2.5 and monitor.last_heard('controller') is None
    with pytest.raises(KeyError, match='planner'):
        monitor.last_heard('planner')


def test_the_mode_publisher_is_renewed_after_repetitions_in_vain_and_not_before():
    repetition = ModeRepetition(renew_after=3)
    assert not repetition.repeat() and not repetition.repeat()
    repetition.heard()  # the controller followed: the count starts over
    assert not repetition.repeat() and not repetition.repeat()
    assert repetition.repeat()  # the third in a row
    assert repetition.renewals == 1 and repetition.repeated == 0
    assert not repetition.repeat()  # the renewed publisher gets its own repetitions


def test_a_mode_repetition_count_below_one_is_refused():
    with pytest.raises(ValueError, match='at least 1'):
        ModeRepetition(renew_after=0)


@pytest.mark.parametrize('busy, mode, after, expected', [
    (True, 'fine', 1.5 * MODE_COMMAND_LATENCY, True),  # long enough after FINE: must track
    (True, 'coarse', 1.0, True),
    (True, 'fine', 0.5 * MODE_COMMAND_LATENCY, False),  # may predate the command's arrival
    (True, 'fine', -0.3, False),  # made before the command (a HOLD while unscrewing)
    (True, 'hold', 1.0, False),  # commanded to hold
    (False, 'fine', 1.0, False),  # between steps
])
def test_a_report_shows_a_fall_back_only_once_the_mode_command_has_had_time_to_arrive(
        busy, mode, after, expected):
    assert tracking_expected(busy, mode, 100.0 + after, 100.0) == expected


def test_new_timeouts_apply_to_every_source_and_keep_what_was_heard():
    monitor = HealthMonitor({'plant': 1.0, 'controller': 1.0}, trouble_grace=1.0)
    monitor.seen('plant', 10.0)
    monitor.seen('controller', 10.0, 'holding')
    assert monitor.faults(12.0, include_trouble=False)  # silent for 2 s, timeout 1 s
    monitor.set_timeouts(3.0, trouble_grace=5.0)
    assert monitor.faults(12.0, include_trouble=True) == []  # 2 s < 3 s; trouble 2 s < 5 s
    assert monitor.last_heard('plant') == 10.0
    with pytest.raises(ValueError, match='timeout'):
        monitor.set_timeouts(0.0, trouble_grace=1.0)
    with pytest.raises(ValueError, match='trouble_grace'):
        monitor.set_timeouts(1.0, trouble_grace=-1.0)
    assert monitor.faults(12.0, include_trouble=True) == []  # nothing changed


def test_an_excused_silence_is_no_fault_and_leaves_a_whole_timeout_after_it():
    monitor = HealthMonitor({'plant': 0.5, 'controller': 0.5, 'heartbeat': 0.5, 'late': 0.5})
    monitor.seen('plant', 1.0)
    monitor.seen('controller', 1.0, 'holding: its inputs are stale')
    monitor.seen('heartbeat', 1.0)
    for now in (1.4, 1.8, 2.2):  # the clock held: the plant and the controller excused
        monitor.excuse(['plant', 'controller', 'late'], now)
    faults = monitor.faults(2.2, include_trouble=False)
    assert [f.split(':')[0] for f in faults] == ['heartbeat', 'late']  # not excused; never heard
    assert monitor.last_heard('plant') == 2.2
    trouble = monitor.faults(2.6, include_trouble=True)[0]
    assert trouble == 'controller: holding: its inputs are stale'  # the report is kept
    assert 'plant' in [f.split(':')[0] for f in monitor.faults(2.8, include_trouble=False)]
    monitor.excuse(['plant'], 1.0)  # an excuse never moves a source's last word back
    assert monitor.last_heard('plant') == 2.2
    with pytest.raises(KeyError):
        monitor.excuse(['nobody'], 3.0)
