"""``run_all.py --composed`` and ``--grouped-controllers``: up, walking, killed, nothing left."""

import json
import os
import signal
import subprocess
import sys
import time

import pytest

from ros_test_support import (
    REPO_ROOT, NodeProcess, isolated_domain, processes_with, ros_environment, serve_command)

pytestmark = pytest.mark.integration


def test_run_all_composed_brings_the_graph_up_in_one_process(tmp_path):
    namespace = f'/walker_composed_check_{os.getpid()}'
    with isolated_domain() as domain:
        args = [sys.executable, str(REPO_ROOT / 'scripts' / 'run_all.py'), '--sim-time',
                '--composed', '--namespace', namespace, '--out', str(tmp_path / 'run'),
                '--no-record', '--no-walk']
        run = subprocess.run(args, env=ros_environment(domain), stdout=subprocess.PIPE,
                             stderr=subprocess.STDOUT, text=True, cwd=REPO_ROOT, timeout=180)
    text = run.stdout
    assert run.returncode == 0, text
    assert 'in 1 composed process' in text
    assert 'graph ready' in text
    assert 'all processes stopped (graph: ' in text
    assert processes_with(namespace) == [], text


def walk_one_step(tmp_path, name, option):
    """Run ``run_all.py --sim-time <option>`` to n1_2, recorded; return its output and files.

    Asserts what every arrangement must give: exit 0, the step reached and screwed in within
    1 mm, no lock-step timeout, and no process left behind.
    """
    namespace = f'/walker_{name}_check_{os.getpid()}'
    out = tmp_path / 'run'
    with isolated_domain() as domain:
        args = [sys.executable, str(REPO_ROOT / 'scripts' / 'run_all.py'), '--sim-time', option,
                '--namespace', namespace, '--out', str(out), '--target', 'n1_2', '--no-report']
        run = subprocess.run(args, env=ros_environment(domain), stdout=subprocess.PIPE,
                             stderr=subprocess.STDOUT, text=True, cwd=REPO_ROOT, timeout=300)
    text = run.stdout
    assert run.returncode == 0, text
    summary = json.loads((out / 'summary.json').read_text())
    assert summary['reached'] and summary['path'] == ['n1_2'], summary
    assert summary['loop']['lockstep_timeouts'] == 0, summary['loop']
    step, = summary['steps']
    assert step['success'] and step['insertion_error'] < 1e-3, step  # [m]
    assert processes_with(namespace) == [], text
    return text, out, summary


def test_run_all_walks_with_the_joint_controllers_grouped_in_one_process(tmp_path):
    """One step with one controller process for the five joints, recorded, in sim time."""
    text, _, _ = walk_one_step(tmp_path, 'grouped', '--grouped-controllers')
    assert 'recorder, plant, controllers, planner, supervisor' in text
    assert 'controller_' not in text.split('graph ready')[0]


def test_run_all_walks_with_the_loop_composed_and_exchanging_by_call(tmp_path):
    """One step with the plant and the grouped controllers in one process, in sim time."""
    text, out, summary = walk_one_step(tmp_path, 'loop', '--composed-loop')
    assert 'with the loop (plant, controllers) in one process' in text
    log = (out / 'logs' / 'loop.log').read_text()
    assert 'the plant and the controllers exchange by call' in log, log
    # the plant waited for the supervisor's decisions (a loaded machine may time one out)
    assert summary['loop']['decision_timeouts'] is not None, summary['loop']
    assert "in sim time with the supervisor's decisions" in text
    assert (out / 'bag' / 'metadata.yaml').exists()  # the recorder, a process of its own


def test_run_all_walks_composed_with_the_planner_and_the_loop_by_call(tmp_path):
    """The whole graph in one process in sim time: states and setpoints by call, recorded.

    The plant hands each state to the planner's stream and to the grouped controllers, the
    stream its setpoints to the controllers, by call (the step could not be walked without
    them); the topics the recorder in the same process keeps are still published, and the
    walk report reads the walk from its bag.
    """
    from walker_bag.core.bag_reader import BagReader
    from walker_report.core.walk_data import load_walk

    text, out, summary = walk_one_step(tmp_path, 'composed', '--composed')
    assert 'in 1 composed process' in text
    log = (out / 'logs' / 'graph.log').read_text()
    assert 'the plant, the planner and the controllers exchange by call' in log, log
    with BagReader(out / 'bag') as reader:
        counts = reader.message_counts
    states = next(n for topic, n in counts.items() if topic.endswith('/joint_states'))
    simulated = summary['steps'][0]['duration']  # [s]
    assert states > 0.9 * 500 * simulated, (states, simulated)  # every period's state
    for name in ('a_yaw_joint', 'b_yaw_joint', 'vertex_joint'):
        controller = next(n for topic, n in counts.items()
                          if topic.endswith(f'/controllers/{name}/state'))
        assert controller > 0.9 * 100 * simulated, (name, controller)  # control.state_rate
    assert any(event.step_count for event in load_walk(out / 'bag').phases)
@pytest.mark.timeout(600)
def test_a_killed_composed_graph_comes_back_where_the_robot_was_and_continues_its_bag(
        tmp_path):
    """``--composed --serve``: one step, a SIGKILL of the one process, the same robot after.

    The process started again restores the plant's snapshot (the grippers' nodes and the joint
    angles of the step's end, not ``sim.start``) and its recorder continues the bag in a new
    file: every file readable whole, no recorded instant without a gripper attached.
    """
    from chaos_run import check_bag
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from walker_msgs.msg import GripperState

    from walker_bringup.chaos_driver import ChaosDriver
    from walker_bringup.graph_client import GraphClient, init_context
    from walker_bringup.processes import read_pids

    namespace = f'/walker_composed_kill_{os.getpid()}'
    out = tmp_path / 'run'
    with isolated_domain() as domain:
        args = serve_command(namespace, out, '--composed', '--respawn-delay', '0.5')
        with NodeProcess(args, ros_environment(domain), 'run_all') as run:
            assert run.wait_for_output('[walker] serving in namespace', 180.0), run.output
            context = init_context(domain)
            client = GraphClient(namespace, context)
            try:
                joints = {}
                client.node.create_subscription(
                    JointState, 'joint_states',
                    lambda m: joints.update(zip(m.name, m.position, strict=True)),
                    QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT))
                # one step, a hold on the way resumed (one process is slow on a loaded machine)
                ChaosDriver(client, out / 'logs', ('n1_2',), 240.0).finish()

                def attached() -> dict:
                    return {g.name: g.node for g in client.grippers.grippers
                            if g.state == GripperState.ATTACHED}

                client.spin_for(1.0)  # the snapshot is at most 0.1 s old
                before_joints, before_grippers = dict(joints), attached()
                assert 'n1_2' in before_grippers.values(), before_grippers
                assert len(before_joints) == 5, before_joints
                os.kill(read_pids(out / 'logs')['graph'], signal.SIGKILL)
                assert run.wait_for_output('node graph started again', 120.0), run.output
                joints.clear()
                client.grippers = None
                deadline = time.monotonic() + 180.0
                while (len(joints) < 5 or client.grippers is None) \
                        and time.monotonic() < deadline:
                    client.spin_for(0.2)
                assert len(joints) == 5 and client.grippers is not None, run.output
                assert attached() == before_grippers
                for name, angle in before_joints.items():
                    assert joints[name] == pytest.approx(angle, abs=2e-3), name  # [rad]
            finally:
                client.close()
                context.try_shutdown()
            assert run.stop(timeout=60.0) == 0, run.output
    assert processes_with(namespace) == [], run.output
    bag = check_bag(out / 'bag')
    assert len(bag['files']) >= 2, bag  # a new file after the kill
    assert bag['messages'] == sum(bag['files'].values()) == bag['metadata_messages'], bag
    assert bag['instants'] > 0 and bag['grip_losses'] == 0, bag
    summary = json.loads((out / 'summary.json').read_text())
    assert summary['processes']['graph']['restarts'] == 1, summary['processes']
