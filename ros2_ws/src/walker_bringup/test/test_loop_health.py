"""The loop's record from the plant's diagnostic status, and the line run_all.py prints."""

import pytest

from walker_bringup.loop_health import loop_health, sources_not_heard

JOINTS = ('a_yaw_joint', 'a_pitch_joint', 'vertex_joint', 'b_pitch_joint', 'b_yaw_joint')


def status(mode='real_time', t='30.000', missed=(0, 0, 0, 0, 0), overruns='0', timeouts='0',
           longest=None):
    """Return a status's message and values as the plant writes them (walker_sim.plant_node)."""
    values = {f'missed {joint}': str(count) for joint, count in zip(JOINTS, missed, strict=True)}
    values.update({'refused commands': '0', 'saturated commands': '2', 'expired commands': '0',
                   'overruns commands': overruns, 'lock-step timeouts': timeouts,
                   'not waited for': ''})
    if longest is not None:
        values['longest tick interval [ms]'] = longest
    return f'{mode}, t={t} s, {sum(missed)} missed command periods', values


def test_the_plants_status_is_read():
    health = loop_health(*status(t='12.5', missed=(3, 0, 1, 0, 9), overruns='40',
                                 longest='104.2'))
    assert health.clock_mode == 'real_time' and health.plant_time == 12.5
    assert health.late_periods == 40 and health.late_efforts['b_yaw_joint'] == 9
    assert health.longest_tick_interval == pytest.approx(0.1042)
    assert health.as_dict()['late_efforts'] == dict(zip(JOINTS, (3, 0, 1, 0, 9), strict=True))


def test_a_real_time_loop_that_fell_behind_says_how_far_and_where_to_read_why():
    line = loop_health(*status(t='10.0', missed=(0, 0, 0, 0, 250), overruns='500',
                               longest='73.8')).summary(500.0)
    assert line.startswith('loop: 5000 periods of 2 ms in real time; the plant stepped 500 late '
                           '(10.0 %), standing still 74 ms at worst')
    assert 'efforts came late in 250 periods (5.0 %, b_yaw_joint)' in line
    assert 'Known limits' in line


def test_a_real_time_loop_that_kept_its_period_says_so_plainly():
    line = loop_health(*status(t='2.0', longest='2.1')).summary(500.0)
    assert line == ('loop: 1000 periods of 2 ms in real time; the plant stepped 0 late (0.0 %), '
                    'standing still 2 ms at worst')


@pytest.mark.parametrize('timeouts, words', [
    ('0', 'no timeout'), ('3', 'stopped waiting for late efforts 3 times')])
def test_a_sim_time_loop_reports_its_lock_step(timeouts, words):
    line = loop_health(*status(mode='sim_time', t='24.0', timeouts=timeouts)).summary(500.0)
    assert line.startswith('loop: lock-stepped in sim time, 12000 periods') and words in line


@pytest.mark.parametrize('gate, words', [
    ('0', "lock-stepped in sim time with the supervisor's decisions, 12000 periods, no timeout"),
    ('2', 'and for the supervisor 2 times')])
def test_a_sim_time_loop_waiting_for_the_supervisor_says_so(gate, words):
    message, values = status(mode='sim_time', t='24.0')
    values['supervisor gate timeouts'] = gate
    health = loop_health(message, values)
    assert health.decision_timeouts == int(gate) and words in health.summary(500.0)
    assert loop_health(*status(mode='sim_time')).decision_timeouts is None  # it does not wait


@pytest.mark.parametrize('message, values', [
    ('OK', {}),                                           # not the plant's status
    ('real_time, t=1.0 s, 0 missed', {'overruns commands': 'many'}),
    ('real_time, t=1.0 s, 0 missed', {'longest tick interval [ms]': 'n/a'}),
])
def test_a_status_that_is_not_the_plants_is_ignored(message, values):
    assert loop_health(message, values) is None


def test_the_sources_the_supervisor_has_not_heard_from_are_named():
    values = {'phase': 'IDLE', 'base gripper': 'a', 'plant joint states': 'OK: fresh',
              'controller a_yaw_joint': 'ERROR: not heard from yet',
              'controller vertex_joint': 'ERROR: silent for 2.1 s',
              'controller b_yaw_joint': 'ERROR: not heard from yet'}
    assert sources_not_heard(values) == ['controller a_yaw_joint', 'controller b_yaw_joint']
    assert sources_not_heard({'phase': 'IDLE', 'plant joint states': 'OK: fresh'}) == []
