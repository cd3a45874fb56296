"""``run_all.py --composed`` and ``--grouped-controllers``: up, walking, nothing left."""

import json

import os
import subprocess
import sys

import pytest

from ros_test_support import REPO_ROOT, isolated_domain, processes_with, ros_environment

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
