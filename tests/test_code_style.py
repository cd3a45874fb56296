"""The linters, as part of the suite (the ament_flake8 / ament_pep257 rules, through ruff)."""

import subprocess
import sys

from ros_test_support import REPO_ROOT


def test_ruff_finds_nothing():
    result = subprocess.run([sys.executable, '-m', 'ruff', 'check', '--no-cache', '.'],
                            cwd=REPO_ROOT, capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr


def test_every_process_the_project_starts_keeps_dds_on_loopback():
    """Scripts that start processes set ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST."""
    env_setup = (REPO_ROOT / 'scripts' / 'walker_env.py').read_text()
    assert "env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'" in env_setup
    support = (REPO_ROOT / 'tests' / 'ros_test_support.py').read_text()
    assert "env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'" in support
