#!/usr/bin/env python3
"""Where the sim-time graph's CPU goes: messages per simulated second, and py-spy profiles.

Usage::

    python3 benchmarks/graph_census.py                 # the graph composed (loop by call)
    python3 benchmarks/graph_census.py --processes     # a process per node
    python3 benchmarks/graph_census.py --five-controllers   # composed, five controller nodes

It brings a walker's sim-time graph up as ``benchmarks/graph_runner.py`` does, keeps it walking
back and forth, then for ``--seconds``:

1. counts the messages of every topic of the walker's namespace and the global ones
   (``/clock``, ``/tf``, ``/diagnostics``, ...), taken serialised (``raw=True``, never
   deserialised) by a hidden node in this process, per simulated second (the plant's
   ``/clock`` gives the simulated time), with each topic's subscribers by node;
2. samples every graph process with py-spy (``benchmarks/profiling.py``), two at a time, and
   gives per process its CPU share and where its busy samples go by category.

Prints the two tables and writes ``benchmarks/results/graph_census.json``. The census's own
subscriptions add a reader to every topic: a little publishing cost, for the figures' sake.
"""

from __future__ import annotations

import argparse
import collections
import importlib
import os
import sys
import tempfile
import threading
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / 'scripts'))
sys.path.insert(0, str(HERE))

import walker_env  # noqa: E402

RESULTS = HERE / 'results' / 'graph_census.json'


def _arguments() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    form = parser.add_mutually_exclusive_group()
    form.add_argument('--processes', action='store_true', help='a process per node')
    form.add_argument('--five-controllers', action='store_true',
                      help='composed, with the five controller nodes exchanging messages')
    parser.add_argument('--seconds', type=float, default=15.0, help='census window [s]')
    parser.add_argument('--no-profile', dest='profile', action='store_false',
                        help='skip the py-spy profiles')
    parser.add_argument('--output', type=Path, default=RESULTS)
    return parser.parse_args()


def census(context, namespace: str, seconds: float) -> dict:
    """Count every topic's messages for ``seconds``; per simulated second, with subscribers."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import qos_profile_sensor_data
    from rosgraph_msgs.msg import Clock

    from walker_runtime.spinning import helper_node

    def get_message(type_name: str):
        package, kind, name = type_name.split('/')
        module = importlib.import_module(f'{package}.{kind}')
        if kind == 'action' and '_' in name:  # an action's own topics (feedback, status)
            action, _, part = name.partition('_')
            return getattr(getattr(module, action).Impl, part)
        return getattr(module, name)

    node = helper_node('walker_graph_census', namespace, context)
    counts: collections.Counter = collections.Counter()
    clock = []
    topics = {name: types[0] for name, types in node.get_topic_names_and_types()
              if name.startswith(namespace + '/') or name.count('/') == 1}
    for name, type_name in topics.items():
        qos = qos_profile_sensor_data
        node.create_subscription(get_message(type_name), name,
                                 lambda _, n=name: counts.__setitem__(n, counts[n] + 1),
                                 qos, raw=True)
    node.create_subscription(Clock, '/clock', lambda m: clock.append(
        m.clock.sec + m.clock.nanosec * 1e-9), qos_profile_sensor_data)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    end = time.monotonic() + seconds
    while time.monotonic() < end and rclpy.ok(context=context):
        executor.spin_once(timeout_sec=0.1)
    simulated = (clock[-1] - clock[0]) if len(clock) > 1 else float('nan')
    rows = {}
    for name in sorted(topics):
        readers = [f'{i.node_namespace.rstrip("/")}/{i.node_name}'
                   for i in node.get_subscriptions_info_by_topic(name)
                   if not i.node_name.startswith('_walker_graph_census')]
        rows[name] = {'type': topics[name], 'messages': counts[name],
                      'per_sim_second': round(counts[name] / simulated, 1),
                      'subscribers': sorted(readers)}
    executor.remove_node(node)
    node.destroy_node()
    return {'simulated_s': round(simulated, 3), 'wall_s': seconds, 'topics': rows}


def profiles(pids: dict[str, int], seconds: float, scratch: Path) -> dict:
    """py-spy samples of every process, two at a time (the samplers take a core at most)."""
    from profiling import categorise, record, top_functions

    result = {}
    names = sorted(pids)
    for pair in (names[i:i + 2] for i in range(0, len(names), 2)):
        files = {n: scratch / (n.strip('/').replace('/', '_') + '.txt') for n in pair}
        recorders = {n: record(pids[n], seconds, files[n]) for n in pair}
        for name, recorder in recorders.items():
            recorder.communicate()
            if files[name].exists():
                result[name] = {**categorise(files[name]),
                                'top_walker_functions': top_functions(files[name], 15)}
    return result


def main() -> int:
    """Bring the graph up walking, count and profile, print and write; exit 0."""
    walker_env.reexec_in_environment(os.path.abspath(__file__), sys.argv[1:])
    args = _arguments()
    from bench_support import CpuMeter, machine_info, write_json
    from graph_runner import GraphRun, Walking, back_and_forth_targets

    composed = not args.processes
    grouped = composed and not args.five_controllers
    scratch = Path(tempfile.mkdtemp(prefix='walker_graph_census_'))
    kind = ('processes' if args.processes else 'composed_five_controllers'
            if args.five_controllers else 'composed')
    document = {'machine': machine_info(), 'arrangement': kind}
    with GraphRun(scratch, 1, composed, True, grouped=grouped) as run:
        with Walking(run, [back_and_forth_targets(s) for _, s, _ in run.graphs]):
            time.sleep(5.0)
            meter = CpuMeter(run.pids())
            meter.start()
            counted = {}
            thread = threading.Thread(target=lambda: counted.update(
                census(run.context, run.graphs[0][0], args.seconds)))
            thread.start()
            thread.join()
            document['cpu'] = meter.stop()
            document['census'] = counted
            if args.profile:
                document['profiles'] = profiles(run.pids(), args.seconds, scratch)
    document['machine']['load_average_after'] = [round(x, 2) for x in os.getloadavg()]
    write_json(args.output.with_name(f'{args.output.stem}_{kind}.json'), document)
    _print(document)
    return 0


def _print(document: dict) -> None:
    counted = document['census']
    print(f'{document["arrangement"]}: {counted["simulated_s"]} s simulated in '
          f'{counted["wall_s"]:g} s; CPU ' + ', '.join(
              f'{n.rsplit("/", 1)[-1]} {100 * c:.0f} %'
              for n, c in sorted(document['cpu']['cpu_fraction'].items(), key=lambda i: -i[1])))
    print(f'{"topic":48} {"msgs / sim s":>12}  subscribers')
    for name, row in sorted(counted['topics'].items(), key=lambda i: -i[1]['per_sim_second']):
        readers = ', '.join(r.rsplit('/', 1)[-1] for r in row['subscribers'])
        print(f'{name:48} {row["per_sim_second"]:12.1f}  {readers}')
    for name, profile in document.get('profiles', {}).items():
        print(f'{name}: idle {100 * (profile["idle_share"] or 0):.0f} %; busy: '
              + ', '.join(f'{c} {100 * s:.0f} %' for c, s in profile['shares'].items()))
        for function, share in profile['top_walker_functions'][:10]:
            print(f'    {100 * share:5.1f} %  {function}')


if __name__ == '__main__':
    sys.exit(main())
