"""A bigger campaign, opt-in (``-m campaign_large``): real headless walks under dispersions.

Twenty walks of one step (n2_1 -> n1_2) on the headless runner under the shipped default
campaign's dispersions, on a local Ray with two workers; every run has its rows, the report
with its figures is written, and one run re-run alone by its index matches its rows exactly.
And one walk of the whole sim-time ROS graph (``--graph``) as a Ray task.
"""

import json
import os
import secrets
import subprocess
import sys

import pytest
import yaml

from ros_test_support import REPO_ROOT

pytestmark = [pytest.mark.campaign_large, pytest.mark.timeout(3600)]
RUNS = 20


def test_a_campaign_of_real_headless_walks(tmp_path):
    shipped = REPO_ROOT / 'ros2_ws' / 'src' / 'walker_campaign' / 'config' / 'default_walk.yaml'
    spec = yaml.safe_load(shipped.read_text())
    spec.update(name='large_test', runs=RUNS, route={'target': 'n1_2', 'walk_timeout': 600})
    path = tmp_path / 'large.yaml'
    path.write_text(yaml.safe_dump(spec))
    out = tmp_path / 'out'
    command = [sys.executable, str(REPO_ROOT / 'scripts' / 'campaign.py'), str(path),
               '--out', str(out), '--workers', '2']
    run = subprocess.run(command, capture_output=True, text=True, timeout=3000, cwd=REPO_ROOT)
    assert run.returncode == 0, run.stdout + run.stderr
    rows = [json.loads(line) for line in (out / 'results.jsonl').read_text().splitlines()]
    runs = [r for r in rows if r['kind'] == 'run']
    assert sorted(r['index'] for r in runs) == list(range(RUNS))
    assert not [r for r in runs if r['outcome'] == 'error'], 'every walk was carried out'
    for name in ('report.md', 'outcomes.png', 'distributions.png', 'sensitivity.png'):
        assert (out / 'report' / name).is_file(), name
    rerun = subprocess.run([*command[:-2], '--run-index', '7'], capture_output=True,
                           text=True, timeout=900, cwd=REPO_ROOT)
    assert rerun.returncode == 0, rerun.stdout + rerun.stderr
    assert 'run 7: every row identical to' in rerun.stdout


def test_a_real_walk_of_the_graph_on_a_local_ray(tmp_path):
    """One walk of the sim-time graph (--graph) as a Ray task, its plant on the truth's file."""
    env = dict(os.environ, RAY_USAGE_STATS_ENABLED='0', PYTHONUNBUFFERED='1',
               RAY_AUTH_MODE='token', RAY_AUTH_TOKEN=secrets.token_hex(32))
    spec = tmp_path / 'graph.yaml'
    spec.write_text(yaml.safe_dump({
        'name': 'graph_test', 'seed': 5, 'runs': 1, 'route': {'target': 'n1_2'},
        'dispersions': {
            'friction': {'parameters': ['robot.drive.*.friction_torque'],
                         'apply': 'scale', 'uniform': {'low': 0.9, 'high': 1.2}}}}))
    out = tmp_path / 'out'
    command = [sys.executable, str(REPO_ROOT / 'scripts' / 'campaign.py'),
               str(spec), '--out', str(out), '--workers', '1', '--graph']
    run = subprocess.run(command, env=env, capture_output=True, text=True, timeout=900,
                         cwd=REPO_ROOT)
    assert run.returncode == 0, run.stdout + run.stderr
    rows = [json.loads(line) for line in (out / 'results.jsonl').read_text().splitlines()]
    walk = next(r for r in rows if r['kind'] == 'run')
    assert walk['outcome'] != 'error', walk
    assert walk['exec.walk'] == 'graph'
    steps = [r for r in rows if r['kind'] == 'step']
    assert steps and all(r['tip_error'] < 2e-3 for r in steps if r['success'])
    assert (out / 'report' / 'report.md').is_file()
