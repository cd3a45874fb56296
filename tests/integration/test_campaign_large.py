"""A bigger campaign, opt-in (``-m campaign_large``): real headless walks under dispersions.

Twenty walks of one step (n2_1 -> n1_2) on the headless runner under the shipped default
campaign's dispersions, on a local Ray with two workers; every run has its rows, the report
with its figures is written, and one run re-run alone by its index matches its rows exactly.
"""

import json
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
