"""The headless runner walks as the sim-time graph does: the same steps, times and errors.

The same two steps (gripper b n2_1 -> n1_2 about a, then gripper a n1_1 -> n2_2 about b: both
bases, both roles of every joint), with the wrist cameras looking before each descent,
walked by ``run_all.py --headless`` and by ``run_all.py --sim-time`` (the graph as separate
processes over DDS in an isolated domain) with the supervisor in the lock-step
(``sim.wait_for_decisions``: the plant steps no further than the supervisor has decided),
from the same parameter file. They must agree: the same route,
steps and phase sequence, every step's time within 5 %, every phase's within 5 % of its
step's, the tip errors at insertion within 0.3 mm, and bags of the same topics and types.

What still differs, and why the bounds hold: the graph's supervisor decides at once when a
gripper's state changes or a motion ends, at whatever simulated time its clock reads when
the message arrives (up to a tick later than the plant's stamp); the headless loop decides
at the stamp. Each of its ticks waits for the joint state of its time
(``walker_supervisor.core.current_state``). Measured: phase boundaries one 20 ms tick apart,
tip errors within 0.05 mm (docs/performance_log.md).

The truss as built: one step (gripper b n2_1 -> n1_2 about a) over a truss whose nodes the
plant places 1.5 to 3 mm off the parameter file's (``sim.imperfections.node_placement``, the
plant's truth alone), far enough that the first screw-in jams and the hole is found by a search.
Both walks start from a truss survey file (``--truss-survey``) that surveyed a node off the
route; both reach n1_2 without ever letting go, with the same steps and search probes, tip
errors within 0.3 mm, and each writes its survey, the given node kept, the target surveyed.
"""

import json
import math
import re
import subprocess
import sys

import numpy as np
import pytest
import yaml

from ros_test_support import REPO_ROOT, isolated_domain, ros_environment

TARGET = 'n2_2'
PATH = ['n1_2', 'n2_2']
RUN_TIMEOUT = 900.0  # [s] wall: the graph walks at a fraction of real time on a loaded machine
STEP_TIME_TOLERANCE = 0.05  # relative
TIP_ERROR_TOLERANCE = 0.3e-3  # [m]
# [m] the screw-in's error from the real hole after the search on the displaced truss: the tip
# comes to rest on the node's face and in the mouth's chamfer, where contact and friction hold
# it, and the two walks (their decisions some ticks apart) leave it up to 0.2 mm apart there;
# measured from the real hole, 0.52 mm headless against 0.80-0.84 mm in the graph
CONTACT_TIP_ERROR_TOLERANCE = 0.5e-3
# the truss as built: a placement of 1.5 mm standard deviation whose seed puts the nodes of the
# step 1.7 to 2.8 mm off their places, n1_2 2.9 mm sideways of n1_1's offset: the screw-in at
# the estimate jams and the search's first probe finds the hole (at seed 164, 1.2 mm, the graph
# and headless parted at the first probe: docs/performance_log.md)
DISPLACED_TARGET = 'n1_2'
DISPLACED_NODES = ('n1_1', 'n2_1', 'n1_2')  # the start stance and the target
PLACEMENT, PLACEMENT_SEED = 0.0015, 191  # [m], seed
SURVEYED_OFF_ROUTE = 'n4_3'  # the node the given survey knows, off the route
# the two steps are walked with the wrist cameras: each looks before its descent, the graph's
# plant rendering the frames its supervisor triggers, the headless loop's the runner's
CAMERAS_ON = (r'enabled: false( +# chosen: the paper)', r'enabled: true\1')

pytestmark = [pytest.mark.integration, pytest.mark.timeout(2 * RUN_TIMEOUT + 120.0)]


def _run_all(options, out, env=None, target=TARGET):
    args = [sys.executable, str(REPO_ROOT / 'scripts' / 'run_all.py'), '--target', target,
            '--out', str(out), '--no-report', '--quiet', *options]
    run = subprocess.run(args, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                         text=True, cwd=REPO_ROOT, timeout=RUN_TIMEOUT)
    summary = json.loads((out / 'summary.json').read_text()) \
        if (out / 'summary.json').exists() else None
    return run, summary


def _parameter_file(path, *replacements):
    """Write the shipped file with the supervisor in the lock-step and ``replacements``."""
    shipped = (REPO_ROOT / 'ros2_ws' / 'src' / 'walker_core' / 'config' / 'walker.yaml')
    text = shipped.read_text()
    for pattern, value in (('wait_for_decisions: false', 'wait_for_decisions: true'),
                           *replacements):
        text, count = re.subn(pattern, value, text)
        assert count == 1, f'{pattern!r} is no longer in the parameter file'
    path.write_text(text)
    return path


@pytest.fixture(scope='module')
def walks(tmp_path_factory):
    """Walk the graph and headless from one parameter file; return their summaries."""
    tmp = tmp_path_factory.mktemp('parity')
    params = _parameter_file(tmp / 'walker.yaml', CAMERAS_ON)
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


def test_both_look_before_each_descent(walks):
    """Both walks look before each descent.

    The headless walk's looks are in its summary; the graph's are in its FINE phases, as long
    as the headless's (a look adds 0.38 s to a 0.26 s fine motion: more than the phases' 5 %
    of the step).
    """
    finals = [look for look in walks['headless']['looks'] if look['final']]
    assert [look['node'] for look in finals] == PATH
    assert all(look['seen'] for look in finals)
    for step in walks['graph']['steps']:
        assert step['phase_durations']['fine'] > 0.5, step['phase_durations']


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


# ---------------------------------------------------------------- the truss as built
def _placement_errors(params):
    """Node -> the plant's placement error (x, y, z) [m] of the parameter file."""
    from walker_config.core.configuration import load_configuration
    from walker_core.truss import Truss
    from walker_sim.core.imperfections import NodePlacement

    imperfect = load_configuration(params).sim.imperfections
    truss = Truss.from_parameters(load_configuration(params).walker)
    return NodePlacement(truss.node_names, imperfect.node_placement, imperfect.seed).errors


def _given_survey(path, params):
    """Write a survey file anchored at n1_1 that knows one node off the route, where it is."""
    from walker_config.core.configuration import load_configuration
    from walker_core.truss import Truss

    truss = Truss.from_parameters(load_configuration(params).walker)
    errors = _placement_errors(params)
    relative = np.subtract(errors[SURVEYED_OFF_ROUTE], errors['n1_1'])
    path.write_text(yaml.safe_dump({
        'format': 'walker-truss-survey-1', 'frame': 'truss', 'anchor': 'n1_1',
        'nodes': {'n1_1': {'position': truss.position('n1_1').tolist(),
                           'covariance': np.zeros((3, 3)).tolist()},
                  SURVEYED_OFF_ROUTE: {
                      'position': (truss.position(SURVEYED_OFF_ROUTE) + relative).tolist(),
                      'covariance': (np.eye(3) * 1e-8).tolist()}}}))
    return path


@pytest.fixture(scope='module')
def displaced(tmp_path_factory):
    """Walk the graph and headless over the displaced truss, from one given survey."""
    tmp = tmp_path_factory.mktemp('displaced')
    params = _parameter_file(
        tmp / 'walker.yaml', (r'node_placement: 0\.0 ', f'node_placement: {PLACEMENT} '),
        (r'seed: 0( +# chosen: seed of the placement)', rf'seed: {PLACEMENT_SEED}\1'))
    survey = _given_survey(tmp / 'given_survey.yaml', params)
    options = ['--params-file', str(params), '--truss-survey', str(survey)]
    with isolated_domain() as domain:
        graph = _run_all(['--sim-time', *options], tmp / 'graph', ros_environment(domain),
                         DISPLACED_TARGET)
    headless = _run_all(['--headless', *options], tmp / 'headless', target=DISPLACED_TARGET)
    for name, (run, summary) in (('graph', graph), ('headless', headless)):
        assert run.returncode == 0 and summary is not None, f'{name}:\n{run.stdout}'
    return {'params': params, 'survey': survey, 'graph': graph[1], 'headless': headless[1],
            'dirs': {'graph': tmp / 'graph', 'headless': tmp / 'headless'}}


def test_the_step_is_over_nodes_displaced_one_and_a_half_to_three_millimetres(displaced):
    errors = _placement_errors(displaced['params'])
    for node in DISPLACED_NODES:
        assert 1.5e-3 <= np.linalg.norm(errors[node]) <= 3e-3, (node, errors[node])


def test_both_reach_the_target_over_the_displaced_truss_after_the_same_search(displaced):
    graph, headless = displaced['graph'], displaced['headless']
    assert graph['reached'] and headless['reached'], (graph['message'], headless['message'])
    assert graph['path'] == headless['path'] == [DISPLACED_TARGET]
    keys = ('index', 'gripper', 'from_node', 'to_node', 'sweep', 'success', 'attempts',
            'search_probes')
    assert [{k: s[k] for k in keys} for s in graph['steps']] == \
        [{k: s[k] for k in keys} for s in headless['steps']]
    step = graph['steps'][0]
    assert step['search_probes'] >= 1, 'the displaced node was found without a search'
    for walk in (graph, headless):
        assert math.isfinite(walk['steps'][0]['hole_offset'])
    assert abs(graph['steps'][0]['hole_offset'] - headless['steps'][0]['hole_offset']) \
        <= TIP_ERROR_TOLERANCE
    for key, tolerance in (('insertion_error', CONTACT_TIP_ERROR_TOLERANCE),
                           ('insertion_error_estimated', TIP_ERROR_TOLERANCE)):
        assert abs(headless['steps'][0][key] - step[key]) <= tolerance, key


def test_one_gripper_is_attached_at_every_moment_of_both_walks(displaced):
    from walker_msgs.msg import GripperState
    from walker_report.core.walk_data import load_walk

    for name, run_dir in displaced['dirs'].items():
        events = load_walk(run_dir / 'bag').gripper_events
        assert events, name
        for event in events:
            assert any(state == GripperState.ATTACHED for state, _ in event.states.values()), \
                (name, event)


def test_both_start_from_the_given_survey_and_write_the_walks_survey(displaced):
    given = yaml.safe_load(displaced['survey'].read_text())['nodes'][SURVEYED_OFF_ROUTE]
    written = {name: yaml.safe_load((run_dir / 'truss_survey.yaml').read_text())
               for name, run_dir in displaced['dirs'].items()}
    for name, survey in written.items():
        # the given node is kept as given: the map started from the file, not the drawing
        np.testing.assert_allclose(survey['nodes'][SURVEYED_OFF_ROUTE]['position'],
                                   given['position'], atol=1e-12, err_msg=name)
        assert survey['anchor'] == 'n1_1' and DISPLACED_TARGET in survey['nodes'], name
    graph, headless = written['graph']['nodes'], written['headless']['nodes']
    assert sorted(graph) == sorted(headless)
    for node in graph:
        np.testing.assert_allclose(graph[node]['position'], headless[node]['position'],
                                   atol=TIP_ERROR_TOLERANCE, err_msg=node)
