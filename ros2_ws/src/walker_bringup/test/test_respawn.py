"""The supervised bring-up: a dead node started again, given up when it keeps dying.

Each death and restart recorded: the ROS-free decisions, then on real child processes.
"""

import os
import sys
import time

import pytest

from walker_bringup.core.respawn import REFUSED_EXIT_CODE, RespawnBook, RespawnPolicy
from walker_bringup.graph import NodeSpec
from walker_bringup.processes import ProcessGroup
from walker_bringup.respawning import ERROR, OK, WARN, RespawningGroup, exit_text

KILLED = -9  # exit code of a process ended by SIGKILL


def test_a_death_is_answered_by_a_restart_after_the_delay():
    book = RespawnBook(RespawnPolicy(delay=2.0, limit=3))
    decision = book.on_death('planner', KILLED, ran_for=5.0, now=100.0)
    assert decision.respawn and decision.restart_at == 102.0
    assert book.due(101.9) == [] and book.pending
    assert book.due(102.0) == ['planner']
    book.on_restart('planner')
    assert not book.pending and book.due(200.0) == []
    assert book.summary() == {'planner': {'deaths': 1, 'restarts': 1, 'exit_codes': [KILLED],
                                          'gave_up': ''}}


def test_a_node_that_keeps_dying_is_given_up_after_the_limit_of_restarts_in_a_row():
    book = RespawnBook(RespawnPolicy(delay=0.5, limit=2))
    now = 0.0
    for _ in range(2):
        assert book.on_death('plant', 1, ran_for=1.0, now=now).respawn
        now += 0.5
        assert book.due(now) == ['plant']
        book.on_restart('plant')
    third = book.on_death('plant', 1, ran_for=1.0, now=now)
    assert not third.respawn
    assert '3 times in a row' in third.gave_up and '--respawn-limit 2' in third.gave_up
    assert book.given_up == {'plant': third.gave_up} and not book.pending
    assert book.summary()['plant'] == {'deaths': 3, 'restarts': 2, 'exit_codes': [1, 1, 1],
                                       'gave_up': third.gave_up}


def test_a_node_that_ran_long_before_it_died_starts_its_count_again():
    book = RespawnBook(RespawnPolicy(delay=0.0, limit=1, stable_after=60.0))
    assert book.on_death('recorder', KILLED, ran_for=10.0, now=0.0).respawn
    book.on_restart('recorder')
    # a second quick death would be one too many; after an hour of running it is not
    assert book.on_death('recorder', KILLED, ran_for=3600.0, now=3600.0).respawn
    book.on_restart('recorder')
    assert not book.on_death('recorder', KILLED, ran_for=1.0, now=3601.0).respawn


def test_nodes_are_counted_apart_and_restarted_in_the_order_they_died():
    book = RespawnBook(RespawnPolicy(delay=1.0, limit=1))
    book.on_death('planner', KILLED, 5.0, now=10.0)
    book.on_death('controller_vertex', KILLED, 5.0, now=9.5)
    assert book.due(11.0) == ['controller_vertex', 'planner']


def test_a_node_that_refused_its_configuration_is_given_up_at_once():
    book = RespawnBook(RespawnPolicy())
    decision = book.on_death('supervisor', REFUSED_EXIT_CODE, ran_for=0.5, now=0.0)
    assert not decision.respawn and 'refused its configuration' in decision.gave_up


def test_a_limit_of_zero_never_restarts_as_before_respawning():
    decision = RespawnBook(RespawnPolicy(limit=0)).on_death('planner', KILLED, 100.0, 0.0)
    assert not decision.respawn and '--respawn-limit 0' in decision.gave_up


@pytest.mark.parametrize('fields, words', [
    ({'delay': -1.0}, 'delay'), ({'delay': float('nan')}, 'delay'),
    ({'limit': -1}, 'limit'), ({'limit': 1.5}, 'limit'), ({'limit': True}, 'limit'),
    ({'stable_after': 0.0}, 'stable_after')])
def test_a_bad_policy_is_refused_naming_the_field(fields, words):
    with pytest.raises(ValueError, match=words):
        RespawnPolicy(**fields)


def test_exit_text_names_the_signal_of_a_killed_process():
    assert exit_text(-9) == 'killed by SIGKILL'
    assert exit_text(1) == 'exit code 1'


ENV = {**os.environ, 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST'}


def _poll_until(respawner, condition, timeout=20.0):
    given_up = []
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        given_up += respawner.poll()
        if condition(given_up):
            return given_up
        time.sleep(0.05)
    raise AssertionError('the condition did not come true')


def test_a_killed_child_is_started_again_with_the_same_command_and_reported(tmp_path):
    spec = NodeSpec('pkg', 'exe', 'child', '/walker', 'walker.yaml')
    lines = []
    marker = tmp_path / 'starts'
    code = f'open({str(marker)!r}, "a").write("x"); import time; time.sleep(60)'
    with ProcessGroup(tmp_path, ENV) as group:
        first = group.start(spec, [sys.executable, '-c', code])
        respawner = RespawningGroup(group, RespawnPolicy(delay=0.2, limit=2), lines.append)
        _poll_until(respawner, lambda _: marker.exists())
        first.popen.kill()
        _poll_until(respawner, lambda _: marker.exists() and marker.read_text() == 'xx')
        newest = group.processes[-1]
        assert newest is not first and newest.alive and newest.command == first.command
        assert respawner.summary() == {'child': {'deaths': 1, 'restarts': 1,
                                                 'exit_codes': [KILLED], 'gave_up': ''}}
    said = '\n'.join(lines)
    assert 'node child died (killed by SIGKILL, death 1); starting it again in 0.2 s' in said
    assert 'node child started again' in said


def test_a_child_that_keeps_dying_is_given_up_and_handed_back(tmp_path):
    spec = NodeSpec('pkg', 'exe', 'crasher', '/walker', 'walker.yaml')
    lines, reports = [], []
    with ProcessGroup(tmp_path, ENV) as group:
        group.start(spec, [sys.executable, '-c', 'import sys; sys.exit(1)'])
        respawner = RespawningGroup(group, RespawnPolicy(delay=0.0, limit=2), lines.append,
                                    report=lambda *status: reports.append(status))
        given_up = _poll_until(respawner, bool)
    assert [p.spec.name for p in given_up] == ['crasher']
    assert respawner.summary()['crasher']['deaths'] == 3
    assert respawner.summary()['crasher']['restarts'] == 2
    assert 'is not started again: it died 3 times in a row' in lines[-1]
    # each death and restart is the node's status on /diagnostics (the bag records it): a
    # death to be answered WARN, a restart OK, the death given up on ERROR, last
    assert [level for _, level, _ in reports] == [WARN, OK, WARN, OK, ERROR]
    assert {node for node, _, _ in reports} == {'/walker/crasher'}
    assert reports[-1][2].startswith('died (exit code 1) and is not started again')


def test_a_recorder_started_again_continues_its_bag_and_other_nodes_run_as_before(tmp_path):
    from walker_bringup.processes import ManagedProcess
    from walker_bringup.respawning import rejoin_command

    recorder = NodeSpec('walker_bag', 'recorder_node', 'recorder', '/walker', 'walker.yaml')
    plant = NodeSpec('walker_sim', 'plant_node', 'plant', '/walker', 'walker.yaml')
    once = rejoin_command(ManagedProcess(recorder, None, tmp_path, 0.0, command=['rec']))
    assert once == ['rec', '-p', 'recorder.append:=true']
    assert rejoin_command(ManagedProcess(recorder, None, tmp_path, 0.0, command=once)) == once
    assert rejoin_command(ManagedProcess(plant, None, tmp_path, 0.0, command=['p'])) == ['p']
    # a composed graph that records continues its bag too; its plant has its snapshot already
    graph = NodeSpec('walker_bringup', 'composed_graph', 'graph', '/walker', 'walker.yaml')
    recording = ['g', '--record', '--plant-state-file', 's.json']
    again = rejoin_command(ManagedProcess(graph, None, tmp_path, 0.0, command=recording))
    assert again == [*recording, '--append-bag']
    assert rejoin_command(ManagedProcess(graph, None, tmp_path, 0.0, command=again)) == again
    assert rejoin_command(ManagedProcess(graph, None, tmp_path, 0.0, command=['g'])) == ['g']
