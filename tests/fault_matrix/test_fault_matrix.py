"""Every node failing at every phase of a step, over real DDS in sim time (issue 8).

The fault suite (``tests/integration/test_faults.py``) kills each node once, at one phase; this
matrix crosses them all: a controller, the planner and the supervisor killed with SIGKILL, and
the plant frozen with SIGSTOP (killing the plant means the hardware is gone: there is nothing to
resume), each in EXTRACTION, COARSE, FINE and INSERTION, one step per case on one graph. A
different controller dies at each phase, so that with the suite's vertex controller every joint's
controller is killed once.

Every case checks what the suite checks: the fault is reported or survived (safe hold with a
reason, or the step completed where the fault came too late to matter), at least one gripper is
attached in every state seen (the module, with the bag), and ``resume`` completes the step
without restarting the graph. Each case's outcome (phase, reason, resumes needed, wall time) is
written to ``fault_matrix.json`` beside the graph's logs and printed as a table.

About 20 minutes on a 2-core machine, so it is not part of the default test run:
``python3 scripts/run_tests.py -m fault_matrix tests/fault_matrix``.
"""

import pytest

from fault_graph import TEST_TIMEOUT, FaultGraph, assert_the_bag_holds_the_faults, write_outcomes
from ros_test_support import running_graph

pytestmark = [pytest.mark.integration, pytest.mark.fault_matrix,
              pytest.mark.timeout(TEST_TIMEOUT)]

PHASES = ('EXTRACTION', 'COARSE', 'FINE', 'INSERTION')
#: The controller killed at each phase (the suite kills the vertex one in COARSE).
CONTROLLERS = {'EXTRACTION': 'controller_a_yaw', 'COARSE': 'controller_a_pitch',
               'FINE': 'controller_b_pitch', 'INSERTION': 'controller_b_yaw'}
READY = {'planner': 'planner ready', 'supervisor': None}
FREEZE = 'plant'
CASES = [(node, phase) for phase in PHASES
         for node in ('controller', 'planner', 'supervisor', FREEZE)]


@pytest.fixture(scope='module')
def outcomes():
    return []


@pytest.fixture(scope='module')
def graph(tmp_path_factory, outcomes):
    tmp = tmp_path_factory.mktemp('fault_matrix')
    with running_graph(FaultGraph, tmp) as running:
        yield running
    assert_the_bag_holds_the_faults(running)
    write_outcomes(tmp / 'fault_matrix.json', outcomes)


@pytest.mark.parametrize('node, phase', CASES, ids=[f'{n}-{p.lower()}' for n, p in CASES])
def test_a_node_failing_at_a_phase_is_held_or_survived_and_the_step_completes(
        graph, outcomes, node, phase):
    name = CONTROLLERS[phase] if node == 'controller' else node
    ready = READY.get(node, f'controlling {name.removeprefix("controller_")}_joint')
    outcomes.append(graph.fail_in_phase(name, phase, freeze=node == FREEZE, ready=ready))
