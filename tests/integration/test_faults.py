"""Faults injected into the running walker, over real DDS in sim time (issue 8).

One graph serves the module: the recorder, the plant, five controllers, the planner and the
supervisor, each a separate process. The tests kill nodes with SIGKILL in the middle of a step,
freeze the plant with SIGSTOP, and send bad inputs over DDS. Every case checks that the fault is
reported (the supervisor's phase reason, ``/diagnostics``, or the refusal itself), that the walker
ends in a safe hold or a completed step, and that an operator can resume without restarting the
graph. Whatever the tests do, the module checks that at least one gripper was attached in every
``gripper_states`` message seen, and that the bag holds every safe hold with its reason and the
gripper states up to the end of the run.

The tests run in file order and share the walker's stance: each fault case takes one step.
"""

import math
import os
import signal
import time

import pytest

from walker_bringup.graph_client import GoalRejectedError

from fault_graph import (
    FAULT_TIMEOUT, STILL, TEST_TIMEOUT, TIMEOUT, FaultGraph, assert_the_bag_holds_the_faults)
from ros_test_support import running_graph

pytestmark = [pytest.mark.integration, pytest.mark.timeout(TEST_TIMEOUT)]


@pytest.fixture(scope='module')
def graph(tmp_path_factory):
    # every node must stop cleanly: the ones killed were replaced by processes that do
    with running_graph(FaultGraph, tmp_path_factory.mktemp('faults')) as running:
        yield running
    assert_the_bag_holds_the_faults(running)


def _assert_still(before, after) -> None:
    moved = max(abs(a - b) for a, b in zip(before, after, strict=True))
    assert moved < STILL, f'a joint moved by {moved:.2e} rad'


# ---------------------------------------------------------------------- bad inputs, idle
def test_bad_parameter_updates_are_refused_and_nothing_moves(graph):
    from rcl_interfaces.srv import GetParameters, SetParameters
    from rclpy.parameter import Parameter

    before = graph.joints()
    cases = [  # (node, parameter, bad value, words of the reason)
        ('controller_vertex', 'control.fine.bandwidth', [5.0, 5.0, 5.0, 8.0, 8.0], 'unstable'),
        ('controller_vertex', 'control.state_timeout', -1.0, 'state_timeout'),
        ('supervisor', 'supervisor.watchdog_timeout', 1000.0, 'watchdog_timeout'),
        ('supervisor', 'supervisor.insertion_alignment', 0.1, 'insertion_alignment'),
        # inside its own range and the supervisor section's rules, wider than the gripper's
        ('supervisor', 'supervisor.descent_region', 0.003, 'insertion_position_tolerance'),
        ('planner', 'gripper.insertion_position_tolerance', 0.5, 'read-only'),
    ]
    for node, name, value, words in cases:
        values = graph.parameters(node, 'get_parameters', GetParameters.Request(names=[name]))
        request = SetParameters.Request(parameters=[Parameter(name, value=value)
                                                    .to_parameter_msg()])
        result = graph.parameters(node, 'set_parameters', request).results[0]
        assert not result.successful, (node, name)
        assert words in result.reason, (node, name, result.reason)
        after = graph.parameters(node, 'get_parameters', GetParameters.Request(names=[name]))
        assert after.values == values.values, f'{node} {name} changed'
    # a value of the wrong type
    request = SetParameters.Request(parameters=[Parameter(
        'supervisor.settle_time', value='long').to_parameter_msg()])
    assert not graph.parameters('supervisor', 'set_parameters', request).results[0].successful
    _assert_still(before, graph.joints())


def test_commands_in_the_wrong_phase_and_malformed_commands_are_refused(graph):
    from walker_msgs.msg import StepPhase
    from walker_msgs.srv import GripperCommand

    before = graph.joints()
    answer = graph.client.call_trigger('resume', timeout=30.0)
    assert not answer.success and 'not in SAFE_HOLD' in answer.message
    for gripper, command, words in [('c', GripperCommand.Request.UNSCREW, 'gripper'),
                                    ('a', 7, 'unknown gripper command'),
                                    ('a', GripperCommand.Request.SCREW_IN, 'ATTACHED')]:
        response = graph.gripper_command(gripper, command)
        assert not response.success and words in response.message, response.message
    # an operator's hold: walks are refused until resume
    since = time.monotonic()
    assert graph.client.call_trigger('hold', timeout=30.0).success
    held = graph.wait_phase(StepPhase.SAFE_HOLD, FAULT_TIMEOUT, since)
    assert 'operator' in held.reason
    with pytest.raises(GoalRejectedError, match='call resume first'):
        graph.client.walk_to(graph.one_step().to_node, 60.0)
    since = time.monotonic()
    assert graph.client.call_trigger('resume', timeout=30.0).success
    graph.wait_phase(StepPhase.IDLE, FAULT_TIMEOUT, since)
    _assert_still(before, graph.joints())
    assert set(graph.attached_nodes()) == {'a', 'b'}


# ---------------------------------------------------------------------- a node killed mid-step
def test_a_controller_killed_in_coarse_motion_holds_then_rejoins_and_the_step_completes(graph):
    from action_msgs.msg import GoalStatus
    from walker_msgs.msg import StepPhase
    from walker_msgs.srv import GripperCommand

    step = graph.one_step()
    started = time.monotonic()
    handle = graph.start_walk(step.to_node)
    graph.wait_phase(StepPhase.EXTRACTION, TIMEOUT, started)
    # a second goal while a walk runs is rejected at goal time, the walk goes on
    with pytest.raises(GoalRejectedError, match='is running'):
        graph.client.walk_to(step.to_node, 60.0)
    graph.wait_phase(StepPhase.COARSE, TIMEOUT, started)
    since = time.monotonic()
    graph.kill('controller_vertex')
    held = graph.wait_phase(StepPhase.SAFE_HOLD, FAULT_TIMEOUT, since)
    wrapped = graph.result(handle)
    assert wrapped.status == GoalStatus.STATUS_ABORTED and not wrapped.result.success
    graph.wait_until(lambda: 'vertex_joint' in graph.phase.reason, FAULT_TIMEOUT,
                     'the hold reason names the dead controller')
    assert graph.phase.phase == StepPhase.SAFE_HOLD and held.to_node == step.to_node
    # the free gripper's step is held; the base cannot be released, nothing resumes
    assert graph.attached_nodes() == {step.base_gripper: step.base_node}
    response = graph.gripper_command(step.base_gripper, GripperCommand.Request.UNSCREW)
    assert not response.success and 'interlock' in response.message
    answer = graph.client.call_trigger('resume', timeout=30.0)
    assert not answer.success and 'vertex_joint' in answer.message
    graph.restart('controller_vertex', 'controlling vertex_joint')
    refused = graph.streams_refused_for_moved_joints()
    graph.resume_and_complete(step)
    # tracking again, the joints are held where they are, not sent after the setpoints of the
    # stream the fault cut short: the way back starts from where the resume measured them
    assert graph.streams_refused_for_moved_joints() == refused, graph.log_tails('supervisor')


def test_the_planner_killed_in_coarse_motion_holds_then_rejoins_and_the_step_completes(graph):
    """A planner that dies mid-motion: the walker holds, never lets go, and resume completes.

    Killed in the sweep, it leaves the controllers its whole trajectory: they execute it to its
    end without the planner and hold there; the supervisor, whose motion never ends, holds once
    ``supervisor.motion_end_margin`` has passed since the motion's planned end, naming the
    planner (a setpoint stream: the controllers hold on stale setpoints). Also: the walk after
    a step completed by resume takes a step of its own.
    """
    from action_msgs.msg import GoalStatus
    from walker_msgs.msg import StepPhase

    step = graph.one_step()
    started = time.monotonic()
    handle = graph.start_walk(step.to_node)
    coarse = graph.wait_phase(StepPhase.COARSE, TIMEOUT, started)
    assert (coarse.from_node, coarse.to_node) == (step.from_node, step.to_node)
    since = time.monotonic()
    graph.kill('planner')
    held = graph.wait_phase(StepPhase.SAFE_HOLD, FAULT_TIMEOUT * 2, since)
    # a whole trajectory: its end never reported; a stream: the controllers' setpoints stale
    expected = ['the planner did not report the end of the'] if graph.whole_trajectories \
        else ['stale', 'planner']
    assert any(words in held.reason for words in expected), \
        f'{held.reason}\n{graph.log_tails("plant", "controller_a_yaw", "supervisor")}'
    wrapped = graph.result(handle)
    assert wrapped.status == GoalStatus.STATUS_ABORTED
    assert graph.attached_nodes() == {step.base_gripper: step.base_node}
    graph.restart('planner', 'planner ready')
    graph.resume_and_complete(step)


def test_the_supervisor_killed_in_insertion_is_restarted_and_completes_the_step(graph):
    from walker_msgs.msg import StepPhase

    step = graph.one_step()
    started = time.monotonic()
    graph.start_walk(step.to_node)
    graph.wait_phase(StepPhase.INSERTION, TIMEOUT, started)
    graph.kill('supervisor')
    since = time.monotonic()
    graph.restart('supervisor')

    def taken_up() -> bool:
        return any(t >= since and m.phase == StepPhase.SAFE_HOLD
                   and 'restarted in the middle of the step' in m.reason
                   for t, m in graph.phases)

    def screwed_in() -> bool:  # the kill came as the screw-in had started: nothing to take up
        return graph.attached_nodes().get(step.moving_gripper) == step.to_node

    graph.wait_until(lambda: taken_up() or screwed_in(), FAULT_TIMEOUT * 2,
                     'the restarted supervisor takes the step up')
    if taken_up():
        graph.resume_and_complete(step)
    else:
        graph.wait_until(lambda: graph.phase.phase == StepPhase.IDLE, FAULT_TIMEOUT,
                         'the restarted supervisor idle')
        assert set(graph.attached_nodes()) == {'a', 'b'}


# ---------------------------------------------------------------------- a jammed insertion
def test_a_jammed_insertion_is_retried_a_bounded_number_of_times_then_held_and_resumed(graph):
    """A fouled thread jams every try: the step ends in safe hold; resume completes it.

    The plant's thread is fouled (``sim.jam_screw_ins``) for as many screw-ins as the
    supervisor tries; the base holds throughout; with the thread clear again, resume completes
    the step.
    """
    from action_msgs.msg import GoalStatus
    from rcl_interfaces.srv import GetParameters, SetParameters
    from rclpy.parameter import Parameter
    from walker_msgs.msg import GripperState, StepPhase

    def plant_jams() -> int:
        answer = graph.parameters('plant', 'get_parameters',
                                  GetParameters.Request(names=['sim.jam_screw_ins']))
        return answer.values[0].integer_value

    attempts = graph.parameters('supervisor', 'get_parameters', GetParameters.Request(
        names=['supervisor.max_insertion_attempts'])).values[0].integer_value
    assert attempts >= 2, 'the bounded retry needs at least two attempts to show'
    # the retry in place, without the search on a jam (the search has its own tests)
    radius = graph.parameters('supervisor', 'get_parameters', GetParameters.Request(
        names=['supervisor.search_radius'])).values[0].double_value

    def search_radius(value: float) -> None:
        request = SetParameters.Request(parameters=[
            Parameter('supervisor.search_radius', value=value).to_parameter_msg()])
        assert graph.parameters('supervisor', 'set_parameters', request).results[0].successful

    search_radius(0.0)
    injected = SetParameters.Request(parameters=[
        Parameter('sim.jam_screw_ins', value=attempts).to_parameter_msg()])
    assert graph.parameters('plant', 'set_parameters', injected).results[0].successful
    assert plant_jams() == attempts
    step = graph.one_step()
    reports = len(graph.step_reports)
    started = time.monotonic()
    handle = graph.start_walk(step.to_node)
    held = graph.wait_step_end(started)
    assert held.phase == StepPhase.SAFE_HOLD, 'the step completed: a screw-in did not jam'
    assert f'insertion jammed {attempts} times' in held.reason, held.reason
    assert 'fouled' in held.reason, held.reason
    wrapped = graph.result(handle)
    assert wrapped.status == GoalStatus.STATUS_ABORTED and not wrapped.result.success
    # the report travels on its own topic: it may come after the phase and the result
    graph.wait_until(lambda: len(graph.step_reports) > reports, FAULT_TIMEOUT,
                     'the step report')
    report = graph.step_reports[-1]
    assert not report.success and report.insertion_attempts == attempts, report
    assert plant_jams() == 0, 'each jam counts the injected fault down'
    # the base holds the walker; the jammed gripper is free, never screwed in
    assert graph.attached_nodes() == {step.base_gripper: step.base_node}
    moving = [g for message in graph.gripper_states for g in message.grippers
              if g.name == step.moving_gripper]
    assert any(g.state == GripperState.JAMMED and g.node == step.to_node for g in moving)
    graph.resume_and_complete(step)
    search_radius(radius)


# ---------------------------------------------------------------------- a lossy link
def _link_counts(graph) -> tuple[int, int]:
    """Return the messages the lossy link has received and dropped, by its newest report."""
    import re

    found = re.findall(r'(\d+) received, (\d+) dropped',
                       graph.processes['lossy_link'].log_path.read_text(errors='replace'))
    return tuple(int(n) for n in found[-1]) if found else (0, 0)


def test_a_lossy_late_link_still_walks_and_a_cut_one_holds_or_completes_safely(graph):
    """Late messages cost accuracy, not safety; a link cut mid-step never lets the walker go.

    The vertex controller reads the planner's motions through the lossy link: its whole
    trajectories (the shipped planner), or its setpoint stream. With every message 20-30 ms
    late (and, for a stream, a third of them dropped), a step completes: a late trajectory is
    sampled at its own time. Cut (every message dropped) from the coarse motion on, the vertex
    joint misses what the planner sends next: the walker holds with a reason, the base gripper
    attached (a cut stream: the controller's setpoint watchdog holds the joint, and the hold
    names it), or completes the step in its target node; the link restored, resume completes a
    held step.
    """
    from action_msgs.msg import GoalStatus
    from walker_msgs.msg import StepPhase

    def link(**settings) -> None:
        from rcl_interfaces.srv import SetParameters
        from rclpy.parameter import Parameter

        request = SetParameters.Request(parameters=[
            Parameter(name, value=value).to_parameter_msg() for name, value in settings.items()])
        results = graph.parameters('lossy_link', 'set_parameters', request).results
        assert all(r.successful for r in results), [r.reason for r in results]

    # a whole trajectory dropped is a motion the joint never makes: only a stream may lose some
    drops = 0.0 if graph.whole_trajectories else 0.3
    link(drop_probability=drops, delay=0.02, jitter=0.01)
    received = _link_counts(graph)[0]
    try:
        step = graph.one_step()
        status, result = graph.client.walk_to(step.to_node, TIMEOUT)
        assert status == GoalStatus.STATUS_SUCCEEDED and result.success, result.message
    finally:
        link(drop_probability=0.0, delay=0.0, jitter=0.0)
    assert graph.attached_nodes().get(step.moving_gripper) == step.to_node
    graph.wait_until(lambda: _link_counts(graph)[0] > received, FAULT_TIMEOUT,
                     'the link reports the messages of the step')
    if drops:
        assert _link_counts(graph)[1] > 0, 'the link dropped nothing'

    # Cut in coarse motion, the longest motion of a step: a stream cut in fine motion may land
    # in the last half second of the step, shorter than the watchdog's timeout
    step = graph.one_step()
    started = time.monotonic()
    handle = graph.start_walk(step.to_node)
    graph.wait_phase(StepPhase.COARSE, TIMEOUT, started)
    since = time.monotonic()
    dropped = _link_counts(graph)[1]
    link(drop_probability=1.0)
    try:
        graph.wait_phase_in((StepPhase.SAFE_HOLD, StepPhase.IDLE), TIMEOUT, since,
                            tails=('supervisor', 'lossy_link'))
        held = graph.last_phase
        if not graph.whole_trajectories:
            assert held.phase == StepPhase.SAFE_HOLD, 'the step completed without its stream'
            graph.wait_until(lambda: 'vertex_joint' in graph.phase.reason, FAULT_TIMEOUT,
                             'the hold reason names the joint whose setpoints stopped')
        if held.phase == StepPhase.SAFE_HOLD:
            assert held.reason, 'a safe hold without a reason'
            assert graph.attached_nodes() == {step.base_gripper: step.base_node}, held.reason
            wrapped = graph.result(handle)
            assert wrapped.status == GoalStatus.STATUS_ABORTED
        # the planner sent the joint something while the link was cut (not a vacuous cut)
        graph.wait_until(lambda: _link_counts(graph)[1] > dropped, FAULT_TIMEOUT,
                         'the link reports a message dropped')
    finally:
        link(drop_probability=0.0)
    if held.phase == StepPhase.SAFE_HOLD:
        graph.resume_and_complete(step)
    else:
        graph.complete_step(step, since)


# ---------------------------------------------------------------------- a starved planner
def test_a_starved_planner_leaves_the_motion_as_planned(graph):
    """A planner stalled during the sweep leaves the motion as planned.

    The controllers hold the sweep's whole trajectory and sample it: the stalled planner owes
    them nothing. A setpoint stream (``planner.send_whole_trajectories`` false) owes them a
    setpoint every period, and in sim time they wait for it; without the wait, the controllers
    carried old setpoints on and the stream jumped when it came back (a sim-time walk on a busy
    machine once overshot the node by 42 mrad of joint 1 that way).
    """
    from action_msgs.msg import GoalStatus
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from trajectory_msgs.msg import JointTrajectory
    from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
    from walker_msgs.msg import ControllerState, StepPhase
    from walker_planner.conversions import sampled_trajectory

    step = graph.one_step()
    joint_1 = f'{step.base_gripper}_yaw_joint'
    setpoints = []  # (stamp [s], setpoint in force [rad]) of joint 1 in the sweep
    streamed = []  # the trajectories the planner started streaming
    node = graph.client.node
    subscriptions = [
        node.create_subscription(
            ControllerState, f'controllers/{joint_1}/state',
            lambda m: setpoints.append((m.header.stamp.sec + m.header.stamp.nanosec * 1e-9,
                                        m.position_setpoint))
            if m.mode == ControllerState.COARSE else None, 100),
        node.create_subscription(
            JointTrajectory, 'planned_trajectory',
            lambda m: streamed.append(m) if m.header.stamp.sec or m.header.stamp.nanosec
            else None,
            QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.TRANSIENT_LOCAL))]
    try:
        reports = len(graph.step_reports)
        started = time.monotonic()
        handle = graph.start_walk(step.to_node)
        graph.wait_phase(StepPhase.COARSE, TIMEOUT, started)
        planner = graph.processes['planner'].popen.pid
        for _ in range(5):  # starved for 0.15 s five times in the sweep, half the wait each
            time.sleep(0.1)
            os.killpg(planner, signal.SIGSTOP)
            try:
                time.sleep(0.15)
            finally:
                os.killpg(planner, signal.SIGCONT)
        wrapped = graph.result(handle)
    finally:
        for subscription in subscriptions:
            node.destroy_subscription(subscription)
    assert wrapped.status == GoalStatus.STATUS_SUCCEEDED and wrapped.result.success, \
        wrapped.result.message
    graph.wait_until(lambda: len(graph.step_reports) > reports, FAULT_TIMEOUT,
                     'the step report')
    report = graph.step_reports[-1]
    assert report.success and report.insertion_attempts == 1 and report.insertion_error < 1e-3
    # every setpoint joint 1 used in the sweep is the coarse plan's sample at its stamp (the
    # plan interpolated as the planner's stream does it; the lift streams with its start)
    sweep = max(streamed, key=lambda m: len(m.points))
    origin = sweep.header.stamp.sec + sweep.header.stamp.nanosec * 1e-9
    plan = sampled_trajectory(sweep)
    column = list(PHYSICAL_JOINT_NAMES).index(joint_1)
    during = [(t, q) for t, q in setpoints if 0.0 < t - origin < plan.duration]
    assert len(during) > 50, f'{len(during)} controller states of the sweep'
    off = max(abs(q - plan.sample(t - origin).position[column]) for t, q in during)
    # a stream carries the planner's own samples; a whole trajectory is interpolated between
    # its points by the controller (quintic where it has accelerations), a few microradians
    # from the planner's sampling: under one count of an 18-bit encoder (24 urad) either way
    allowed = 1e-5 if graph.whole_trajectories else 1e-6
    assert off < allowed, f'joint 1 used setpoints {off:.3g} rad off its plan'


# ---------------------------------------------------------------------- a silent publisher
def test_a_frozen_plant_is_reported_and_the_walker_resumes_when_it_is_back(graph):
    from walker_msgs.msg import StepPhase

    step = graph.one_step()
    started = time.monotonic()
    graph.start_walk(step.to_node)
    graph.wait_phase(StepPhase.FINE, TIMEOUT, started)
    plant = graph.processes['plant'].popen.pid
    since = time.monotonic()
    os.killpg(plant, signal.SIGSTOP)
    try:
        graph.wait_phase(StepPhase.SAFE_HOLD, FAULT_TIMEOUT, since)
        graph.wait_until(
            lambda: any(t > since and 'plant joint states: silent' in s.message
                        or any('plant joint states' == v.key and 'silent' in v.value
                               for v in s.values)
                        for t, s in graph.diagnostics),
            FAULT_TIMEOUT, 'the diagnostics name the silent plant')
        answer = graph.client.call_trigger('resume', timeout=30.0)
        assert not answer.success and 'plant' in answer.message
        # silent for long, the plant's streams are subscribed anew (a frozen and resumed
        # publisher has been seen unheard by the old subscription): the new one must hear it
        renewed = 'plant joint states: silent for'
        graph.wait_until(lambda: graph.count_in_log('supervisor', renewed) > 0,
                         FAULT_TIMEOUT, 'the supervisor subscribes anew to the silent plant')
    finally:
        os.killpg(plant, signal.SIGCONT)
    graph.resume_and_complete(step)
    assert math.isfinite(sum(graph.joints()))
