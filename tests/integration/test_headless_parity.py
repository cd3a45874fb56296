"""The headless runner walks as the sim-time graph does: the same steps, times and errors.

The same two steps (gripper b n2_1 -> n1_2 about a, then gripper a n1_1 -> n2_2 about b: both
bases, both roles of every joint) walked by ``run_all.py --headless`` and by ``run_all.py
--sim-time`` (the graph as separate processes over DDS in an isolated domain) with the
supervisor in the lock-step (``sim.wait_for_decisions``: the plant steps no further than the
supervisor has decided), from the same parameter file. They must agree: the same route,
steps and phase sequence, every step's time within 5 %, every phase's within 5 % of its
step's, the tip errors at insertion within 0.3 mm, and bags of the same topics and types.

What still differs, and why the bounds hold: the graph's supervisor decides at once when a
gripper's state changes or a motion ends, at whatever simulated time its clock reads when
the message arrives (up to a tick later than the plant's stamp); the headless loop decides
at the stamp. Each of its ticks waits for the joint state of its time
(``walker_supervisor.core.current_state``). Measured: phase boundaries one 20 ms tick apart,
tip errors within 0.05 mm (docs/performance_log.md).
"""

import json
import re
import subprocess
import sys

import pytest

from ros_test_support import REPO_ROOT, isolated_domain, ros_environment

TARGET = 'n2_2'
PATH = ['n1_2', 'n2_2']
RUN_TIMEOUT = 900.0  # [s] wall: the graph walks at a fraction of real time on a loaded machine
STEP_TIME_TOLERANCE = 0.05  # relative
TIP_ERROR_TOLERANCE = 0.3e-3  # [m]

pytestmark = [pytest.mark.integration, pytest.mark.timeout(2 * RUN_TIMEOUT + 120.0)]


def _run_all(options, out, env=None):
    args = [sys.executable, str(REPO_ROOT / 'scripts' / 'run_all.py'), '--target', TARGET,
            '--out', str(out), '--no-report', '--quiet', *options]
    run = subprocess.run(args, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                         text=True, cwd=REPO_ROOT, timeout=RUN_TIMEOUT)
    summary = json.loads((out / 'summary.json').read_text()) \
        if (out / 'summary.json').exists() else None
    return run, summary


@pytest.fixture(scope='module')
def walks(tmp_path_factory):
    """Walk the graph and headless from one parameter file; return their summaries."""
    tmp = tmp_path_factory.mktemp('parity')
    shipped = (REPO_ROOT / 'ros2_ws' / 'src' / 'walker_core' / 'config' / 'walker.yaml')
    params = tmp / 'walker.yaml'
    text, count = re.subn(r'wait_for_decisions: false', 'wait_for_decisions: true',
                          shipped.read_text())
    assert count == 1, 'sim.wait_for_decisions is no longer in the parameter file'
    params.write_text(text)
    with isolated_domain() as domain:
        graph = _run_all(['--sim-time', '--params-file', str(params)], tmp / 'graph',
                         ros_environment(domain))
    headless = _run_all(['--headless', '--params-file', str(params)], tmp / 'headless')
    for name, (run, summary) in (('graph', graph), ('headless', headless)):
        assert run.returncode == 0 and summary is not None, f'{name}:\n{run.stdout}'
    return {'graph': graph[1], 'headless': headless[1], 'dirs': (tmp / 'graph', tmp / 'headless')}


def test_both_take_the_same_route_with_the_same_steps(walks):
    graph, headless = walks['graph'], walks['headless']
    assert graph['reached'] and headless['reached']
    assert graph['path'] == headless['path'] == PATH
    keys = ('index', 'gripper', 'from_node', 'to_node', 'sweep', 'success', 'attempts')
    assert [{k: s[k] for k in keys} for s in graph['steps']] == \
        [{k: s[k] for k in keys} for s in headless['steps']]


def test_every_step_and_phase_takes_the_same_time_within_five_percent(walks):
    for graph, headless in zip(walks['graph']['steps'], walks['headless']['steps'],
                               strict=True):
        assert headless['duration'] == pytest.approx(graph['duration'],
                                                     rel=STEP_TIME_TOLERANCE), \
            (graph['phase_durations'], headless['phase_durations'])
        assert list(headless['phase_durations']) == list(graph['phase_durations'])
        for phase, seconds in graph['phase_durations'].items():
            assert abs(headless['phase_durations'][phase] - seconds) \
                <= STEP_TIME_TOLERANCE * graph['duration'], (phase, graph, headless)


def test_the_tip_errors_at_insertion_agree_within_three_tenths_of_a_millimetre(walks):
    for graph, headless in zip(walks['graph']['steps'], walks['headless']['steps'],
                               strict=True):
        for key in ('insertion_error', 'insertion_error_estimated'):
            assert abs(headless[key] - graph[key]) <= TIP_ERROR_TOLERANCE, (key, graph,
                                                                            headless)


def test_both_bags_hold_the_same_topics_and_phase_sequence(walks):
    from walker_bag.core.bag_reader import BagReader
    from walker_report.core.walk_data import load_walk

    def phases(run_dir):
        """Return the walk's phases in order (the graph's IDLE before the walk left out)."""
        events = [(e.phase, e.step_index, e.from_node, e.to_node)
                  for e in load_walk(run_dir / 'bag').phases if e.step_count]
        return [e for k, e in enumerate(events) if k == 0 or e != events[k - 1]]

    def topics(run_dir):
        with BagReader(run_dir / 'bag') as reader:
            return reader.topics

    graph_dir, headless_dir = walks['dirs']
    assert topics(headless_dir) == topics(graph_dir)
    sequence = phases(graph_dir)
    assert [p[0] for p in sequence if p[2]].count(1) == 2  # two extractions: two steps
    assert phases(headless_dir) == sequence
