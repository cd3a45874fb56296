"""The chaos run's plan and figures (walker_bringup.core.chaos), with no process or ROS."""

import math

import pytest

from walker_bringup.core.chaos import (
    FREEZE, KILL, NODES, PHASES, Fault, FaultOutcome, GripCount, moved_on, next_target,
    plan_faults, summarise_outcomes)


def test_a_seed_gives_one_plan_and_another_seed_another():
    assert plan_faults(7, 30) == plan_faults(7, 30)
    assert plan_faults(7, 30) != plan_faults(8, 30)


@pytest.mark.parametrize('seed', range(20))
@pytest.mark.parametrize('count', [9, 12, 30, 31])
def test_every_node_and_every_phase_has_a_fault_and_no_node_fails_twice_in_a_row(seed, count):
    faults = plan_faults(seed, count)
    assert [f.index for f in faults] == list(range(count))
    assert {f.node for f in faults} == set(NODES)
    assert {f.phase for f in faults} == set(PHASES)
    assert all(a.node != b.node for a, b in zip(faults, faults[1:], strict=False))
    assert sum(f.kind == FREEZE for f in faults) == round(count / 2)


def test_in_step_order_each_round_of_phases_runs_as_a_step_does():
    faults = plan_faults(4, 10, in_step_order=True)
    assert [f.phase for f in faults] == [*PHASES, *PHASES, *PHASES[:2]]
    assert [f.node for f in faults] != [f.node for f in plan_faults(5, 10, in_step_order=True)]


def test_freezes_last_within_their_range_and_kills_for_no_time():
    faults = plan_faults(3, 40, freeze=(2.0, 5.0), delay=(0.1, 0.4))
    for fault in faults:
        assert 0.1 <= fault.delay <= 0.4
        if fault.kind == FREEZE:
            assert 2.0 <= fault.hold <= 5.0
        else:
            assert fault.hold == 0.0


def test_a_plan_can_be_narrowed_to_some_nodes_phases_and_kinds():
    faults = plan_faults(1, 3, nodes=('controller_vertex', 'plant'), phases=('COARSE',),
                         freeze_share=0.0)
    assert {f.node for f in faults} == {'controller_vertex', 'plant'}
    assert {f.phase for f in faults} == {'COARSE'} and {f.kind for f in faults} == {KILL}


@pytest.mark.parametrize('arguments, named', [
    ({'count': 0}, 'count'), ({'count': 2.5}, 'count'), ({'seed': 'x'}, 'seed'),
    ({'nodes': ()}, 'nodes'), ({'nodes': ('plant', 'plant')}, 'nodes'),
    ({'phases': ('IDLE',)}, 'phases'), ({'freeze_share': 1.5}, 'freeze_share'),
    ({'freeze': (3.0, 2.0)}, 'freeze'), ({'delay': (-1.0, 0.0)}, 'delay'),
    ({'freeze': (0.0, 1.0)}, 'freeze'), ({'delay': (0.0, math.nan)}, 'delay')])
def test_bad_arguments_are_refused_by_name(arguments, named):
    given = {'seed': 1, 'count': 5, **arguments}
    with pytest.raises(ValueError, match=named):
        plan_faults(**given)


@pytest.mark.parametrize('fields, named', [
    ({'phase': 'IDLE'}, 'phase'), ({'kind': 'SIGTERM'}, 'kind'), ({'delay': -0.1}, 'delay'),
    ({'hold': math.inf}, 'hold'), ({'kind': KILL, 'hold': 1.0}, 'freeze'),
    ({'kind': FREEZE, 'hold': 0.0}, 'freeze')])
def test_a_fault_out_of_range_is_refused_by_name(fields, named):
    given = {'index': 0, 'node': 'plant', 'phase': 'FINE', 'kind': FREEZE, 'delay': 0.0,
             'hold': 2.0, **fields}
    with pytest.raises(ValueError, match=named):
        Fault(**given)


def test_the_figures_count_by_kind_node_and_phase_and_time_only_recovered_faults():
    kill = Fault(0, 'plant', 'COARSE', KILL, 0.0, 0.0)
    freeze = Fault(1, 'planner', 'FINE', FREEZE, 0.2, 3.0)
    outcomes = [FaultOutcome(kill, 'COARSE', held=True, recovered=True, resumes=2,
                             time_to_recover=8.0),
                FaultOutcome(freeze, 'INSERTION', held=True, recovered=True, resumes=1,
                             time_to_recover=4.0),
                FaultOutcome(kill, 'COARSE', held=False, recovered=False, reason='gone')]
    figures = summarise_outcomes(outcomes, grip_losses=0, bag_grip_losses=0)
    assert figures['faults'] == 3
    assert figures['by_kind'] == {KILL: 2, FREEZE: 1}
    assert figures['by_node'] == {'planner': 1, 'plant': 2}
    assert figures['by_phase'] == {'COARSE': 2, 'FINE': 1}
    assert figures['by_phase_seen'] == {'COARSE': 2, 'INSERTION': 1}
    assert figures['held'] == 2 and figures['recovered'] == 2
    assert figures['time_to_recover'] == {'median': 6.0, 'max': 8.0}
    assert figures['resumes'] == {'total': 3, 'max': 2}
    assert figures['grip_losses'] == {'live': 0, 'bag': 0}
    assert outcomes[2].as_dict()['time_to_recover'] is None
    assert summarise_outcomes([], 0)['time_to_recover'] == {'median': None, 'max': None}


def test_the_grip_count_counts_instants_with_no_gripper_attached():
    count = GripCount()
    count.add(['a', 'b'], 1.0)
    count.add(['a'], 2.0)
    count.add([], 3.0)
    count.add([], 4.0)
    assert (count.instants, count.losses, count.first_loss_stamp) == (4, 2, 3.0)


HOLD, MOVING = True, False


@pytest.mark.parametrize('phases, now, expected', [
    ([], 20.0, None),                                     # nothing seen
    ([(1.0, MOVING)], 20.0, None),                        # only before the node came back
    ([(1.0, MOVING), (3.0, MOVING)], 20.0, 3.0),          # went on, never held
    ([(1.0, MOVING), (3.0, MOVING)], 7.0, None),          # not settled yet
    ([(3.0, HOLD), (4.0, MOVING)], 20.0, 4.0),            # held, resumed
    ([(3.0, HOLD), (4.0, MOVING), (6.0, HOLD)], 20.0, None),   # holding again now
    ([(3.0, HOLD), (4.0, MOVING), (6.0, HOLD), (8.0, MOVING), (9.0, MOVING)], 20.0, 8.0),
    ([(3.0, HOLD), (4.0, MOVING), (6.0, HOLD), (8.0, MOVING)], 12.0, None),  # a late hold
])
def test_a_fault_is_recovered_once_the_walker_goes_on_without_a_hold_for_a_while(
        phases, now, expected):
    assert moved_on(phases, back=2.0, now=now, settle=5.0) == expected


def test_the_walker_walks_to_a_target_until_a_gripper_is_in_it_then_to_a_free_one():
    targets = ('n1_2', 'n2_1')
    assert next_target(targets, 'n1_2', {'n1_1', 'n2_1'}) == 'n1_2'  # not there yet
    assert next_target(targets, 'n1_2', {'n1_1', 'n1_2'}) == 'n2_1'
    assert next_target(targets, 'n2_1', {'n1_1', 'n2_1'}) == 'n1_2'
    # the start's base node and its neighbour both held after one step: nothing to walk
    with pytest.raises(ValueError, match=r'every target \(n1_2, n1_1\) has a gripper in it'):
        next_target(('n1_2', 'n1_1'), 'n1_2', {'n1_1', 'n1_2'})
