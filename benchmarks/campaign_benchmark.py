#!/usr/bin/env python3
"""Benchmark of campaigns on Ray: walks per hour with 1 and 2 workers, and on two Ray nodes.

Usage: ``python3 benchmarks/campaign_benchmark.py [--walks N] [--spec NAME_OR_PATH]
[--walk NAME]``. Sets up the environment like the other scripts, prints a table and writes
``benchmarks/results/campaign.json``.

The same runs of one campaign (default: the first ``N`` of the shipped ``default_walk``, each a
whole default walk under its dispersed truth) are walked three times, each time by the
campaign runner (:class:`walker_campaign.ray_runner.RayCampaign`) on:

1. a local Ray with one worker (``num_cpus=1``);
2. a local Ray with two workers;
3. a two-node Ray cluster on loopback that the benchmark starts itself: a head and a worker
   node as separate ``ray start`` processes (:mod:`walker_campaign.ray_node`: 127.0.0.1 only,
   one CPU each, temp directories and a token of their own, no dashboard, no usage
   statistics), stopped by their process groups at the end.

Each configuration's workers are warmed first (one task per CPU imports the walker), so the
figure is the steady pace of walks, not Ray's start-up. Walks per hour = walks / wall time
from the first submission to the last result; scaling efficiency = walks per hour with two
workers / (2 x with one). The machine's load average before and after each configuration is
recorded: on a machine shared with other work the figures are what that load left.
"""

from __future__ import annotations

import argparse
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

REPO_ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO_ROOT / 'scripts'))
sys.path.insert(0, str(REPO_ROOT / 'benchmarks'))

import walker_env  # noqa: E402

RESULTS = REPO_ROOT / 'benchmarks' / 'results' / 'campaign.json'
TARGET_EFFICIENCY = 0.8


def _warm() -> int:
    """Import what a walk needs, as a task (the worker's first walk would pay for it)."""
    import walker_campaign.execution
    import walker_campaign.walks  # noqa: F401
    return os.getpid()


def measure(ray_campaign, tasks, document) -> dict:
    """Walk ``tasks`` on a connected :class:`RayCampaign`; return the pace and the outcomes."""
    import ray

    warm = ray.remote(num_cpus=1)(_warm)
    ray.get([warm.remote() for _ in range(max(1, ray_campaign.cpus))])
    finished: list[float] = []
    outcomes: dict[str, int] = {}
    nodes: set[str] = set()

    errors: list[str] = []

    def on_rows(rows):
        if rows[-1]['outcome'] == 'error':
            errors.append(rows[-1]['message'])
        finished.append(time.monotonic())
        outcomes[rows[-1]['outcome']] = outcomes.get(rows[-1]['outcome'], 0) + 1
        nodes.add(rows[-1].get('exec.node', ''))

    load_before = os.getloadavg()
    started = time.monotonic()
    lost = ray_campaign.run(tasks, document, on_rows)
    wall = time.monotonic() - started
    if errors:
        raise RuntimeError(f'{len(errors)} walks could not be carried out, so there is no pace '
                           f'to measure; the first: {errors[0]}')
    return {'walks': len(finished), 'lost': len(lost), 'wall_s': round(wall, 2),
            'walks_per_hour': round(3600.0 * len(finished) / wall, 1) if wall > 0 else None,
            'outcomes': outcomes, 'nodes': len(nodes), 'cpus': ray_campaign.cpus,
            'load_average_before': [round(x, 2) for x in load_before],
            'load_average_after': [round(x, 2) for x in os.getloadavg()]}


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(('127.0.0.1', 0))
        return probe.getsockname()[1]


def _ray_start(args: list[str], log: Path, token: str) -> subprocess.Popen:
    command = [sys.executable, '-m', 'walker_campaign.ray_node', '--block',
               '--node-ip-address', '127.0.0.1', '--num-cpus', '1', '--object-store-memory',
               str(80 * 2**20), '--disable-usage-stats', *args]
    return subprocess.Popen(command, stdout=open(log, 'w'), stderr=subprocess.STDOUT,
                            start_new_session=True,
                            env=dict(os.environ, RAY_USAGE_STATS_ENABLED='0',
                                     RAY_AUTH_MODE='token', RAY_AUTH_TOKEN=token))


def _wait_for(log: Path, text: str, process: subprocess.Popen, timeout: float) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if text in log.read_text(errors='replace'):
            return
        if process.poll() is not None:
            break
        time.sleep(0.5)
    raise RuntimeError(f'ray start did not come up; its output:\n{log.read_text()[-2000:]}')


def _stop(process: subprocess.Popen) -> None:
    for sig in (signal.SIGTERM, signal.SIGKILL):
        try:
            os.killpg(process.pid, sig)
        except ProcessLookupError:
            return
        try:
            process.wait(timeout=15)
            return
        except subprocess.TimeoutExpired:
            continue


def two_node_cluster(tasks, document) -> dict:
    """Start a head and a worker node on loopback, walk on them, stop them."""
    from walker_campaign.ray_runner import RayCampaign

    scratch = Path(tempfile.mkdtemp(prefix='wr-bench-'))
    port = _free_port()
    token = os.environ.get('RAY_AUTH_TOKEN') or secrets.token_hex(32)  # read once by Ray
    head = _ray_start(['--head', '--port', str(port), '--include-dashboard', 'false',
                       '--temp-dir', str(scratch / 'head')], scratch / 'head.log', token)
    worker = None
    try:
        _wait_for(scratch / 'head.log', 'Ray runtime started', head, 180)
        worker = _ray_start(['--address', f'127.0.0.1:{port}', '--temp-dir',
                             str(scratch / 'worker')], scratch / 'worker.log', token)
        _wait_for(scratch / 'worker.log', 'Ray runtime started', worker, 180)
        os.environ.update(RAY_AUTH_MODE='token', RAY_AUTH_TOKEN=token)  # the driver's
        with RayCampaign(address=f'127.0.0.1:{port}') as ray_campaign:
            deadline = time.monotonic() + 60
            while ray_campaign.cpus < 2 and time.monotonic() < deadline:
                time.sleep(0.5)
            return measure(ray_campaign, tasks, document)
    finally:
        for process in (worker, head):
            if process is not None:
                _stop(process)
        shutil.rmtree(scratch, ignore_errors=True)


def main() -> int:
    """Measure, print the table, write the JSON; return the exit code."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--walks', type=int, default=6, help='walks per configuration')
    parser.add_argument('--spec', default='default_walk', help='campaign spec (name or path)')
    parser.add_argument('--walk', default=None, help='walk function (default: the campaign '
                                                     "runner's)")
    args = parser.parse_args()
    walker_env.reexec_in_environment(os.path.abspath(__file__), sys.argv[1:])
    from bench_support import NOISE_NOTE, machine_info, write_json
    from walker_campaign.campaign import DEFAULT_WALK
    from walker_campaign.core.plan import plan_run
    from walker_campaign.core.spec import find_spec, load_spec
    from walker_campaign.execution import RunTask
    from walker_campaign.ray_runner import RayCampaign

    spec = load_spec(find_spec(args.spec))
    walk = args.walk or DEFAULT_WALK
    tasks = [RunTask(spec.name, plan_run(spec, i), spec.target, spec.walk_timeout, walk)
             for i in range(min(args.walks, spec.total_runs))]
    results = {'machine': machine_info(), 'note': NOISE_NOTE, 'spec': spec.name,
               'target': spec.target, 'walk': walk, 'walks_per_configuration': len(tasks),
               'configurations': {}}
    for name, workers in (('local_1_worker', 1), ('local_2_workers', 2)):
        print(f'[campaign benchmark] {name}: {len(tasks)} walks', flush=True)
        with RayCampaign(workers=workers) as ray_campaign:
            results['configurations'][name] = measure(ray_campaign, tasks, spec.document)
    print(f'[campaign benchmark] two_node_cluster: {len(tasks)} walks', flush=True)
    results['configurations']['two_node_cluster'] = two_node_cluster(tasks, spec.document)
    pace = {k: v['walks_per_hour'] for k, v in results['configurations'].items()}
    for name in ('local_2_workers', 'two_node_cluster'):
        if pace['local_1_worker'] and pace[name]:
            results[f'scaling_efficiency_{name}'] = round(
                pace[name] / (2 * pace['local_1_worker']), 3)
    results['target_efficiency'] = TARGET_EFFICIENCY
    results['machine']['load_average_after_1_5_15'] = [round(x, 2) for x in os.getloadavg()]
    write_json(RESULTS, results)
    print(f'{"configuration":<20} {"walks":>5} {"wall s":>8} {"walks/h":>8} {"efficiency":>10}')
    for name, figures in results['configurations'].items():
        efficiency = results.get(f'scaling_efficiency_{name}', '')
        print(f'{name:<20} {figures["walks"]:>5} {figures["wall_s"]:>8} '
              f'{figures["walks_per_hour"]:>8} {efficiency!s:>10}')
    print(f'target: scaling efficiency >= {TARGET_EFFICIENCY} from 1 to 2 workers; load average '
          f'{results["machine"]["load_average_1_5_15"]} before, '
          f'{results["machine"]["load_average_after_1_5_15"]} after; written to {RESULTS}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
