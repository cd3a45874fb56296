"""The five joint controllers in one process, killed in the middle of a step.

With ``--grouped-controllers`` one fault ends every joint's controller at once. The graph
(recorder, plant, the ``controllers`` process, planner, supervisor; sim time, each a process,
in a ROS domain of its own with discovery on loopback) must then hold with the base gripper
screwed in, refuse to let it go or to resume while the controllers are away, and complete the
step once they are back; a gripper attached throughout (checked over every gripper state when
the graph is shut down).
"""

import time

import pytest

from fault_graph import FAULT_TIMEOUT, TEST_TIMEOUT, TIMEOUT, FaultGraph
from ros_test_support import running_graph

pytestmark = [pytest.mark.integration, pytest.mark.timeout(TEST_TIMEOUT)]


@pytest.fixture(scope='module')
def graph(tmp_path_factory):
    with running_graph(lambda tmp, domain: FaultGraph(tmp, domain, grouped=True),
                       tmp_path_factory.mktemp('grouped_faults')) as running:
        yield running


def test_the_grouped_controllers_killed_in_coarse_motion_hold_then_the_step_completes(graph):
    from action_msgs.msg import GoalStatus
    from walker_msgs.msg import StepPhase
    from walker_msgs.srv import GripperCommand

    step = graph.one_step()
    started = time.monotonic()
    handle = graph.start_walk(step.to_node)
    graph.wait_phase(StepPhase.COARSE, TIMEOUT, started)
    since = time.monotonic()
    graph.kill('controllers')
    held = graph.wait_phase(StepPhase.SAFE_HOLD, FAULT_TIMEOUT, since)
    wrapped = graph.result(handle)
    assert wrapped.status == GoalStatus.STATUS_ABORTED and not wrapped.result.success
    assert held.to_node == step.to_node
    graph.wait_until(lambda: '_joint' in graph.phase.reason, FAULT_TIMEOUT,
                     lambda: f'the hold reason names the silent controllers: '
                             f'{graph.phase.reason!r}')
    # the free gripper's step is held; the base cannot be released, nothing resumes
    assert graph.attached_nodes() == {step.base_gripper: step.base_node}
    response = graph.gripper_command(step.base_gripper, GripperCommand.Request.UNSCREW)
    assert not response.success and 'interlock' in response.message
    answer = graph.client.call_trigger('resume', timeout=30.0)
    assert not answer.success
    graph.restart('controllers', 'controlling a_yaw_joint')
    refused = graph.streams_refused_for_moved_joints()
    graph.resume_and_complete(step)
    # tracking again, the joints are held where they are, not sent after the setpoints of the
    # stream the fault cut short: the way back starts from where the resume measured them
    assert graph.streams_refused_for_moved_joints() == refused, graph.log_tails('supervisor')
    assert set(graph.attached_nodes()) == {'a', 'b'}
