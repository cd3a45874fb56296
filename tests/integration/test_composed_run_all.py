"""``run_all.py --composed``: the whole graph in one process comes up, and nothing is left."""

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
