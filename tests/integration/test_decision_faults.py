"""Faults in sim time with the plant waiting for the supervisor's decisions.

With ``sim.wait_for_decisions`` (``run_all.py --composed-loop`` in sim time) the plant steps
no further than the supervisor has decided, and the supervisor holds that time while a request
of its own is unanswered: the motion the answer starts then begins at the same simulated time
however long the answer takes. A request that is never answered must not hold it for good.
The graph (recorder, plant, the grouped controllers, planner, supervisor; each a process, in a
ROS domain of its own with discovery on loopback) keeps a gripper attached throughout (checked
over every gripper state when the graph is shut down).
"""

import time

import pytest

from fault_graph import FAULT_TIMEOUT, TEST_TIMEOUT, FaultGraph, assert_the_bag_holds_the_faults
from ros_test_support import running_graph

pytestmark = [pytest.mark.integration, pytest.mark.timeout(TEST_TIMEOUT)]

# [s] wall time for a SIGKILLed process's participant to leave the graph (its lease)
PARTICIPANT_GONE = 60.0


@pytest.fixture(scope='module')
def graph(tmp_path_factory):
    with running_graph(
            lambda tmp, domain: FaultGraph(tmp, domain, grouped=True,
                                           parameters=(('sim.wait_for_decisions', 'true'),)),
            tmp_path_factory.mktemp('decision_faults')) as running:
        yield running
    assert_the_bag_holds_the_faults(running)


def test_a_step_started_with_the_planner_gone_holds_and_the_simulation_runs_on(graph):
    """The step's plans wait for a planner that is not there, then give up on it.

    A request waiting for its server to be discovered held the simulated clock, and the
    supervisor checked the wait's deadline only on its ticks, which run on that clock: the
    whole graph stood still for good (the plant silent, the walker in safe hold and no resume
    possible). Now such a request does not hold the clock, it is given up on within its
    wall-clock deadline, the walker holds
    with its base screwed in, the simulation runs on, and once the planner is back a resume
    completes the step. The silence of the plant's joint states while the supervisor holds the
    clock for its own request is no fault: taken for one, it made every resume fail while the
    restarted planner was still being discovered.
    """
    from action_msgs.msg import GoalStatus
    from sensor_msgs.msg import JointState
    from rclpy.qos import qos_profile_sensor_data
    from walker_msgs.msg import StepPhase

    stamps = []  # [s] the plant's joint-state stamps (simulated time)
    node = graph.client.node
    subscription = node.create_subscription(
        JointState, 'joint_states',
        lambda m: stamps.append(m.header.stamp.sec + m.header.stamp.nanosec * 1e-9),
        qos_profile_sensor_data)
    try:
        step = graph.one_step()
        graph.kill('planner')
        graph.wait_until(lambda: not graph.client.plan_client.service_is_ready(),
                         PARTICIPANT_GONE, 'the killed planner gone from the graph')
        since = time.monotonic()
        handle = graph.start_walk(step.to_node)
        held = graph.wait_phase(StepPhase.SAFE_HOLD, FAULT_TIMEOUT, since)
        wrapped = graph.result(handle, FAULT_TIMEOUT)
        assert wrapped.status == GoalStatus.STATUS_ABORTED, wrapped.result.message
        assert graph.attached_nodes() == {step.base_gripper: step.base_node}, held.reason
        # the simulated clock runs on: the plant steps again (it stood still for good before)
        held_at = stamps[-1]
        graph.wait_until(lambda: stamps[-1] > held_at + 1.0, FAULT_TIMEOUT,
                         lambda: f'the plant stepping again after t = {held_at:.3f} s '
                                 f'({graph.log_tails("supervisor", "plant")})')
    finally:
        node.destroy_subscription(subscription)
    graph.restart('planner', 'planner ready')
    # the restarted planner is heard: it answers a call of its own, and writes where each of
    # its threads stands on SIGUSR1 and runs on
    answered, report = graph.probe('planner', 'stop_trajectory')
    assert answered, report
    graph.wait_until(lambda: graph.count_in_log('planner', 'most recent call first') > 0,
                     FAULT_TIMEOUT,
                     'the thread stacks of the restarted planner in its log')
    graph.resume_and_complete(step)  # the moving gripper screwed in at the step's target
