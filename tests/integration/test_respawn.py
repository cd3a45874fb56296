"""The supervised bring-up over real DDS: killed nodes are started again, the walk goes on.

A node killed mid-walk is started again and the step resumed; a killed plant comes back where
the robot was.

``run_all.py --serve --sim-time`` runs the graph (each node a process of its own) in a ROS domain
of its own; the test is the operator: it sends a one-step walk, SIGKILLs a joint controller in
coarse motion, sees the node started again and the supervisor holding, resumes until the step
completes; then SIGKILLs the plant at rest and checks that the plant started again reports the
joint angles and the grippers' nodes the killed one had, not its start pose. On Ctrl-C the
summary records each node's deaths and restarts, and nothing is left running. With respawning
off, a killed node ends the graph and the bag names it as the reason of the hold.
"""

import json
import os
import signal
import time

import pytest

from ros_test_support import (
    NodeProcess, assert_always_attached, isolated_domain, processes_with, ros_environment,
    serve_command)

pytestmark = [pytest.mark.integration, pytest.mark.timeout(600)]

TIMEOUT = 180.0  # [s] wall clock, for a loaded shared machine
TARGET = 'n1_2'  # one step from the start


def _wait(client, condition, timeout: float, what) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return
        client.spin_for(0.1)
    raise AssertionError(f'timed out waiting for {what() if callable(what) else what}')


def _kill(namespace: str, node: str) -> int:
    pids = processes_with(f'__node:={node}\x00-r\x00__ns:={namespace}\x00')
    assert len(pids) == 1, pids
    os.kill(pids[0], signal.SIGKILL)
    return pids[0]


def test_killed_nodes_are_started_again_and_the_walk_resumes_where_the_robot_is(tmp_path):
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from walker_msgs.action import WalkTo
    from walker_msgs.msg import GripperState, GripperStates, StepPhase

    from walker_bringup.graph_client import GraphClient, init_context

    namespace = f'/walker_respawn_{os.getpid()}'
    out = tmp_path / 'run'
    with isolated_domain() as domain:
        args = serve_command(namespace, out, '--no-record', '--respawn-delay', '0.5')
        with NodeProcess(args, ros_environment(domain), 'run_all') as run:
            assert run.wait_for_output('[walker] serving in namespace', TIMEOUT), run.output
            context = init_context(domain)
            client = GraphClient(namespace, context)
            try:
                phases, grippers, joints = [], [], {}
                latched = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE,
                                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
                client.node.create_subscription(StepPhase, 'phase', phases.append, latched)
                client.node.create_subscription(GripperStates, 'gripper_states',
                                                grippers.append, latched)
                client.node.create_subscription(
                    JointState, 'joint_states',
                    lambda m: joints.update(zip(m.name, m.position, strict=True)),
                    QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT))
                _wait(client, lambda: phases and phases[-1].phase == StepPhase.IDLE, TIMEOUT,
                      'the walker idle')
                # a controller killed in coarse motion: started again, held, resumed
                _wait(client, client.walk_client.server_is_ready, TIMEOUT, 'the walk_to server')
                handle = client._wait(
                    client.walk_client.send_goal_async(WalkTo.Goal(target_node=TARGET)), 30.0,
                    None, 'the walk goal')
                assert handle.accepted
                _wait(client, lambda: phases[-1].phase == StepPhase.COARSE, TIMEOUT,
                      'coarse motion')
                _kill(namespace, 'controller_vertex')
                assert run.wait_for_output('node controller_vertex started again', TIMEOUT), \
                    run.output
                assert 'node controller_vertex died (killed by SIGKILL, death 1)' in run.output
                _wait(client, lambda: phases[-1].phase == StepPhase.SAFE_HOLD, TIMEOUT,
                      lambda: f'the hold (phase {phases[-1]})')
                answers = []

                def resumed() -> bool:
                    answers.append(client.call_trigger('resume', timeout=30.0))
                    return answers[-1].success

                _wait(client, resumed, TIMEOUT, lambda: f'resume ({answers[-1].message})')
                _wait(client, lambda: phases[-1].phase == StepPhase.IDLE, TIMEOUT,
                      lambda: f'the step completed (phase {phases[-1]})')

                def attached() -> dict:
                    return {g.name: g.node for g in grippers[-1].grippers
                            if g.state == GripperState.ATTACHED}

                _wait(client, lambda: TARGET in attached().values(), 30.0,
                      lambda: f'a gripper screwed into {TARGET} ({attached()})')
                assert run.process.poll() is None, run.output
                # the plant killed at rest comes back where the robot is
                client.spin_for(1.0)
                before_joints, before_grippers = dict(joints), attached()
                killed_at = len(grippers)
                _kill(namespace, 'plant')
                assert run.wait_for_output('node plant started again', TIMEOUT), run.output
                _wait(client, lambda: len(grippers) > killed_at + 2, TIMEOUT,
                      'the gripper states of the plant started again')
                joints.clear()
                _wait(client, lambda: len(joints) == 5, TIMEOUT, 'joint states again')
                assert attached() == before_grippers
                for name, angle in before_joints.items():
                    assert joints[name] == pytest.approx(angle, abs=2e-3), name  # [rad]
                assert_always_attached(grippers)
            finally:
                client.close()
                context.try_shutdown()
            assert run.stop(timeout=60.0) == 0, run.output
    summary = json.loads((out / 'summary.json').read_text())
    processes = summary['processes']
    assert processes['controller_vertex'] == {'deaths': 1, 'restarts': 1,
                                              'exit_codes': [-signal.SIGKILL], 'gave_up': ''}
    assert processes['plant']['restarts'] == 1 and processes['plant']['deaths'] == 1
    # the step report is the interrupted step's (the resume completed it, checked above)
    assert [s['to_node'] for s in summary['steps']] == [TARGET], summary
    assert processes_with(namespace) == [], run.output


def test_a_node_given_up_on_is_named_in_the_hold_and_in_the_bag(tmp_path):
    """With respawning off, a killed controller ends the graph; the hold and the bag say why.

    The bring-up reports the death on ``/diagnostics`` and asks the supervisor to hold over
    ``hold`` (``std_srvs/Trigger``, no reason); the hold's reason names the dead node, not an
    operator, in the phase history the bag keeps.
    """
    from walker_msgs.msg import StepPhase

    from walker_bag.core.bag_reader import read_messages
    from walker_bringup.graph_client import GraphClient, init_context

    namespace = f'/walker_given_up_{os.getpid()}'
    out = tmp_path / 'run'
    with isolated_domain() as domain:
        args = serve_command(namespace, out, '--respawn-limit', '0')
        with NodeProcess(args, ros_environment(domain), 'run_all') as run:
            assert run.wait_for_output('[walker] serving in namespace', TIMEOUT), run.output
            context = init_context(domain)
            client = GraphClient(namespace, context)
            try:
                _wait(client, lambda: client.phase is not None
                      and client.phase.phase == StepPhase.IDLE, TIMEOUT, 'the walker idle')
            finally:
                client.close()
                context.try_shutdown()
            _kill(namespace, 'controller_vertex')
            assert run.process.wait(timeout=TIMEOUT) == 5, run.output
            output = run.output
    assert 'node controller_vertex died (killed by SIGKILL) and is not started again' in output, \
        output
    messages = read_messages(out / 'bag', [f'{namespace}/phase', '/diagnostics'])
    holds = [m.message.reason for m in messages
             if m.topic.endswith('/phase') and m.message.phase == StepPhase.SAFE_HOLD]
    dead = f'{namespace}/controller_vertex'
    assert holds and all(dead in r and 'operator' not in r for r in holds), holds
    deaths = [s for m in messages if m.topic == '/diagnostics' for s in m.message.status
              if s.name == f'{dead} (process)' and s.level == 2]
    assert deaths and 'died' in deaths[0].message, deaths
    assert processes_with(namespace) == [], output
