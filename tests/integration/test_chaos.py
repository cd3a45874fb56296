"""Seeded chaos on a served graph: nodes killed and frozen in every phase, the walker holds on.

``run_all.py --serve --sim-time`` runs the graph (each node a process of its own, recorded,
supervised); the chaos driver (``walker_bringup.chaos_driver``) walks it between two truss nodes
and applies faults planned from a seed (``walker_bringup.core.chaos``): ``SIGKILL`` of a node,
which the bring-up starts again, or ``SIGSTOP`` for a few seconds, then ``SIGCONT``; a held
step is resumed as an operator would. The checks are the user's: no instant without a gripper
attached (live and in the bag), every fault recovered and the walk reaching its target without
starting ``run_all.py`` again, nothing left running, every file of the bag readable whole.

The smoke (two faults, one step) runs in the default suite; the full run (30 faults over the
nine nodes and the four phases across a multi-step walk) only when asked: ``-m chaos``.
"""

import pytest

from chaos_run import run_chaos
from walker_bringup.core.chaos import KILL, NODES, PHASES

pytestmark = pytest.mark.integration

SEED = 41


def assert_survived(result: dict, count: int) -> dict:
    """Check what every chaos run must give; return its figures."""
    figures = result['figures']
    failures = [o for o in result['outcomes'] if not o['recovered']]
    assert not result['error'], result['error'] + '\n' + result['output'][-4000:]
    assert figures['faults'] == count and figures['recovered'] == count, failures
    assert result['reached'], 'the walk did not reach its target'
    assert result['exit_code'] == 0, result['output'][-4000:]
    # the walker never let go: live and in the bag, with instants seen in both
    assert figures['grip_losses'] == {'live': 0, 'bag': 0}, figures
    assert result['grip_instants']['live'] > 0 and result['grip_instants']['bag'] > 0
    # the graph outlived its faults: each kill answered by a restart, nobody given up on
    kills = {}
    for outcome in result['outcomes']:
        if outcome['kind'] == KILL:
            kills[outcome['node']] = kills.get(outcome['node'], 0) + 1
    for node, killed in kills.items():
        record = result['processes'][node]
        assert record['restarts'] >= killed and not record['gave_up'], (node, record)
    # nothing left: no process of the run, no shared-memory file of its processes
    assert result['left_running'] == []
    assert result['stale_shared_memory'] == []
    # every file of the bag read to its end by the MCAP reader, the whole bag by rosbags
    bag = result['bag']
    assert bag['files'] and bag['messages'] == sum(bag['files'].values()) == \
        bag['metadata_messages'], bag
    return figures


@pytest.mark.timeout(900)
def test_a_short_seeded_chaos_step_is_survived(tmp_path):
    """Two faults (in a coarse motion and a screw-in) in one step to the next node."""
    count = 2
    result = run_chaos(tmp_path / 'run', SEED, count, targets=('n1_2', 'n2_1'),
                       phases=('COARSE', 'INSERTION'), in_step_order=True)
    assert_survived(result, count)


@pytest.mark.chaos
@pytest.mark.timeout(5400)
def test_thirty_seeded_faults_over_every_node_and_phase_are_survived(tmp_path):
    count = 30
    result = run_chaos(tmp_path / 'run', SEED, count, in_step_order=True)
    figures = assert_survived(result, count)
    assert set(figures['by_node']) == set(NODES)
    assert set(figures['by_phase']) == set(PHASES)
    assert set(figures['by_phase_seen']) >= set(PHASES), figures['by_phase_seen']
