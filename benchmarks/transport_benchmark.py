#!/usr/bin/env python3
"""Fast DDS over shared memory or UDP on loopback: deaf readers after faults, and the cost.

Usage: ``python3 benchmarks/transport_benchmark.py [--cycles N] [--duration SECONDS]``.

Two processes, :mod:`walker_bringup.transport_probe`'s talker and listener (500 Hz, the QoS of
``joint_states`` and of the commands), in a ROS domain of their own, on each transport: the rmw
default (``shm``: shared memory between processes of one machine) and the UDP-on-loopback
profile of :mod:`walker_bringup.transport` (``udp``); the listener with plain subscriptions
(``plain``) or the walker's watched ones (``watched``, made anew after 0.5 s of silence while
the talker is in the graph). For each, ``--cycles`` times each fault:

* ``kill_talker``, ``kill_listener``: ``SIGKILL``, and the process started again at once;
* ``freeze_talker``, ``freeze_listener``: ``SIGSTOP`` for ``--freeze`` seconds, then
  ``SIGCONT``;
* ``port_removed``: the listener's Fast DDS files removed from ``/dev/shm`` (what a clean-up of
  "leftover" files does to a live process), then the talker killed and started again (a fresh
  pair each cycle).

A cycle ends deaf when the listener has not heard both topics again ``--deaf-after`` seconds
after the fault (after the restart or the ``SIGCONT``); otherwise its time to hear again is
kept. Then, per transport, the cost on the 500 Hz path: the latency of every state (stamp to
the listener's callback, wall clock) and the CPU of both processes over ``--duration`` seconds,
measured one transport after the other in the same run. Results:
``benchmarks/results/transport.json``.
"""

from __future__ import annotations

import argparse
import os
import statistics
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

import numpy as np  # noqa: E402
from bench_support import (  # noqa: E402
    NOISE_NOTE, RESULTS, CpuMeter, machine_info, percentiles_ms, write_json)
from ros_test_support import isolated_domain, ros_environment  # noqa: E402
from transport_faults import (  # noqa: E402
    ProbePair, fastdds_files, remove_shared_memory_files)

from walker_bringup.processes import stale_shared_memory_files  # noqa: E402
from walker_bringup.transport import udp_loopback_environment  # noqa: E402

TRANSPORTS = ('shm', 'udp')
LISTENERS = {'plain': 0.0, 'watched': 0.5}  # the listener's --renew-after [s]
FAULTS = ('kill_talker', 'kill_listener', 'freeze_talker', 'freeze_listener', 'port_removed')
START = 60.0  # [s] for a pair to start and be heard, on a loaded machine


def _environment(domain: int, transport: str) -> dict[str, str]:
    env = ros_environment(domain)
    return udp_loopback_environment(env) if transport == 'udp' else env


def _inject(pair: ProbePair, fault: str, freeze: float) -> float:
    """Inject ``fault`` into ``pair``; return the steady time the listener may hear from."""
    if fault.startswith('kill_'):
        return pair.kill_and_restart(fault.removeprefix('kill_'))
    if fault.startswith('freeze_'):
        return pair.freeze(fault.removeprefix('freeze_'), freeze)
    remove_shared_memory_files(pair.listener.process.pid)
    return pair.kill_and_restart('talker')


def run_cycles(env: dict, renew_after: float, fault: str, cycles: int, freeze: float,
               deaf_after: float) -> list[float | None]:
    """Each cycle's time to hear again [s], None for a cycle that ended deaf."""
    outcomes: list[float | None] = []
    fresh_each_cycle = fault == 'port_removed'
    pair = None
    try:
        for _ in range(cycles):
            if pair is None:
                pair = ProbePair(env, renew_after)
                if pair.hears_again(time.monotonic(), START) is None:
                    raise RuntimeError('the probe never heard its talker:\n'
                                       + pair.listener.output)
            since = _inject(pair, fault, freeze)
            outcomes.append(pair.hears_again(since, deaf_after))
            deaf = outcomes[-1] is None
            if fresh_each_cycle or deaf:  # a deaf pair would count the same deafness again
                pair.__exit__(None, None, None)
                pair = None
    finally:
        if pair is not None:
            pair.__exit__(None, None, None)
    return outcomes


def summarise(outcomes: list[float | None]) -> dict:
    """Deaf count and the times to hear again of one set of cycles."""
    heard = [t for t in outcomes if t is not None]
    return {'cycles': len(outcomes), 'deaf': len(outcomes) - len(heard),
            'heard_again_s': [round(t, 3) for t in heard],
            'heard_again_median_s': round(statistics.median(heard), 3) if heard else None,
            'heard_again_max_s': round(max(heard), 3) if heard else None}


def measure_cost(env: dict, duration: float) -> dict:
    """Latency of every state and CPU of talker and listener over ``duration`` seconds."""
    with tempfile.TemporaryDirectory() as folder:
        latencies = Path(folder) / 'latencies.npy'
        with ProbePair(env, 0.0, latencies=latencies) as pair:
            if pair.hears_again(time.monotonic(), START) is None:
                raise RuntimeError(f'the probe never heard its talker:\n{pair.listener.output}')
            meter = CpuMeter({'talker': pair.talker.process.pid,
                              'listener': pair.listener.process.pid})
            meter.start()
            time.sleep(duration)
            cpu = meter.stop()
            first = pair.heard()[-1][1]
            pair.listener.stop()
        values = np.load(latencies)
    return {'cpu': cpu, 'states_latency': percentiles_ms(values),
            'states_received_by_window_end': first}


def main() -> int:
    """Run every transport, listener and fault; print the tables; write the JSON."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--cycles', type=int, default=3,
                        help='cycles of each fault per transport and listener (default: 3)')
    parser.add_argument('--freeze', type=float, default=3.0,
                        help='[s] each SIGSTOP lasts (default: 3)')
    parser.add_argument('--deaf-after', type=float, default=10.0,
                        help='[s] not heard again this long after a fault: deaf (default: 10)')
    parser.add_argument('--duration', type=float, default=20.0,
                        help="[s] each transport's cost is measured (default: 20)")
    args = parser.parse_args()
    if args.cycles < 1 or not (args.freeze > 0 and args.deaf_after > 0 and args.duration > 0):
        parser.error('--cycles must be at least 1 and the durations positive')
    before = fastdds_files()
    faults: dict = {}
    cost: dict = {}
    try:
        for transport in TRANSPORTS:
            for listener, renew_after in LISTENERS.items():
                for fault in FAULTS:
                    with isolated_domain() as domain:
                        outcomes = run_cycles(_environment(domain, transport), renew_after,
                                              fault, args.cycles, args.freeze, args.deaf_after)
                    faults.setdefault(transport, {}).setdefault(listener, {})[fault] = \
                        summarise(outcomes)
                    print(f'{transport:<4} {listener:<8} {fault:<16} '
                          f'{faults[transport][listener][fault]}', flush=True)
        for transport in TRANSPORTS:
            with isolated_domain() as domain:
                cost[transport] = measure_cost(_environment(domain, transport), args.duration)
    finally:
        for path in stale_shared_memory_files(before, min_age=0.0):
            path.unlink(missing_ok=True)
    _print_tables(faults, cost)
    write_json(RESULTS / 'transport.json', {
        'benchmark': 'transport', 'machine': machine_info(), 'note': NOISE_NOTE,
        'cycles': args.cycles, 'freeze_s': args.freeze, 'deaf_after_s': args.deaf_after,
        'duration_s': args.duration, 'rate_hz': 500.0, 'faults': faults, 'cost': cost})
    return 0


def _print_tables(faults: dict, cost: dict) -> None:
    print(f'\n{"fault":<16}' + ''.join(f'{t + " " + li:>22}' for t in faults
                                       for li in faults[t]))
    for fault in FAULTS:
        cells = []
        for transport in faults:
            for listener in faults[transport]:
                s = faults[transport][listener][fault]
                median = s['heard_again_median_s']
                cells.append(f'{s["deaf"]}/{s["cycles"]} deaf'
                             + (f', {median:.2f} s' if median is not None else ''))
        print(f'{fault:<16}' + ''.join(f'{c:>22}' for c in cells))
    print(f'\n{"transport":<10} {"latency median [ms]":>20} {"p99 [ms]":>10} '
          f'{"CPU talker+listener [% of a core]":>34}')
    for transport, result in cost.items():
        latency = result['states_latency']
        print(f'{transport:<10} {latency["median_ms"]:>20.3f} {latency["p99_ms"]:>10.3f} '
              f'{100 * result["cpu"]["cpu_fraction_total"]:>34.1f}')


if __name__ == '__main__':
    sys.exit(main())
