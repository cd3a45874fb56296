"""The processes that decide and plan the steps run below the loop's real-time priority.

On the wall clock, once real time is asked for (``timing.realtime_priority`` 50, what
``run_all.py --realtime`` sets; the shipped file asks for none), the supervisor and the
planner ask for ``SCHED_FIFO`` at ``timing.decision_priority`` (40 as shipped, below the
loop's 50): under the default scheduler
the loop's five controllers and plant, at 50, starved them, and a real-time walk waited up to
seconds for its plans. The planner's setpoint stream, which the controllers expect every
period, is part of the loop and runs at the loop's priority. In sim time, or when the loop
itself asks for nothing, they leave the scheduling alone.
"""

import os

import pytest

from ros_test_support import (
    REPO_ROOT, NodeProcess, isolated_domain, realtime_permitted, ros_environment,
    thread_policies)

pytestmark = pytest.mark.integration

INSTALL = REPO_ROOT / 'ros2_ws' / 'install'
EXECUTABLES = {
    'planner': INSTALL / 'walker_planner' / 'lib' / 'walker_planner' / 'planner_node',
    'supervisor': INSTALL / 'walker_supervisor' / 'lib' / 'walker_supervisor' / 'supervisor_node',
}
CASES = {  # real time is opt-in (run_all.py --realtime asks for the loop's 50)
    'wall clock': ('timing.realtime_priority:=50',),
    'sim time': ('use_sim_time:=true', 'timing.realtime_priority:=50'),
    'loop without a priority': (),
}
WAIT = 30.0  # [s] for the node to start and report its scheduling


@pytest.mark.parametrize('case', sorted(CASES))
@pytest.mark.parametrize('name', sorted(EXECUTABLES))
def test_the_deciding_processes_ask_for_their_priority_on_the_wall_clock_only(name, case):
    args = [str(EXECUTABLES[name]), '--ros-args', '-r', '__ns:=/walker']
    for parameter in CASES[case]:
        args += ['-p', parameter]
    asks = case == 'wall clock'
    with isolated_domain() as domain, \
            NodeProcess(args, ros_environment(domain), name) as node:
        assert node.wait_for_output('SCHED_FIFO' if asks else 'default scheduling', WAIT), \
            node.output
        permitted = realtime_permitted()
        if name == 'planner' and asks and permitted:  # the stream thread is moved up last
            assert node.wait_for_output('setpoint stream:', WAIT), node.output
        policies = thread_policies(node.process.pid)
        if asks and permitted:
            # the planner's setpoint stream is part of the control loop: at the loop's 50
            expected = {(os.SCHED_FIFO, 40), (os.SCHED_FIFO, 50)} if name == 'planner' \
                else {(os.SCHED_FIFO, 40)}
            assert policies == expected, (policies, node.output)
            assert 'SCHED_FIFO priority 40 on' in node.output
            if name == 'planner':
                assert 'setpoint stream: SCHED_FIFO priority 50 on thread' in node.output
        else:
            assert policies == {(os.SCHED_OTHER, 0)}, (policies, node.output)
            if asks:
                assert 'SCHED_FIFO priority 40 refused' in node.output, node.output
