"""The five joint controllers in one process, killed at every phase of a step (issue 8).

The matrix of ``test_fault_matrix.py`` for the ``--grouped-controllers`` graph, where one
fault ends every joint's controller at once: the ``controllers`` process killed with SIGKILL
and started again in EXTRACTION, COARSE, FINE and INSERTION, one step per case on one graph.
Each case must hold with a reason, or complete the step by itself (the process came back
within the supervisor's watchdog, or the fault came too late to matter), keep a gripper
attached in every state seen, and complete the step (on ``resume`` after a hold).
Outcomes go to ``fault_matrix_grouped.json`` beside the graph's logs.

About 4 minutes, so it runs with the matrix only:
``python3 scripts/run_tests.py -m fault_matrix tests/fault_matrix``.
"""

import pytest

from fault_graph import TEST_TIMEOUT, FaultGraph, assert_the_bag_holds_the_faults, write_outcomes
from ros_test_support import running_graph

pytestmark = [pytest.mark.integration, pytest.mark.fault_matrix,
              pytest.mark.timeout(TEST_TIMEOUT)]

PHASES = ('EXTRACTION', 'COARSE', 'FINE', 'INSERTION')


@pytest.fixture(scope='module')
def outcomes():
    return []


@pytest.fixture(scope='module')
def graph(tmp_path_factory, outcomes):
    tmp = tmp_path_factory.mktemp('fault_matrix_grouped')
    with running_graph(lambda path, domain: FaultGraph(path, domain, grouped=True),
                       tmp) as running:
        yield running
    # a controllers' process started again within the supervisor's watchdog may be survived
    # without a hold in every phase: the bag must hold the holds there were
    assert_the_bag_holds_the_faults(running, some_hold=False)
    write_outcomes(tmp / 'fault_matrix_grouped.json', outcomes)


@pytest.mark.parametrize('phase', PHASES, ids=[p.lower() for p in PHASES])
def test_the_grouped_controllers_killed_at_a_phase_hold_and_the_step_completes(
        graph, outcomes, phase):
    outcomes.append(graph.fail_in_phase('controllers', phase, ready='controlling a_yaw_joint'))
