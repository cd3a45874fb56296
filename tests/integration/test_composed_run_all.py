"""``run_all.py --composed``: the whole graph in one process comes up, and nothing is left."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from ros_test_support import REPO_ROOT, isolated_domain, ros_environment

pytestmark = pytest.mark.integration


def _processes_with(marker: str) -> list[int]:
    found = []
    for cmdline in Path('/proc').glob('[0-9]*/cmdline'):
        try:
            if marker in cmdline.read_bytes().decode(errors='replace'):
                found.append(int(cmdline.parent.name))
        except OSError:
            continue
    return [pid for pid in found if pid != os.getpid()]


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
    assert _processes_with(namespace) == [], text
