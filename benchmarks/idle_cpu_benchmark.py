#!/usr/bin/env python3
"""CPU the idle graph takes, and how long a ROS tool waits beside it, by scheduling mode.

Usage: ``python3 benchmarks/idle_cpu_benchmark.py [--duration SECONDS] [--probes N]``. The graph
``run_all.py --serve`` brings up (plant, five controllers, planner, supervisor, recorder, viz),
as separate processes, is measured while it stands still, in three modes:

* ``sim_time``: lock-stepped on the plant's clock (``--sim-time``);
* ``real_time``: on the wall clock under the default scheduler (what ``run_all.py`` does
  unless asked);
* ``real_time_fifo``: on the wall clock with the loop under ``SCHED_FIFO`` 50 and the
  deciders at 40 (``run_all.py --realtime``), when this process may ask for it.

For each: the CPU of every node process over ``--duration`` seconds (fraction of one core;
the machine's cores bound the total), and the wall time a fresh tool process takes to start
rclpy and list the graph's nodes (``ros2 node list``'s work: discovery included), ``--probes``
times, while the graph runs. Results go to ``benchmarks/results/idle_cpu.json``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO_ROOT / 'scripts'))
sys.path.insert(0, str(REPO_ROOT / 'benchmarks'))
sys.path.insert(0, str(REPO_ROOT / 'tests'))

import walker_env  # noqa: E402

walker_env.reexec_in_environment(os.path.abspath(__file__), sys.argv[1:])

from bench_support import (  # noqa: E402
    NOISE_NOTE, RESULTS, CpuMeter, machine_info, write_json)
from ros_test_support import (  # noqa: E402
    isolated_domain, realtime_permitted, ros_environment)

SETTLE = 5.0  # [s] after the graph is ready, before measuring
START_TIMEOUT = 180.0  # [s]
#: What a ROS tool does first: start, join the graph, see its nodes.
PROBE = """
import time, rclpy
from rclpy.node import Node
rclpy.init()
node = Node('_idle_probe', start_parameter_services=False)
deadline = time.monotonic() + 60.0
while time.monotonic() < deadline:
    names = [n for n, ns in node.get_node_names_and_namespaces() if ns == '/walker']
    if 'supervisor' in names and 'plant' in names:
        break
    time.sleep(0.05)
print(len(names))
"""
MODES = {'sim_time': (True, 0), 'real_time': (False, 0), 'real_time_fifo': (False, 50)}


def measure(mode: str, duration: float, probes: int) -> dict:
    """Bring the graph up in ``mode``, measure it idle, shut it down."""
    from walker_bringup.graph import walker_graph
    from walker_bringup.graph_client import GraphClient, init_context
    from walker_bringup.processes import ProcessGroup
    from walker_core.robot_parameters import default_parameter_file

    sim_time, priority = MODES[mode]
    parameters = (('timing.realtime_priority', str(priority)),) if priority else ()
    with tempfile.TemporaryDirectory() as folder, isolated_domain() as domain:
        env = ros_environment(domain)
        nodes = walker_graph(default_parameter_file(), sim_time=sim_time, record=True,
                             bag_path=Path(folder) / 'bag', parameters=parameters)
        group = ProcessGroup(Path(folder) / 'logs', env)
        for spec in nodes:
            group.start(spec)
        context = init_context(domain)
        client = GraphClient('/walker', context)
        try:
            client.wait_until_ready([n.full_name for n in nodes], START_TIMEOUT)
            client.close()
            time.sleep(SETTLE)
            meter = CpuMeter({p.spec.name: p.popen.pid for p in group.processes})
            meter.start()
            waits = []
            for _ in range(probes):
                started = time.monotonic()
                subprocess.run([sys.executable, '-c', PROBE], env=env, check=True,
                               capture_output=True, timeout=300)
                waits.append(time.monotonic() - started)
            time.sleep(max(0.0, duration - (time.monotonic() - meter._started)))
            cpu = meter.stop()
        finally:
            context.try_shutdown()
            group.stop_all()
    return {'cpu': cpu, 'tool_start_and_list_s': {
        'median': round(statistics.median(waits), 3), 'max': round(max(waits), 3),
        'count': len(waits)}}


def main() -> int:
    """Measure each mode and print a table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--duration', type=float, default=20.0,
                        help='seconds each idle graph is measured (default: %(default)s)')
    parser.add_argument('--probes', type=int, default=3,
                        help='tool processes started beside each graph (default: %(default)s)')
    args = parser.parse_args()
    results = {}
    for mode in MODES:
        if MODES[mode][1] and not realtime_permitted():
            results[mode] = {'skipped': 'SCHED_FIFO not permitted for this user'}
            continue
        results[mode] = measure(mode, args.duration, args.probes)
    print(f'{"mode":<16} {"graph CPU [% of a core]":>24} {"tool start+list [s]":>22}')
    for mode, result in results.items():
        if 'skipped' in result:
            print(f'{mode:<16} {"skipped: " + result["skipped"]:>47}')
            continue
        wait = result['tool_start_and_list_s']
        print(f'{mode:<16} {100 * result["cpu"]["cpu_fraction_total"]:>24.0f} '
              f'{wait["median"]:>12.2f} (max {wait["max"]:.2f})')
    write_json(RESULTS / 'idle_cpu.json', {
        'benchmark': 'idle_cpu', 'machine': machine_info(), 'note': NOISE_NOTE,
        'duration_s': args.duration, 'modes': results})
    return 0


if __name__ == '__main__':
    sys.exit(main())
