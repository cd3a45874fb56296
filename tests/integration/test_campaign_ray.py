"""A campaign on a two-node Ray cluster on loopback survives the death of a worker node.

The test starts a head and a worker node as separate ``ray start`` processes (127.0.0.1 only,
one CPU each, temp directories of their own, a token of their own, no dashboard, no usage
statistics), runs a small
campaign on them through ``campaign.py --address``, kills the worker node's processes while
it runs a walk, and checks that the campaign still finishes with every run's result (the lost
walk retried on the head), that one run re-run alone by its index gives its row exactly, and
that the report is written. Every process it started is stopped by its own process group.
"""

from __future__ import annotations

import json
import os
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest
import yaml

from ros_test_support import REPO_ROOT, NodeProcess

pytestmark = pytest.mark.integration

CAMPAIGN = (REPO_ROOT / 'ros2_ws' / 'src' / 'walker_campaign' / 'test').resolve()
RUNS = 6
_TASK_TITLE = 'ray::_execute_on_ray'  # a Ray worker's process title while it runs a walk


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(('127.0.0.1', 0))
        return probe.getsockname()[1]


def ray_start(args: list[str], env: dict[str, str], name: str) -> NodeProcess:
    """Start a Ray node on loopback (``ray start`` through :mod:`walker_campaign.ray_node`)."""
    return NodeProcess([sys.executable, '-m', 'walker_campaign.ray_node', '--block',
                        '--node-ip-address', '127.0.0.1', '--num-cpus', '1',
                        '--object-store-memory', str(80 * 2**20), '--disable-usage-stats',
                        *args], env, name)


def _stat(pid: int) -> list[str] | None:
    """Return the fields of /proc/PID/stat after the command name (state first), or None."""
    try:
        return Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()
    except OSError:
        return None


def descendants(root: int) -> dict[int, str]:
    """Return the live processes started, directly or not, by ``root`` (and itself).

    Each process is keyed by its id, with its start time (so that a process id used again
    later is not taken for it).
    """
    children: dict[int, list[int]] = {}
    for entry in Path('/proc').iterdir():
        if entry.name.isdigit() and (fields := _stat(int(entry.name))) is not None:
            children.setdefault(int(fields[1]), []).append(int(entry.name))
    found: dict[int, str] = {}
    todo = [root]
    while todo:
        pid = todo.pop()
        if pid not in found and (fields := _stat(pid)) is not None:
            found[pid] = fields[19]
            todo.extend(children.get(pid, []))
    return found


def alive(processes: dict[int, str]) -> set[int]:
    """Return the processes still running (a zombie has ended)."""
    running = set()
    for pid, started in processes.items():
        fields = _stat(pid)
        if fields is not None and fields[19] == started and fields[0] != 'Z':
            running.add(pid)
    return running


def running_walk(process: NodeProcess) -> bool:
    """Whether a worker process of this node is running a walk now."""
    for pid in descendants(process.process.pid):
        try:
            title = Path(f'/proc/{pid}/cmdline').read_bytes().split(b'\0')[0].decode()
        except OSError:
            continue
        if title.startswith(_TASK_TITLE):
            return True
    return False


def assert_all_ended(processes: dict[int, str], timeout: float = 30.0) -> None:
    """Assert that every process ends; kill (by id) and name any that does not."""
    deadline = time.monotonic() + timeout
    while alive(processes) and time.monotonic() < deadline:
        time.sleep(0.2)
    left = alive(processes)
    for pid in left:
        os.kill(pid, signal.SIGKILL)
    assert not left, f'processes left running: {sorted(left)}'


_LOOPBACK = {'0100007F', '0000000000000000FFFF00000100007F', '00000000000000000000000001000000'}


def listening_addresses(pids: list[int]) -> set[str]:
    """Return the local addresses (hex, as /proc/net shows them) the processes listen on."""
    inodes = set()
    for pid in pids:
        try:
            for fd in Path(f'/proc/{pid}/fd').iterdir():
                target = os.readlink(fd)
                if target.startswith('socket:['):
                    inodes.add(target[8:-1])
        except OSError:
            continue
    addresses = set()
    for table in ('tcp', 'tcp6'):
        for line in Path(f'/proc/net/{table}').read_text().splitlines()[1:]:
            fields = line.split()
            if fields[3] == '0A' and fields[9] in inodes:  # LISTEN
                addresses.add(fields[1].rsplit(':', 1)[0])
    return addresses


def wait_for(condition, timeout: float, what: str, poll: float = 0.2) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return
        time.sleep(poll)
    raise AssertionError(f'timed out waiting for {what}')


def finished_runs(path: Path) -> set[int]:
    if not path.is_file():
        return set()
    rows = [json.loads(line) for line in path.read_text().splitlines() if line.endswith('}')]
    return {row['index'] for row in rows if row.get('kind') == 'run'}


def small_spec(tmp_path: Path, runs: int, target: str = 'n1_2') -> Path:
    """Write a small campaign's spec: friction and joint offsets dispersed."""
    spec = tmp_path / 'small.yaml'
    spec.write_text(yaml.safe_dump({
        'name': 'ray_test', 'seed': 5, 'runs': runs, 'route': {'target': target},
        'dispersions': {
            'friction': {'parameters': ['robot.drive.*.friction_torque',
                                        'robot.drive.*.stiction_torque'],
                         'apply': 'scale', 'uniform': {'low': 0.9, 'high': 1.2}},
            'offset': {'parameter': 'sim.imperfections.joint_offset', 'per_parameter': True,
                       'normal': {'mean': 0.0, 'std': 0.0002}}}}))
    return spec


def campaign_environment() -> dict[str, str]:
    """Return the environment of a campaign: the stand-in walk importable, a token."""
    env = dict(os.environ, RAY_USAGE_STATS_ENABLED='0', PYTHONUNBUFFERED='1',
               RAY_AUTH_MODE='token', RAY_AUTH_TOKEN=secrets.token_hex(32))
    env['PYTHONPATH'] = os.pathsep.join([str(CAMPAIGN), env.get('PYTHONPATH', '')])
    return env


def run_nodes(path: Path) -> set[str]:
    """Return the Ray nodes that wrote a run row."""
    if not path.is_file():
        return set()
    rows = [json.loads(line) for line in path.read_text().splitlines() if line.endswith('}')]
    return {row['exec.node'] for row in rows if row.get('kind') == 'run'}


def test_a_campaign_on_two_ray_nodes_survives_a_dead_worker(tmp_path):
    env = campaign_environment()
    spec = small_spec(tmp_path, RUNS)
    out = tmp_path / 'out'
    results = out / 'results.jsonl'
    port = free_port()
    address = f'127.0.0.1:{port}'
    head_dir = tempfile.mkdtemp(prefix='wr-head-')
    worker_dir = tempfile.mkdtemp(prefix='wr-work-')
    campaign = [sys.executable, str(REPO_ROOT / 'scripts' / 'campaign.py'), str(spec),
                '--out', str(out), '--walk', 'campaign_samples:slow_stand_in_walk']
    started: dict[int, str] = {}
    try:
        with ray_start(['--head', '--port', str(port), '--include-dashboard', 'false',
                        '--temp-dir', head_dir], env, 'ray-head') as head:
            assert head.wait_for_output('Ray runtime started', 120), head.output
            with ray_start(['--address', address, '--temp-dir', worker_dir], env,
                           'ray-worker') as worker:
                assert worker.wait_for_output('Ray runtime started', 120), worker.output
                with NodeProcess([*campaign, '--address', address], env,
                                 'campaign') as driver:
                    # the worker node has walked one run and walks another: kill it then
                    wait_for(lambda: (len(run_nodes(results)) == 2 and running_walk(worker))
                             or driver.process.poll() is not None, 120,
                             'a second walk on the worker node')
                    assert driver.process.poll() is None, driver.output
                    for root in (head, worker, driver):
                        started.update(descendants(root.process.pid))
                    listening = listening_addresses(list(started))
                    assert listening and listening <= _LOOPBACK, \
                        f'listening beyond loopback: {listening}'
                    assert len(finished_runs(results)) < RUNS
                    doomed = descendants(worker.process.pid)
                    for pid in doomed:  # the node dies at once, every process of it
                        os.kill(pid, signal.SIGKILL)
                    wait_for(lambda: not alive(doomed), 10, 'the worker node to die')
                    assert driver.process.wait(timeout=180) == 0, driver.output
                    text = driver.output
                    started.update(descendants(head.process.pid))
    finally:
        assert_all_ended(started)
        shutil.rmtree(head_dir, ignore_errors=True)
        shutil.rmtree(worker_dir, ignore_errors=True)
    assert finished_runs(results) == set(range(RUNS)), text
    assert len(run_nodes(results)) == 2, 'both nodes walked'
    assert 'lost' not in text, text
    assert (out / 'report' / 'report.md').is_file()
    assert f'of {RUNS})' in (out / 'report' / 'report.md').read_text()
    # one run again alone, here, without Ray: the same row exactly
    rerun = subprocess.run([*campaign, '--run-index', '4'], env=env, capture_output=True,
                           text=True, timeout=120, cwd=REPO_ROOT)
    assert rerun.returncode == 0, rerun.stdout + rerun.stderr
    assert 'run 4: every row identical to' in rerun.stdout


def test_a_local_campaign_stays_on_loopback_resumes_and_ends_its_processes(tmp_path):
    env = campaign_environment()
    runs = 4
    out = tmp_path / 'out'
    results = out / 'results.jsonl'
    campaign = [sys.executable, str(REPO_ROOT / 'scripts' / 'campaign.py'),
                str(small_spec(tmp_path, runs)), '--out', str(out), '--workers', '2',
                '--walk', 'campaign_samples:slow_stand_in_walk', '--no-report']
    started: dict[int, str] = {}
    try:
        with NodeProcess(campaign, env, 'campaign') as driver:
            wait_for(lambda: len(finished_runs(results)) >= 1
                     or driver.process.poll() is not None, 120, 'a first run written')
            assert driver.process.poll() is None, driver.output
            started.update(descendants(driver.process.pid))
            listening = listening_addresses(list(started))
            assert listening and listening <= _LOOPBACK, f'listening beyond loopback: {listening}'
            os.kill(driver.process.pid, signal.SIGTERM)  # interrupted: resumable
            assert driver.process.wait(timeout=60) == 130, driver.output
    finally:
        assert_all_ended(started)
    first = finished_runs(results)
    assert 1 <= len(first) < runs
    before = results.read_text()
    with NodeProcess(campaign, env, 'campaign') as driver:
        assert driver.process.wait(timeout=180) == 0, driver.output
        text = driver.output
    assert f'{len(first)} done already, {runs - len(first)} to run' in text, text
    assert results.read_text().startswith(before)
    assert finished_runs(results) == set(range(runs))
    rows = [json.loads(line) for line in results.read_text().splitlines()]
    assert sorted(r['index'] for r in rows if r['kind'] == 'run') == list(range(runs)), \
        'no run walked twice'
