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

import json
import os
import signal
import time

import pytest

from fault_graph import FAULT_TIMEOUT, TIMEOUT, FaultGraph, assert_the_bag_holds_the_faults
from ros_test_support import running_graph

pytestmark = [pytest.mark.integration, pytest.mark.fault_matrix]

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
    (tmp / 'fault_matrix.json').write_text(json.dumps(outcomes, indent=1))
    print('\nnode        phase       outcome     resumes  wall [s]  reason')
    for row in outcomes:
        print(f'{row["node"]:<11} {row["phase"]:<11} {row["outcome"]:<11} '
              f'{row["resumes"]:>7}  {row["wall_s"]:>8.1f}  {row["reason"][:70]}')


@pytest.mark.parametrize('node, phase', CASES, ids=[f'{n}-{p.lower()}' for n, p in CASES])
def test_a_node_failing_at_a_phase_is_held_or_survived_and_the_step_completes(
        graph, outcomes, node, phase):
    from walker_msgs.msg import StepPhase

    step = graph.one_step()
    started = time.monotonic()
    graph.start_walk(step.to_node)
    graph.wait_phase(getattr(StepPhase, phase), TIMEOUT, started)
    since = time.monotonic()
    name = CONTROLLERS[phase] if node == 'controller' else node
    if node == FREEZE:
        pid = graph.processes['plant'].popen.pid
        os.killpg(pid, signal.SIGSTOP)
        try:
            graph.wait_phase(StepPhase.SAFE_HOLD, FAULT_TIMEOUT, since)
        finally:
            os.killpg(pid, signal.SIGCONT)
    else:
        graph.kill(name)
        ready = READY.get(node, f'controlling {name.removeprefix("controller_")}_joint')
        graph.restart(name, ready)
    # held (with a reason), or the step got as far as screwing in and ended by itself
    graph.wait_phase_in((StepPhase.SAFE_HOLD, StepPhase.IDLE), FAULT_TIMEOUT * 2, since)
    first = graph.last_phase
    assert first.phase == StepPhase.IDLE or first.reason, 'a safe hold without a reason'
    resumes = 0
    if first.phase == StepPhase.SAFE_HOLD:
        resumes = graph.resume_and_complete(step)
    else:
        graph.complete_step(step, since)
    outcomes.append({'node': name, 'phase': phase,
                     'outcome': 'held' if first.phase == StepPhase.SAFE_HOLD else 'completed',
                     'reason': first.reason, 'resumes': resumes,
                     'wall_s': round(time.monotonic() - since, 1)})
    assert set(graph.attached_nodes()) == {'a', 'b'}
