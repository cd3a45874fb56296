#!/usr/bin/env python3
"""Benchmark of the headless runner, against the plant alone and the sim-time graph, one run.

Usage::

    python3 benchmarks/headless_benchmark.py            # the default walk, graph windows
    python3 benchmarks/headless_benchmark.py --quick    # one step, shorter graph windows
    python3 benchmarks/headless_benchmark.py --no-graph # the headless runner and the plant
    python3 benchmarks/headless_benchmark.py --profile  # and cProfile's top functions
    python3 benchmarks/headless_benchmark.py --graph-only  # the graph rows alone, merged

It sets up the environment like the other scripts, prints a table and writes
``benchmarks/results/headless.json``. Measured side by side, in one process (one core):

1. The headless walk (:func:`walker_headless.runner.walk`) to ``--target`` from the parameter
   file's start, without a bag and with one (what ``run_all.py --headless`` records): simulated
   seconds per second of this process's CPU time in the loop, and per wall second (the
   machine's load shows in the difference). Median of ``--repeats`` walks each.
2. The plant core alone doing the same physics: the torques and gripper commands of the walk,
   captured period by period and replayed on a fresh
   :class:`~walker_sim.core.plant.WalkerPlant` (the plant is deterministic: the replay ends in
   the very state the walk ended in, which is checked). Its rate is the physical limit of the
   loop; the headless rate is quoted as a fraction of it. Within the replay, the CPU time of
   pybullet's ``stepSimulation`` alone is measured too: the engine's floor, which no Python
   around it can go below.
3. The sim-time graph walking back and forth (``benchmarks/graph_runner.py``, as
   ``run_benchmarks.py`` measures it), composed in one process (the plant and the grouped
   controllers exchanging by call, ``run_all.py --composed``'s form in sim time), the same
   with five controller nodes exchanging messages, and as separate processes: CPU-seconds of
   the graph per simulated second, and each process's share. ``--graph-only`` measures these
   alone and replaces only the graph rows of the results file.

Targets (issue 37): headless at least 10 x real time on one core and at least half the
plant-alone rate; the graph at least 3 x real time composed (at most 0.33 CPU-s per simulated
second) and 1 x as separate processes.
"""

from __future__ import annotations

import argparse
import cProfile
import json
import os
import pstats
import statistics
import sys
import tempfile
import time
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO_ROOT / 'scripts'))
sys.path.insert(0, str(REPO_ROOT / 'benchmarks'))

import walker_env  # noqa: E402

RESULTS = REPO_ROOT / 'benchmarks' / 'results' / 'headless.json'
TARGETS = {'headless_real_time_factor': 10.0, 'fraction_of_plant_alone': 0.5,
           'composed_real_time_factor': 3.0, 'processes_real_time_factor': 1.0}


def _arguments() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--target', default=None,
                        help='node to walk to (default: n4_3, five steps; --quick: n1_2)')
    parser.add_argument('--repeats', type=int, default=3, help='walks of each kind')
    parser.add_argument('--quick', action='store_true',
                        help='one step and shorter graph windows')
    parser.add_argument('--no-graph', dest='graph', action='store_false',
                        help='skip the sim-time graph windows')
    parser.add_argument('--graph-only', action='store_true',
                        help='only the graph windows; the other rows of --output are kept')
    parser.add_argument('--graph-seconds', type=float, default=None,
                        help='measured window of each graph arrangement [s] (default 40, '
                             '--quick 15)')
    parser.add_argument('--profile', action='store_true',
                        help="also profile one headless walk (cProfile's top functions)")
    parser.add_argument('--output', type=Path, default=RESULTS)
    return parser.parse_args()


class _Capture:
    """The torques and gripper commands of a headless walk, period by period."""

    def __init__(self) -> None:
        self.torques: list = []
        self.grippers: list[tuple[int, str, str]] = []  # (period, gripper, action)
        self.final = None

    def __enter__(self) -> '_Capture':
        from walker_headless.loop import RobotLoop
        from walker_sim.core.plant import WalkerPlant

        self._step, self._command = RobotLoop.step, WalkerPlant.command_gripper
        capture, step, command = self, self._step, self._command

        def captured_step(loop) -> None:
            capture.torques.append(loop.commands.torques(loop.stamp)[0].copy())
            step(loop)
            capture.final = loop.state.position.copy()

        def captured_command(plant, gripper: str, action: str):
            capture.grippers.append((len(capture.torques), gripper, action))
            return command(plant, gripper, action)

        RobotLoop.step, WalkerPlant.command_gripper = captured_step, captured_command
        return self

    def __exit__(self, *exc_info) -> None:
        from walker_headless.loop import RobotLoop
        from walker_sim.core.plant import WalkerPlant

        RobotLoop.step, WalkerPlant.command_gripper = self._step, self._command


def plant_alone(configuration, capture: _Capture) -> dict:
    """Replay a walk's torques and gripper commands on the plant core alone; time it."""
    import numpy as np

    from walker_sim.core.plant import WalkerPlant

    period = configuration.controllers.sample_time
    with WalkerPlant(*configuration.plant) as plant, _EngineClock() as engine:
        commands = iter(capture.grippers)
        pending = next(commands, None)
        began_cpu, began_wall = time.process_time(), time.perf_counter()
        state = plant.state()
        for k, torques in enumerate(capture.torques):
            while pending is not None and pending[0] == k:
                plant.command_gripper(pending[1], pending[2])
                pending = next(commands, None)
            state = plant.step(torques, period)
        cpu, wall = time.process_time() - began_cpu, time.perf_counter() - began_wall
    simulated = len(capture.torques) * period
    periods = len(capture.torques)
    return {'simulated_s': simulated, 'cpu_s': cpu, 'wall_s': wall,
            'real_time_factor_cpu': simulated / cpu, 'real_time_factor_wall': simulated / wall,
            'us_per_period_cpu': cpu / periods * 1e6,
            'engine_cpu_s': engine.cpu, 'engine_steps': engine.steps,
            'engine_us_per_period_cpu': engine.cpu / periods * 1e6,
            'engine_us_per_step_cpu': engine.cpu / max(1, engine.steps) * 1e6,
            'same_final_state': bool(np.array_equal(state.position, capture.final))}


class _EngineClock:
    """CPU time spent inside ``pybullet.stepSimulation`` while in use (the engine's floor)."""

    def __init__(self) -> None:
        self.cpu = 0.0
        self.steps = 0

    def __enter__(self) -> '_EngineClock':
        import pybullet

        self._step = step = pybullet.stepSimulation
        clock, meter = time.process_time, self

        def timed(*args, **kwargs):
            began = clock()
            result = step(*args, **kwargs)
            meter.cpu += clock() - began
            meter.steps += 1
            return result

        pybullet.stepSimulation = timed
        return self

    def __exit__(self, *exc_info) -> None:
        import pybullet

        pybullet.stepSimulation = self._step


def headless_walk(configuration, target: str, record: bool, scratch: Path) -> dict:
    """One headless walk; its speed on one core and on the wall clock."""
    from walker_headless.recording import WalkRecording
    from walker_headless.runner import walk

    recording = WalkRecording(Path(tempfile.mkdtemp(dir=scratch)) / 'bag') if record else None
    try:
        result = walk(configuration, target, recording)
    finally:
        if recording is not None:
            recording.close()
    loop_wall = result.wall_time  # set-up included
    return {'reached': result.reached, 'steps': result.steps_taken,
            'simulated_s': result.sim_time, 'cpu_s': result.cpu_time, 'wall_s': loop_wall,
            'real_time_factor_cpu': result.sim_time / result.cpu_time,
            'real_time_factor_wall': result.sim_time / loop_wall,
            'us_per_period_cpu': result.cpu_time / max(1, result.periods) * 1e6}


def profile_walk(configuration, target: str, count: int = 20) -> list[dict]:
    """Profile one headless walk (no bag); the functions costing most, by their own time."""
    from walker_headless.runner import walk

    profiler = cProfile.Profile()
    profiler.enable()
    walk(configuration, target)
    profiler.disable()
    stats = pstats.Stats(profiler)
    total = sum(row[2] for row in stats.stats.values())
    rows = sorted(stats.stats.items(), key=lambda item: item[1][2], reverse=True)[:count]
    return [{'function': f'{name} ({Path(file).parent.name}/{Path(file).name}:{line})',
             'calls': row[1], 'own_share': row[2] / total, 'cumulative_share': row[3] / total}
            for (file, line, name), row in rows]


#: The graph's arrangements measured: (key, GraphRun options).
GRAPH_ARRANGEMENTS = (('composed', {'composed': True, 'grouped': True}),
                      ('composed_five_controllers', {'composed': True}),
                      ('processes', {}))


def graph_windows(seconds: float, scratch: Path) -> dict:
    """Measure the sim-time graph walking in each arrangement: CPU per sim second."""
    from run_benchmarks import Suite

    suite = Suite(argparse.Namespace(quick=False, soak=None), scratch)
    windows = {}
    for kind, options in GRAPH_ARRANGEMENTS:
        window = suite.window(sim_time=True, walking=True, seconds=seconds, warmup=5.0,
                              **options)
        walker = window['per_walker'][0]
        cost = walker['cpu_seconds_per_sim_second']
        loop = walker['loop']
        windows[kind] = {'cpu_seconds_per_sim_second': cost,
                         'real_time_factor_cpu': 1.0 / cost if cost else None,
                         'real_time_factor_wall': loop.get('real_time_factor'),
                         'round_trip_ms': loop.get('all_five_latency'),
                         'cpu_fraction': walker['cpu_fraction'],
                         'cpu_fraction_by_process': window['usage']['cpu_fraction'],
                         'walks_completed': walker['walks_completed'],
                         'safe_holds': walker['safe_holds'],
                         'load_average': window['load_average'], 'errors': window['errors']}
    return windows


def _keep_graph(path: Path, document: dict) -> None:
    """Carry the graph's part of an earlier result file over (``--no-graph`` measures none)."""
    import json

    try:
        earlier = json.loads(path.read_text())
    except (OSError, ValueError):
        return
    if 'graph' in earlier:
        document['graph'] = earlier['graph']
        document['graph_machine'] = earlier.get('graph_machine', earlier.get('machine'))


def _median(runs: list[dict], key: str) -> float:
    return statistics.median(run[key] for run in runs)


def headless_rows(args: argparse.Namespace, target: str, machine: dict, scratch: Path) -> dict:
    """Measure the headless walks and the plant alone, interleaved; their document."""
    from walker_config.core.configuration import load_configuration

    configuration = load_configuration()
    print(f'[benchmark] headless walks to {target}, {args.repeats} of each kind, load average '
          f'{machine["load_average_1_5_15"][0]:.2f}', flush=True)
    bare, recorded, alone = [], [], []
    for _ in range(args.repeats):  # interleaved: each kind sees the same load
        with _Capture() as capture:
            bare.append(headless_walk(configuration, target, False, scratch))
        alone.append(plant_alone(configuration, capture))
        recorded.append(headless_walk(configuration, target, True, scratch))
    plant_rate = _median(alone, 'real_time_factor_cpu')
    document = {
        'machine': machine, 'target': target, 'repeats': args.repeats,
        'headless': {'walks': bare}, 'headless_with_bag': {'walks': recorded},
        'plant_alone': {'runs': alone}, 'targets': TARGETS}
    engine = [{'real_time_factor_cpu': run['simulated_s'] / run['engine_cpu_s'],
               'us_per_period_cpu': run['engine_us_per_period_cpu']} for run in alone]
    document['engine_alone'] = {'runs': engine, 'us_per_step_cpu': _median(
        alone, 'engine_us_per_step_cpu')}
    for key, runs in (('headless', bare), ('headless_with_bag', recorded),
                      ('plant_alone', alone), ('engine_alone', engine)):
        document[key].update({
            'real_time_factor_cpu': _median(runs, 'real_time_factor_cpu'),
            'real_time_factor_wall': (_median(runs, 'real_time_factor_wall')
                                      if key != 'engine_alone' else None),
            'us_per_period_cpu': _median(runs, 'us_per_period_cpu'),
            'fraction_of_plant_alone': _median(runs, 'real_time_factor_cpu') / plant_rate})
    if args.profile:
        document['profile'] = profile_walk(configuration, target)
    return document


def main() -> int:
    """Measure, print the table, write the JSON; exit 0 (targets are reported, not enforced)."""
    walker_env.reexec_in_environment(os.path.abspath(__file__), sys.argv[1:])
    args = _arguments()
    from bench_support import machine_info, write_json

    target = args.target or ('n1_2' if args.quick else 'n4_3')
    machine = machine_info()
    scratch = Path(tempfile.mkdtemp(prefix='walker_headless_bench_'))
    if args.graph_only:
        if not args.output.exists():
            print(f'[benchmark] --graph-only: {args.output} does not exist; run without '
                  '--graph-only first', file=sys.stderr)
            return 2
        document = json.loads(args.output.read_text())
        document['graph_machine'] = machine
    else:
        document = headless_rows(args, target, machine, scratch)
    if args.graph:
        seconds = args.graph_seconds or (15.0 if args.quick else 40.0)
        print(f'[benchmark] the sim-time graph walking: {seconds:g} s windows', flush=True)
        document['graph'] = graph_windows(seconds, scratch)
    elif not args.graph_only:  # the graph's figures come from their own run: kept as found
        _keep_graph(args.output, document)
    document['graph_machine' if args.graph_only else 'machine']['load_average_after'] = [
        round(x, 2) for x in os.getloadavg()]
    write_json(args.output, document)
    _print_table(document)
    print(f'[benchmark] results in {args.output}')
    return 0


def _print_table(document: dict) -> None:
    rows = [('what', 'x real time (CPU)', 'x real time (wall)', 'us / period (CPU)',
             'of plant alone', 'target')]
    for key, name, target in (
            ('engine_alone', 'pybullet stepSimulation alone (in the replay)', ''),
            ('plant_alone', 'plant core alone (same physics)', ''),
            ('headless', 'headless walk, no bag', '>= 10 x; >= 0.5 of plant'),
            ('headless_with_bag', 'headless walk, with its bag', '')):
        row = document[key]
        wall = row['real_time_factor_wall']
        rows.append((name, f'{row["real_time_factor_cpu"]:.1f}',
                     f'{wall:.1f}' if wall is not None else '-',
                     f'{row["us_per_period_cpu"]:.0f}',
                     f'{row["fraction_of_plant_alone"]:.2f}', target))
    for kind, target in (('composed', '>= 3 x'), ('composed_five_controllers', ''),
                         ('processes', '>= 1 x')):
        window = document.get('graph', {}).get(kind)
        if window is None:
            continue
        cost = window['cpu_seconds_per_sim_second']
        rows.append((f'graph {kind.replace("_", " ")}, sim time walking',
                     f'{window["real_time_factor_cpu"]:.2f}' if cost else '-',
                     f'{window["real_time_factor_wall"]:.2f}'
                     if window['real_time_factor_wall'] else '-',
                     f'{cost:.2f} CPU-s per sim s' if cost else '-', '', target))
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    for k, row in enumerate(rows):
        print('  '.join(cell.ljust(w) for cell, w in zip(row, widths, strict=True)))
        if k == 0:
            print('  '.join('-' * w for w in widths))
    for kind, window in document.get('graph', {}).items():
        shares = sorted(window['cpu_fraction_by_process'].items(), key=lambda item: -item[1])
        print(f'{kind}: ' + ', '.join(f'{name.rsplit("/", 1)[-1]} {100 * share:.0f} %'
                                      for name, share in shares)
              + (f'; errors: {window["errors"]}' if window['errors'] else ''))
    same = all(run['same_final_state'] for run in document['plant_alone']['runs'])
    print(f"the replay on the plant alone ends in the walk's final state: {same}")
    for entry in document.get('profile', [])[:12]:
        print(f'  {100 * entry["own_share"]:5.1f} %  {entry["function"]}')


if __name__ == '__main__':
    sys.exit(main())
