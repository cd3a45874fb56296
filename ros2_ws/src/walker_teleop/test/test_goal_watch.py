"""A goal's server judged from what its client sees: its status, its answers to probes."""

import pytest

from walker_teleop.core.goal_watch import (
    ANSWER_GRACE, PROBE_PERIOD, SILENCE_LIMIT, GoalWatch, supervisor_status_name)

SERVER, WHAT = '/walker/supervisor', 'the walk to n4_3'


def test_the_supervisors_status_name_is_its_node_name_and_walker():
    assert supervisor_status_name('/walker') == '/walker/supervisor: walker'
    assert supervisor_status_name('/walker_2/') == '/walker_2/supervisor: walker'


def test_a_server_that_keeps_publishing_its_status_is_alive_however_long_the_goal():
    watch = GoalWatch(SERVER, WHAT, now=0.0)
    for t in range(1, 600):
        watch.heard(float(t))
        assert watch.verdict(t + 0.5) == ''


def test_a_silent_server_is_dead_after_the_silence_limit_counted_from_the_start():
    watch = GoalWatch(SERVER, WHAT, now=10.0)
    assert watch.verdict(10.0 + SILENCE_LIMIT - 0.1) == ''  # never heard: counted from 10 s
    watch.heard(12.0)
    assert watch.verdict(12.0 + SILENCE_LIMIT - 0.1) == ''
    assert watch.verdict(12.0 + SILENCE_LIMIT + 0.2) == (
        f'{SERVER} has been silent for {SILENCE_LIMIT + 0.2:.1f} s (it publishes its status '
        f'on /diagnostics every second): it is not running or cannot be reached, and the '
        f'outcome of {WHAT} is unknown: check with walkerctl status')


def test_probes_are_due_once_a_period():
    watch = GoalWatch(SERVER, WHAT, now=0.0)
    due = [t for t in [x * 0.5 for x in range(13)] if watch.probe_due(t)]
    assert due == [PROBE_PERIOD, 2 * PROBE_PERIOD, 3 * PROBE_PERIOD]


def test_a_server_started_again_that_does_not_know_the_goal_is_found_at_once():
    watch = GoalWatch(SERVER, WHAT, now=0.0)
    watch.heard(4.0)
    watch.probe_answered('unknown', '', now=4.0)
    assert watch.verdict(4.0) == f'{SERVER} was started again and does not know {WHAT}: ' \
                                 'it has ended'


@pytest.mark.parametrize('message, said', [
    ('the supervisor restarted', ' (aborted: the supervisor restarted)'), ('', ' (aborted)')])
def test_an_end_answered_to_a_probe_alone_means_another_server_after_a_grace(message, said):
    watch = GoalWatch(SERVER, WHAT, now=0.0)
    watch.heard(4.0)
    watch.probe_answered('aborted', message, now=4.0)
    assert watch.verdict(4.0 + ANSWER_GRACE / 2) == ''  # the first answer may be on its way
    assert watch.verdict(4.0 + ANSWER_GRACE) == \
        f'{SERVER} was started again and ended {WHAT}{said}'
