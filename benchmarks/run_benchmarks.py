#!/usr/bin/env python3
"""walker's benchmark suite: what users care about, measured in one run, one table, one file.

Usage::

    python3 benchmarks/run_benchmarks.py              # the whole suite, about ten minutes
    python3 benchmarks/run_benchmarks.py --quick      # shorter windows, fewer cases (~4 min)
    python3 benchmarks/run_benchmarks.py --only walk scaling
    python3 benchmarks/run_benchmarks.py --soak 10    # only the soak: 10 min of simulated walking
    python3 benchmarks/run_benchmarks.py --soak 10 --composed-loop   # the soak, loop composed
    python3 benchmarks/run_benchmarks.py --profile    # only the py-spy profiles

It sets up the environment like the other scripts, runs the parts, prints one table of the
figures with their targets, and writes ``benchmarks/results/summary.json`` (the table, the
machine, the load average before and after) and one JSON file per part in
``benchmarks/results/suite/``. ``docs/performance.md`` quotes ``summary.json``.

Parts (each brings up what it needs with :mod:`graph_runner`: the graph ``run_all.py``
starts, in a ROS domain of its own, discovery on loopback, the plant timed from the inside by
:mod:`loop_probe`):

* ``plant``: the plant core alone in sim time: real-time factor and cost of a control step.
* ``planner``: planning time per trajectory type, and the bang-bang solve alone.
* ``control_loop``: all the graph's processes up in real time (controllers holding), at
  500 Hz and 1 kHz: JointState-to-effort round trip (median, p99, max), missed periods, CPU.
* ``composition``: the same graph as separate processes, with the five joint controllers
  grouped in one process (``--grouped-controllers``), as one process, and with the loop (the
  plant and the grouped controllers) in one process (``--composed-loop``): the real-time loop
  at 500 Hz and 1 kHz, and a sim-time walking window (real-time factor, round trip); CPU and
  memory.
* ``walk``: a walk in sim time (the step reports: step time and its ratio to the time-optimal
  bound, tip error at insertion, residual vibration, walking speed; whole-graph CPU and peak
  memory), and one step in real time with the loop timed during it, as separate processes,
  with the controllers grouped and with the loop composed.
* ``scaling``: 1, 2 and 4 walkers (namespaces ``/walker``, ``/walker_2``, ...), each walking
  back and forth on the same truss layout (separate physics worlds: they do not collide), in
  sim time: per-walker real-time factor, round trip and CPU; and 1 and 2 walkers in real time;
  again with each walker's controllers grouped (1, 2 and 4 in real time).
* ``soak`` (only with ``--soak``): a long walk back and forth; memory, open files and shared
  memory over time, drift of the step figures.
* ``profile`` (only with ``--profile``): py-spy samples of the plant, a controller (or the
  controllers' node, grouped), the planner and the supervisor during a sim-time walk, and of
  the composed graph.

The numbers come from a 2-core virtual machine shared with other work: they are noisy, and
the load average is recorded beside them.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import sys
import tempfile
import time
import traceback
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(REPO / 'scripts'))
sys.path.insert(0, str(HERE))

import walker_env  # noqa: E402

PARTS = ('plant', 'planner', 'control_loop', 'composition', 'walk', 'scaling')
OPTIONAL = ('soak', 'profile')
#: Targets (issue 9).
TARGET_BOUND_RATIO = 1.25
WALK_BOUND_RATIO = 1.5  # the walking issue's target, each step's share against it is reported
TARGET_TIP_ERROR = 0.5e-3  # [m]
TARGET_REAL_TIME_FACTOR = 3.0
DEFAULT_TARGET = 'n4_3'     # the run_all.py default walk (5 steps)
QUICK_TARGET = 'n2_2'       # its first two steps
REAL_TIME_TARGET = 'n1_2'   # its first step


def _arguments(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--quick', action='store_true', help='shorter windows, fewer cases')
    parser.add_argument('--only', nargs='+', choices=PARTS + OPTIONAL, metavar='NAME',
                        help=f'run only these parts ({", ".join(PARTS + OPTIONAL)})')
    parser.add_argument('--soak', nargs='?', type=float, const=10.0, default=None,
                        metavar='MINUTES',
                        help='run only the soak: this many minutes of simulated walking '
                             '(default 10)')
    parser.add_argument('--profile', action='store_true', help='run only the py-spy profiles')
    parser.add_argument('--grouped-controllers', dest='grouped', action='store_true',
                        help="run the soak with the five joint controllers in one process "
                             "(run_all.py's --grouped-controllers)")
    parser.add_argument('--composed-loop', dest='loop', action='store_true',
                        help="run the soak with the plant and the grouped controllers in one "
                             "process, waiting for the supervisor's decisions (run_all.py's "
                             "--composed-loop)")
    parser.add_argument('--output', type=Path, default=HERE / 'results',
                        help='results directory (default: benchmarks/results)')
    args = parser.parse_args(argv)
    if args.soak is not None and not (math.isfinite(args.soak) and args.soak > 0):
        parser.error(f'--soak {args.soak}: expected a positive number of minutes')
    parts = list(args.only or [])
    if args.soak is not None:
        parts.append('soak')
    if args.profile:
        parts.append('profile')
    args.parts = parts or list(PARTS)
    return args


# ----------------------------------------------------------------------------- measuring
class Suite:
    """Runs the parts and shares what several of them need (a measured window is run once)."""

    def __init__(self, args: argparse.Namespace, scratch: Path) -> None:
        self.quick = args.quick
        self.soak_minutes = args.soak
        self.loop = getattr(args, 'loop', False)
        self.grouped = getattr(args, 'grouped', False) or self.loop
        self.scratch = scratch
        self._windows: dict[tuple, dict] = {}
        self._runs = 0

    def seconds(self, full: float, quick: float) -> float:
        """Return a window's length [s] in this mode."""
        return quick if self.quick else full

    def say(self, text: str) -> None:
        """Progress line."""
        print(f'[benchmark] {text}', flush=True)

    def window(self, *, sim_time: bool, walking: bool, walkers: int = 1,
               composed: bool = False, rate: float | None = None, seconds: float,
               warmup: float = 3.0, grouped: bool = False, loop: bool = False) -> dict:
        """Bring graphs up, measure a window (walking or holding), bring them down.

        Returns per walker the loop figures (:func:`bench_support.loop_statistics`), its CPU
        (sum over its processes, fraction of one core), its CPU per simulated second and its
        processes' peak memory; and the whole run's CPU and the time the graphs took to come up.
        """
        key = (sim_time, walking, walkers, composed, rate, seconds, grouped, loop)
        if key in self._windows:
            return self._windows[key]
        from bench_support import CpuMeter, loop_statistics
        from graph_runner import GraphRun, Walking, back_and_forth_targets

        self._runs += 1
        what = (f'{walkers} walker{"s" if walkers > 1 else ""}, '
                f'{"composed" if composed else "loop composed" if loop else "processes"}, '
                + ('controllers grouped, ' if grouped else '') +
                f'{"sim time" if sim_time else "real time"}'
                + (f', {rate:g} Hz' if rate else '') + (', walking' if walking else ', holding'))
        self.say(f'{what}: bringing up, then {warmup:g} s + {seconds:g} s measured')
        parameters = (('timing.control_rate', f'{float(rate)}'),) if rate else ()
        began = time.monotonic()
        walking_context = None
        with GraphRun(self.scratch / f'run{self._runs}', walkers, composed, sim_time,
                      parameters, grouped=grouped, loop=loop) as run:
            startup = time.monotonic() - began
            if walking:
                walking_context = Walking(run, [back_and_forth_targets(start)
                                                for _, start, _ in run.graphs])
                walking_context.__enter__()
            try:
                time.sleep(warmup)
                meter = CpuMeter(run.pids())
                meter.start()
                start_ns = time.monotonic_ns()
                time.sleep(seconds)
                end_ns = time.monotonic_ns()
                usage = meter.stop()
                died = run.died()
            finally:
                if walking_context is not None:
                    walking_context.__exit__(None, None, None)
            period_ns = run.period_ns
            graphs = list(run.graphs)
        per_walker = []
        for index, (namespace, start, _) in enumerate(graphs):
            events = run.events(index)
            loop = (loop_statistics(events, start_ns, end_ns, period_ns) if events is not None
                    else {'error': 'no loop probe: the plant did not end on its interrupt'})
            mine = {n: c for n, c in usage['cpu_fraction'].items()
                    if n.startswith(namespace + '/')}
            cpu = sum(mine.values())
            peak = sum(b for n, b in usage['peak_rss_bytes'].items()
                       if n.startswith(namespace + '/'))
            sim = loop.get('sim_seconds', 0.0)
            per_walker.append({
                'namespace': namespace,
                'start': [start.base_gripper, start.base_node, start.other_node],
                'loop': loop, 'cpu_fraction': round(cpu, 4),
                'cpu_seconds_per_sim_second': (round(cpu * usage['wall_s'] / sim, 4)
                                               if sim > 0 else None),
                'peak_rss_bytes': peak,
                'walks_completed': (len(walking_context.results[index])
                                    if walking_context else 0),
                'safe_holds': walking_context.holds[index] if walking_context else []})
        result = {'walkers': walkers, 'composed': composed, 'grouped': grouped,
                  'loop_composed': loop,
                  'sim_time': sim_time,
                  'rate_hz': rate or 1e9 / period_ns, 'walking': walking,
                  'startup_s': round(startup, 2), 'window_s': seconds,
                  'load_average': [round(x, 2) for x in os.getloadavg()],
                  'per_walker': per_walker, 'usage': usage,
                  'errors': (walking_context.errors if walking_context else [])
                  + (['a process exited during the window'] if died else [])
                  + [f'{w["namespace"]}: {w["loop"]["error"]}' for w in per_walker
                     if 'error' in w['loop']]}
        self._windows[key] = result
        self._report_window(what, result)
        return result

    def _report_window(self, what: str, result: dict) -> None:
        for walker in result['per_walker']:
            loop = walker['loop']
            rt = loop.get('all_five_latency', {})
            text = (f'  {walker["namespace"]}: round trip median '
                    f'{rt.get("median_ms", math.nan):.2f} / p99 {rt.get("p99_ms", math.nan):.2f}'
                    ' ms, ')
            text += (f'real-time factor {loop.get("real_time_factor", math.nan):.2f}'
                     if result['sim_time'] else
                     f'missed {100 * loop.get("missed_fraction", math.nan):.1f} % of '
                     f'{loop.get("states_published", 0)} periods')
            text += (f', CPU {100 * walker["cpu_fraction"]:.0f} %, peak memory '
                     f'{walker["peak_rss_bytes"] / 2**20:.0f} MiB')
            self.say(text)
        for error in result['errors']:
            self.say(f'  error: {error}')


# ----------------------------------------------------------------------------- the parts
def part_plant(suite: Suite) -> dict:
    """Measure the plant core alone, in sim time, and the accuracy of its physics settings.

    ``plant_benchmark.physics_benchmark`` and ``plant_benchmark.accuracy_benchmark``.
    """
    from plant_benchmark import accuracy_benchmark, physics_benchmark

    seconds = suite.seconds(10.0, 3.0)
    suite.say(f'plant core: {seconds:g} s simulated, moving and at rest; accuracy against a '
              'converged reference')
    return {**physics_benchmark(seconds), 'accuracy': accuracy_benchmark()}


def part_planner(suite: Suite) -> dict:
    """Planning time per trajectory type (``planner_benchmark.measure``)."""
    from planner_benchmark import measure

    runs = 30 if suite.quick else 200
    suite.say(f'planner: every case, {runs} runs (Cartesian plans a tenth)')
    return {'runs': runs, 'results': measure(runs, report=None), 'target_solve_ms': 5.0}


def part_control_loop(suite: Suite) -> dict:
    """Measure the whole graph in real time, controllers holding, at 500 Hz and 1 kHz."""
    seconds = suite.seconds(15.0, 6.0)
    return {str(rate): suite.window(sim_time=False, walking=False, rate=rate, seconds=seconds)
            for rate in (500.0, 1000.0)}


#: The graph's arrangements the composition part compares: a process per node; the five
#: joint controllers grouped in one node and process; the whole graph in one process; the
#: loop (the plant and the grouped controllers) in one process, exchanging by call in sim time.
ARRANGEMENTS = {'processes': {}, 'grouped': {'grouped': True}, 'composed': {'composed': True},
                'loop': {'loop': True}}


def part_composition(suite: Suite) -> dict:
    """Arrangements of the graph (:data:`ARRANGEMENTS`): real-time loop, sim-time walking."""
    real = suite.seconds(15.0, 6.0)
    sim = suite.seconds(40.0, 15.0)
    return {
        'real_time_500hz': {kind: suite.window(sim_time=False, walking=False, rate=500.0,
                                               seconds=real, **options)
                            for kind, options in ARRANGEMENTS.items()},
        'real_time_1000hz': {kind: suite.window(sim_time=False, walking=False, rate=1000.0,
                                                seconds=real, **options)
                             for kind, options in ARRANGEMENTS.items()},
        'sim_time_walking': {kind: suite.window(sim_time=True, walking=True, seconds=sim,
                                                warmup=5.0, **options)
                             for kind, options in ARRANGEMENTS.items()},
    }


def part_scaling(suite: Suite) -> dict:
    """Several walkers in one ROS graph: how per-walker cost and speed grow.

    As separate processes (the top-level keys) and with each walker's controllers grouped in
    one process (``grouped``).
    """
    result = _scaling(suite, grouped=False)
    result['grouped'] = _scaling(suite, grouped=True)
    return result


def _scaling(suite: Suite, grouped: bool) -> dict:
    sim = suite.seconds(40.0, 15.0)
    real = suite.seconds(15.0, 6.0)
    counts = (1, 2) if suite.quick else (1, 2, 4)
    result = {'sim_time_walking': {str(n): suite.window(sim_time=True, walking=True,
                                                        walkers=n, seconds=sim, warmup=5.0,
                                                        grouped=grouped)
                                   for n in counts},
              'real_time_holding': {str(n): suite.window(sim_time=False, walking=False,
                                                         walkers=n, rate=500.0, seconds=real,
                                                         grouped=grouped)
                                    for n in (counts if grouped else counts[:2])}}
    base = _mean([w['cpu_seconds_per_sim_second']
                  for w in result['sim_time_walking']['1']['per_walker']])
    growth = {}
    for n, window in result['sim_time_walking'].items():
        cost = _mean([w['cpu_seconds_per_sim_second'] for w in window['per_walker']])
        growth[n] = {'cpu_seconds_per_sim_second_per_walker': cost,
                     'relative_to_one_walker': round(cost / base, 3) if base and cost else None,
                     'real_time_factor_per_walker': _mean(
                         [w['loop'].get('real_time_factor') for w in window['per_walker']]),
                     'lockstep_timeouts': sum(w['loop'].get('lockstep_timeouts', 0)
                                              for w in window['per_walker']),
                     'errors': window['errors']}
    result['growth'] = growth
    return result


def _walk_once(suite: Suite, sim_time: bool, target: str, record: bool = True,
               grouped: bool = False, loop: bool = False) -> dict:
    from bench_support import CpuMeter, loop_statistics
    from graph_runner import GraphRun, walk_resuming
    from walker_bringup.summary import rows_from_reports

    suite._runs += 1
    suite.say(f'walk to {target} in {"sim" if sim_time else "real"} time (recorded'
              + (', loop composed)' if loop else ', controllers grouped)' if grouped else ')'))
    began = time.monotonic()
    with GraphRun(suite.scratch / f'run{suite._runs}', 1, False, sim_time, record=record,
                  grouped=grouped, loop=loop) as run:
        startup = time.monotonic() - began
        client = run.clients[0]
        meter = CpuMeter(run.pids())
        meter.start()
        start_ns = time.monotonic_ns()
        result, holds = walk_resuming(client, target, 1800.0, run.died)
        end_ns = time.monotonic_ns()
        usage = meter.stop()
        client.spin_for(0.5)
        reports = list(client.reports)
        period_ns = run.period_ns
    events = run.events(0)
    loop = (loop_statistics(events, start_ns, end_ns, period_ns) if events is not None
            else {'error': 'no loop probe: the plant did not end on its interrupt'})
    rows = rows_from_reports(reports)
    walking = sum(r.duration for r in rows)
    steps = []
    for row in rows:
        steps.append({'step': row.index + 1, 'from': row.from_node, 'to': row.to_node,
                      'sweep_deg': round(math.degrees(row.sweep)), 'success': row.success,
                      'phase_durations_s': row.phase_durations, 'duration_s': row.duration,
                      'bound_s': row.bound, 'bound_ratio': row.bound_ratio,
                      'insertion_error_m': row.insertion_error,
                      'insertion_error_estimated_m': row.insertion_error_estimated,
                      'residual_vibration_m': row.residual_vibration,
                      'attempts': row.attempts})
    wall = (end_ns - start_ns) / 1e9
    return {'target': target, 'sim_time': sim_time, 'grouped': grouped, 'loop_composed': loop,
            'reached': bool(result.success),
            'message': result.message, 'safe_holds': holds, 'steps': steps,
            'startup_s': round(startup, 2),
            'walking_s': walking, 'wall_s': round(wall, 2),
            'nodes_per_minute_walking': round(60 * len(rows) / walking, 3) if walking else None,
            'nodes_per_minute_wall': round(60 * len(rows) / wall, 3) if wall else None,
            'loop': loop, 'usage': usage,
            'load_average': [round(x, 2) for x in os.getloadavg()]}


def part_walk(suite: Suite) -> dict:
    """Walk in sim time, and one step in real time in three arrangements, from the reports."""
    sim = _walk_once(suite, True, QUICK_TARGET if suite.quick else DEFAULT_TARGET)
    _report_walk(suite, sim)
    real = _walk_once(suite, False, REAL_TIME_TARGET)
    _report_walk(suite, real)
    grouped = _walk_once(suite, False, REAL_TIME_TARGET, grouped=True)
    _report_walk(suite, grouped)
    loop = _walk_once(suite, False, REAL_TIME_TARGET, loop=True)
    _report_walk(suite, loop)
    return {'sim_time': sim, 'real_time': real, 'real_time_grouped': grouped,
            'real_time_loop': loop}


def _report_walk(suite: Suite, walk: dict) -> None:
    for step in walk['steps']:
        suite.say(f'  step {step["step"]} {step["from"]} -> {step["to"]}: '
                  f'{step["duration_s"]:.2f} s = {step["bound_ratio"]:.2f} x bound, insertion '
                  f'error {1e3 * step["insertion_error_m"]:.2f} mm, vibration '
                  f'{1e3 * step["residual_vibration_m"]:.2f} mm')
    for hold in walk['safe_holds']:
        suite.say(f'  safe hold, resumed: {hold}')
    suite.say(f'  reached: {walk["reached"]} {walk["message"]}; CPU '
              f'{100 * walk["usage"]["cpu_fraction_total"]:.0f} %, peak memory '
              f'{walk["usage"]["peak_rss_bytes_total"] / 2**20:.0f} MiB')


def part_soak(suite: Suite) -> dict:
    """Walk back and forth for long: memory, files, shared memory and step figures over time."""
    import numpy as np
    from bench_support import fastdds_shm_files, process_stats
    from graph_runner import GraphRun, walk_resuming
    from walker_bringup.summary import rows_from_reports

    minutes = suite.soak_minutes or 10.0
    targets = (DEFAULT_TARGET, 'n1_1')
    suite.say(f'soak: walking {targets[0]} <-> {targets[1]} until {minutes:g} min of '
              'simulated walking' + (', loop composed' if suite.loop else
                                     ', controllers grouped' if suite.grouped else ''))
    samples, legs = [], []
    suite._runs += 1
    began = time.monotonic()
    with GraphRun(suite.scratch / f'run{suite._runs}', 1, False, True, record=True,
                  probe=False, grouped=suite.grouped, loop=suite.loop) as run:
        client = run.clients[0]
        pids = run.pids()

        def sample() -> None:
            stats = {name: process_stats(pid) for name, pid in pids.items()}
            samples.append({'wall_s': round(time.monotonic() - began, 1),
                            'rss_bytes': {n: s.rss_bytes for n, s in stats.items() if s},
                            'open_files': {n: s.open_files for n, s in stats.items() if s},
                            'fastdds_shm_files': fastdds_shm_files()})

        sample()
        walked, failures = 0.0, 0
        while walked < 60.0 * minutes:
            target = targets[len(legs) % 2]
            count = len(client.reports)
            result, holds = walk_resuming(client, target, 3600.0, run.died)
            client.spin_for(0.5)
            rows = rows_from_reports(client.reports[count:])
            walked += sum(r.duration for r in rows)
            legs.append({'target': target, 'reached': bool(result.success),
                         'message': result.message, 'steps': len(rows),
                         'safe_holds': holds})
            sample()
            suite.say(f'  leg {len(legs)} to {target}: '
                      f'{"reached" if result.success else "FAILED: " + result.message}'
                      f', {walked / 60:.1f} of {minutes:g} min walked'
                      + (f', {len(holds)} safe holds resumed from' if holds else ''))
            if result.success:
                failures = 0
                continue
            # A failed leg is counted; the soak goes on from where the walker stands unless
            # three legs in a row fail.
            failures += 1
            if failures >= 3:
                break
            with contextlib.suppress(Exception):
                client.call_trigger('resume')
            client.spin_for(1.0)
        rows = rows_from_reports(client.reports)
    first, last = samples[1] if len(samples) > 2 else samples[0], samples[-1]
    growth = {n: last['rss_bytes'].get(n, 0) - first['rss_bytes'].get(n, 0)
              for n in first['rss_bytes']}
    files = lasting_open_files_change(samples)
    durations = np.array([r.duration for r in rows if r.success])
    errors = np.array([r.insertion_error for r in rows if r.success])
    vibration = np.array([r.residual_vibration for r in rows if r.success])

    def drift(values):
        if values.size < 6:
            return None
        third = values.size // 3
        (slope, _), covariance = np.polyfit(np.arange(values.size), values, 1, cov=True)
        return {'first_third_mean': float(values[:third].mean()),
                'last_third_mean': float(values[-third:].mean()),
                'slope_per_step': float(slope),
                'slope_standard_error': float(np.sqrt(covariance[0, 0]))}

    return {'grouped': suite.grouped, 'loop_composed': suite.loop,
            'minutes_walked': round(walked / 60, 2), 'wall_minutes':
            round((time.monotonic() - began) / 60, 2), 'legs': legs, 'steps': len(rows),
            'failed_steps': sum(1 for r in rows if not r.success),
            'safe_holds': sum(len(leg['safe_holds']) for leg in legs),
            'samples': samples,
            'rss_growth_after_first_leg_bytes': growth,
            'open_files_change_after_first_leg': files,
            'fastdds_shm_files_change': (last['fastdds_shm_files']
                                         - samples[0]['fastdds_shm_files']),
            'drift': {'duration_s': drift(durations), 'insertion_error_m': drift(errors),
                      'residual_vibration_m': drift(vibration)},
            # the estimate beside the truth: a drift of the true error is either the
            # supervisor's aim or the gap between what the joints say and where the tip is
            'step_rows': [{'from': r.from_node, 'to': r.to_node, 'success': r.success,
                           'phase_durations_s': r.phase_durations,
                           'duration_s': r.duration, 'bound_s': r.bound,
                           'bound_ratio': r.bound_ratio, 'attempts': r.attempts,
                           'insertion_error_m': r.insertion_error,
                           'insertion_error_estimated_m': r.insertion_error_estimated,
                           'residual_vibration_m': r.residual_vibration} for r in rows]}


def lasting_open_files_change(samples: list[dict]) -> dict:
    """Open files each process holds for good since the first leg: a leak, or 0.

    The fewest files over the last three samples less the fewest over the (up to) three after
    the first leg. A process opens a file for a moment now and then (the recorder rewrites its
    bag's metadata through a temporary file), which a single sample may catch; a leak raises
    even the fewest.
    """
    head = samples[1:4] if len(samples) > 2 else samples[:1]
    tail = samples[-3:]

    def fewest(window, name):
        return min(s['open_files'].get(name, 0) for s in window)

    return {n: fewest(tail, n) - fewest(head, n) for n in head[0]['open_files']}


def part_profile(suite: Suite) -> dict:
    """py-spy samples of the busiest processes during sim-time walking, in each arrangement.

    Separate processes (the plant, one controller, the planner, the supervisor), the
    controllers grouped (the plant, the controllers' node, the planner, the supervisor) and
    the graph composed in one process. Two processes are sampled at a time, so that the
    samplers themselves take at most one core.
    """
    from graph_runner import GraphRun, Walking, back_and_forth_targets
    from profiling import categorise, py_spy, record, top_functions

    if py_spy() is None:
        raise RuntimeError('py-spy is not installed: pip install py-spy (into .venv)')
    seconds = suite.seconds(10.0, 5.0)
    arrangements = (
        ('', False, False, ['/walker/plant', '/walker/controller_a_yaw', '/walker/planner',
                            '/walker/supervisor']),
        (' (grouped)', False, True, ['/walker/plant', '/walker/controllers', '/walker/planner',
                                     '/walker/supervisor']),
        (' (composed)', True, False, ['/walker/graph']))
    result = {}
    for label, composed, grouped, names in arrangements:
        suite._runs += 1
        scratch = suite.scratch / f'run{suite._runs}'
        with GraphRun(scratch, 1, composed, True, grouped=grouped) as run:
            with Walking(run, [back_and_forth_targets(s) for _, s, _ in run.graphs]):
                time.sleep(5.0)
                pids = run.pids()
                files = {n: scratch / (n.strip('/').replace('/', '_') + '.txt') for n in names}
                for pair in (names[i:i + 2] for i in range(0, len(names), 2)):
                    suite.say(f'profiling {", ".join(pair)}{label} for {seconds:g} s '
                              '(walking)')
                    recorders = {n: record(pids[n], seconds, files[n]) for n in pair}
                    for name, recorder in recorders.items():
                        _, error = recorder.communicate()
                        path = files[name]
                        if not path.exists():
                            raise RuntimeError(f'py-spy could not sample {name}: {error}')
                        result[name + label] = {
                            **categorise(path), 'top_walker_functions': top_functions(path)}
    for name, profile in result.items():
        suite.say(f'  {name}: idle {100 * (profile["idle_share"] or 0):.0f} %; busy: '
                  + ', '.join(f'{c} {100 * s:.0f} %' for c, s in profile['shares'].items()))
    return result


# ----------------------------------------------------------------------------- the table
def _mean(values):
    values = [v for v in values if v is not None and math.isfinite(v)]
    return round(sum(values) / len(values), 4) if values else None


def _fmt(value, scale=1.0, digits=2, unit=''):
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return '-'
    return f'{value * scale:.{digits}f}{unit}'


def _loop_cell(loop: dict) -> str:
    rt = loop.get('all_five_latency', {})
    return (f'{_fmt(rt.get("median_ms"))} / {_fmt(rt.get("p99_ms"))} / '
            f'{_fmt(rt.get("max_ms"), digits=1)} ms')


def figures(results: dict) -> list[dict]:
    """Build the summary table: one row per figure, with its target and whether it is met."""
    rows = []

    def add(figure, value, target='', met=None):
        rows.append({'figure': figure, 'value': value, 'target': target,
                     'met': None if met is None else bool(met)})

    plant = results.get('plant')
    if plant:
        for case in ('moving', 'at_rest'):
            row = plant[case]
            add(f'plant core alone ({case.replace("_", " ")}): real-time factor of step() '
                '(of pybullet alone); control step p50 / p99',
                f'{row["real_time_factor"]:.1f} ({row["engine_only_real_time_factor"]:.1f}); '
                f'{row["control_step_us"]["p50"]:.0f} / '
                f'{row["control_step_us"]["p99"]:.0f} us', '>= 20 (physics alone)',
                row['real_time_factor'] >= 20)
        accuracy = plant.get('accuracy')
        if accuracy:
            worst = max(accuracy['joints'].values(), key=lambda j: j['speed_error_relative'])
            tip = max(j['tip_error_m'] for j in accuracy['joints'].values())
            add(f'plant accuracy ({accuracy["physics_rate_hz"]:g} Hz, '
                f'{accuracy["solver_iterations"]} iterations) against a converged reference: '
                'largest joint speed error; tip error',
                f'{100 * worst["speed_error_relative"]:.2f} % of peak; {1e3 * tip:.2f} mm')
    planner = results.get('planner')
    if planner:
        for case in planner['results']:
            if case['case'].startswith(('solve', 'direct method')) \
                    or 'bang_bang_node' in case['case'] \
                    or 'insertion' in case['case'] or 'joint_parabolic_time' in case['case'] \
                    or 'cartesian_line' in case['case']:
                solve = case['case'].startswith('solve')
                add(f'planner: {case["case"]}: median / p99',
                    f'{case["median_ms"]:.2f} / {case["p99_ms"]:.2f} ms',
                    '< 5 ms' if solve else '', case['p99_ms'] < 5.0 if solve else None)
    loop = results.get('control_loop')
    if loop:
        for rate, window in loop.items():
            w = window['per_walker'][0]['loop']
            period = 1e3 / float(rate)
            p99 = w.get('all_five_latency', {}).get('p99_ms', math.inf)
            add(f'control loop {float(rate):g} Hz, 8 processes, real time, holding: round trip '
                'median / p99 / max', _loop_cell(w), f'p99 <= {period:g} ms', p99 <= period)
            add(f'control loop {float(rate):g} Hz: missed periods; CPU of the graph',
                f'{100 * w.get("missed_fraction", math.nan):.1f} % of '
                f'{w.get("states_published", 0)}; '
                f'{100 * window["usage"]["cpu_fraction_total"]:.0f} % of a core',
                'none missed', w.get('missed_periods', 1) == 0)
    composition = results.get('composition')
    if composition:
        kinds = [k for k in ARRANGEMENTS if k in composition['real_time_500hz']]
        for rate in ('500', '1000'):
            for kind in kinds if f'real_time_{rate}hz' in composition else ():
                window = composition[f'real_time_{rate}hz'][kind]
                w = window['per_walker'][0]
                add(f'{kind}: real time {rate} Hz round trip median / p99 / max; missed',
                    f'{_loop_cell(w["loop"])}; '
                    f'{100 * w["loop"].get("missed_fraction", 0):.1f} %')
                add(f'{kind}: real time {rate} Hz CPU; peak memory',
                    f'{100 * w["cpu_fraction"]:.0f} % of a core; '
                    f'{w["peak_rss_bytes"] / 2**20:.0f} MiB')
        for kind in kinds:
            window = composition['sim_time_walking'][kind]
            w = window['per_walker'][0]
            rtf = w['loop'].get('real_time_factor')
            add(f'{kind}: sim time walking: real-time factor; round trip median / p99',
                f'{_fmt(rtf)}; {_fmt(w["loop"].get("all_five_latency", {}).get("median_ms"))} /'
                f' {_fmt(w["loop"].get("all_five_latency", {}).get("p99_ms"))} ms',
                f'>= {TARGET_REAL_TIME_FACTOR:g}', rtf is not None
                and rtf >= TARGET_REAL_TIME_FACTOR)
            add(f'{kind}: sim time walking: CPU; CPU per simulated second; peak memory',
                f'{100 * w["cpu_fraction"]:.0f} % of a core; '
                f'{_fmt(w["cpu_seconds_per_sim_second"])} s; '
                f'{w["peak_rss_bytes"] / 2**20:.0f} MiB')
    walk = results.get('walk')
    if walk:
        labels = {'sim_time': 'walk (sim time)', 'real_time': 'one step (real time)',
                  'real_time_grouped': 'one step (real time, controllers grouped)',
                  'real_time_loop': 'one step (real time, loop composed)'}
        for kind in [k for k in labels if k in walk]:
            data = walk[kind]
            steps = [s for s in data['steps'] if s['success']]
            label = labels[kind]
            holds = data.get('safe_holds', [])
            add(f'{label}: reached {data["target"]}; safe holds resumed from (watchdogs)',
                f'{"yes" if data["reached"] else "no"}; {len(holds)}', 'reached; 0 holds',
                data['reached'] and not holds)
            if not steps:
                add(f'{label}: steps', f'none succeeded: {data["message"]}', '', False)
                continue
            ratios = [s['bound_ratio'] for s in steps]
            tip = [s['insertion_error_m'] for s in steps]
            vibration = [s['residual_vibration_m'] for s in steps]
            add(f'{label}: {len(steps)} steps to {data["target"]}, step time (min-max)',
                f'{min(s["duration_s"] for s in steps):.1f}-'
                f'{max(s["duration_s"] for s in steps):.1f} s')
            add(f'{label}: step time / time-optimal bound (median, max)',
                f'{_median(ratios):.2f}, {max(ratios):.2f}', f'<= {TARGET_BOUND_RATIO:g}',
                max(ratios) <= TARGET_BOUND_RATIO)
            add(f'{label}: tip error at insertion (median, max)',
                f'{1e3 * _median(tip):.2f}, {1e3 * max(tip):.2f} mm',
                f'< {1e3 * TARGET_TIP_ERROR:g} mm', max(tip) < TARGET_TIP_ERROR)
            add(f'{label}: residual vibration (median, max)',
                f'{1e3 * _median(vibration):.2f}, {1e3 * max(vibration):.2f} mm')
            add(f'{label}: walking speed (simulated; wall clock)',
                f'{_fmt(data["nodes_per_minute_walking"])}; '
                f'{_fmt(data["nodes_per_minute_wall"])} nodes/min')
            loop_data = data['loop']
            if kind == 'sim_time':
                add(f'{label}: real-time factor over the walk',
                    _fmt(loop_data.get('real_time_factor')), f'>= {TARGET_REAL_TIME_FACTOR:g}',
                    (loop_data.get('real_time_factor') or 0) >= TARGET_REAL_TIME_FACTOR)
            else:
                add(f'{label}: round trip median / p99 / max; missed periods',
                    f'{_loop_cell(loop_data)}; '
                    f'{100 * loop_data.get("missed_fraction", math.nan):.1f} %')
            add(f'{label}: whole-graph CPU; peak memory (sum of the processes)',
                f'{100 * data["usage"]["cpu_fraction_total"]:.0f} % of a core; '
                f'{data["usage"]["peak_rss_bytes_total"] / 2**20:.0f} MiB')
    scaling = results.get('scaling')
    for label, data in (('', scaling), ('controllers grouped, ', (scaling or {}).get('grouped'))):
        if not data:
            continue
        for n, growth in data['growth'].items():
            window = data['sim_time_walking'][n]
            p99 = _mean([w['loop'].get('all_five_latency', {}).get('p99_ms')
                         for w in window['per_walker']])
            relative = growth['relative_to_one_walker']
            add(f'{n} walker(s), {label}sim time walking: per walker real-time factor; round '
                'trip p99; CPU per simulated second (x one walker)',
                f'{_fmt(growth["real_time_factor_per_walker"])}; {_fmt(p99)} ms; '
                f'{_fmt(growth["cpu_seconds_per_sim_second_per_walker"])} s '
                f'({_fmt(relative)} x)'
                + (f'; {len(window["errors"])} errors' if window['errors'] else ''),
                'per-walker cost <= linear',
                relative is not None and relative <= 1.25 and not window['errors'])
        for n, window in data['real_time_holding'].items():
            missed = _mean([w['loop'].get('missed_fraction') for w in window['per_walker']])
            p99 = _mean([w['loop'].get('all_five_latency', {}).get('p99_ms')
                         for w in window['per_walker']])
            add(f'{n} walker(s), {label}real time 500 Hz holding: round trip p99; missed '
                'periods',
                f'{_fmt(p99)} ms; {_fmt(missed, 100, 1)} %', 'p99 <= 2 ms',
                p99 is not None and p99 <= 2.0)
    soak = results.get('soak')
    if soak:
        growth = max(soak['rss_growth_after_first_leg_bytes'].values(), default=0)
        files = max((lasting_open_files_change(soak['samples']) if soak.get('samples')
                     else soak['open_files_change_after_first_leg']).values(), default=0)
        label = ('soak (loop composed)' if soak.get('loop_composed')
                 else 'soak (controllers grouped)' if soak.get('grouped') else 'soak')
        add(f'{label}: {soak["minutes_walked"]:g} min walked ({soak["steps"]} steps, '
            f'{soak["failed_steps"]} failed, {soak.get("safe_holds", 0)} safe holds resumed '
            'from): largest RSS growth after the first leg; '
            'open files change', f'{growth / 2**20:.1f} MiB; {files:+d}',
            'no leak', growth < 20 * 2**20 and files <= 0)
        _soak_step_figures(add, label, [r for r in soak.get('step_rows', [])
                                        if r['success'] and 'bound_ratio' in r])
        duration = soak['drift']['duration_s']
        if duration:
            add(f'{label}: step time first third / last third of the steps',
                f'{duration["first_third_mean"]:.2f} / {duration["last_third_mean"]:.2f} s',
                'no drift')
    return rows


def _soak_step_figures(add, label: str, steps: list[dict]) -> None:
    """Add the soak's step time against each step's own bound, and its tip error.

    The median, the tail and the share of the steps within the walking issue's 1.5 and the
    benchmark's 0.5 mm: one step over is what a user meets.
    """
    import numpy as np

    ratios = np.array([s['bound_ratio'] for s in steps], dtype=float)
    ratios = ratios[np.isfinite(ratios)]
    if ratios.size:
        add(f'{label}: step time / time-optimal bound (median, p90, max; steps at most '
            f'{WALK_BOUND_RATIO:g})',
            f'{np.median(ratios):.2f}, {np.percentile(ratios, 90):.2f}, {ratios.max():.2f}; '
            f'{100 * np.mean(ratios <= WALK_BOUND_RATIO):.0f} %',
            f'<= {TARGET_BOUND_RATIO:g}', bool(ratios.max() <= TARGET_BOUND_RATIO))
    tip = np.array([s['insertion_error_m'] for s in steps], dtype=float)
    if tip.size:
        add(f'{label}: tip error at insertion (mean, max; steps under '
            f'{1e3 * TARGET_TIP_ERROR:g} mm)',
            f'{1e3 * tip.mean():.2f}, {1e3 * tip.max():.2f} mm; '
            f'{100 * np.mean(tip < TARGET_TIP_ERROR):.0f} %',
            f'< {1e3 * TARGET_TIP_ERROR:g} mm', bool(tip.max() < TARGET_TIP_ERROR))


def _median(values):
    ordered = sorted(values)
    middle = len(ordered) // 2
    return ordered[middle] if len(ordered) % 2 else 0.5 * (ordered[middle - 1] + ordered[middle])


def format_table(rows: list[dict]) -> str:
    """Rows as aligned text."""
    header = ('figure', 'value', 'target', 'met')
    body = [(r['figure'], r['value'], r['target'] or '',
             '' if r['met'] is None else ('yes' if r['met'] else 'NO')) for r in rows]
    widths = [max(len(h), *(len(b[i]) for b in body)) if body else len(h)
              for i, h in enumerate(header)]
    lines = ['  '.join(h.ljust(w) for h, w in zip(header, widths, strict=True)),
             '  '.join('-' * w for w in widths)]
    lines += ['  '.join(c.ljust(w) for c, w in zip(b, widths, strict=True)) for b in body]
    return '\n'.join(lines)


# ----------------------------------------------------------------------------- main
def earlier_results(directory: Path, names: list[str], quick: bool) -> dict:
    """Return the last results of parts not run now: name -> (result, status).

    Only results of the same kind of run (``--quick`` or not) are taken; each status says
    when, on which commit and under which load the part ran.
    """
    import json

    found = {}
    for name in names:
        path = directory / f'{name}.json'
        try:
            document = json.loads(path.read_text())
        except (OSError, ValueError):
            continue
        if document.get('quick') != quick or name not in document:
            continue
        machine = document.get('machine', {})
        found[name] = (document[name], {
            'ok': True, 'earlier_run': machine.get('date'), 'commit': machine.get('commit'),
            'load_average_before_run': machine.get('load_average_1_5_15'),
            'load_average_after': document.get('load_average_after_part')})
    return found


def summary_document(machine: dict, quick: bool, status: dict, rows: list[dict]) -> dict:
    """Return what ``summary.json`` holds: the machine and its load, the parts, the figures."""
    from bench_support import NOISE_NOTE

    return {'suite': 'walker benchmarks (benchmarks/run_benchmarks.py)',
            'machine': machine, 'note': NOISE_NOTE, 'quick': quick,
            'executor': os.environ.get('WALKER_EXECUTOR', 'events'),
            'parts': status, 'figures': rows,
            'targets': {'step_time_bound_ratio': TARGET_BOUND_RATIO,
                        'tip_error_m': TARGET_TIP_ERROR,
                        'p99_round_trip': 'within one control period at 500 Hz with five '
                                          'separate controller processes',
                        'sim_time_real_time_factor': TARGET_REAL_TIME_FACTOR,
                        'per_walker_cost': 'growing no worse than linearly'}}


def main(argv: list[str] | None = None) -> int:
    """Run the selected parts, print the table, write the JSON files."""
    argv = sys.argv[1:] if argv is None else argv
    args = _arguments(argv)
    walker_env.reexec_in_environment(os.path.abspath(__file__), argv)
    from bench_support import NOISE_NOTE, machine_info, write_json

    machine = machine_info()
    print(f'[benchmark] {machine["cpus"]} CPUs, load average '
          f'{machine["load_average_1_5_15"][0]:.2f}; parts: {", ".join(args.parts)}'
          f'{" (quick)" if args.quick else ""}')
    print(f'[benchmark] note: {NOISE_NOTE}')
    functions = {name: globals()[f'part_{name}'] for name in PARTS + OPTIONAL}
    results, status = {}, {}
    with tempfile.TemporaryDirectory(prefix='walker-bench-') as scratch:
        suite = Suite(args, Path(scratch))
        for name in args.parts:
            began = time.monotonic()
            try:
                results[name] = functions[name](suite)
                status[name] = {'ok': True}
            except Exception as error:  # report and go on with the other parts
                traceback.print_exc()
                status[name] = {'ok': False, 'error': f'{type(error).__name__}: {error}'}
            status[name]['seconds'] = round(time.monotonic() - began, 1)
            status[name]['load_average_after'] = [round(x, 2) for x in os.getloadavg()]
            if name in results:
                write_json(args.output / 'suite' / f'{name}.json',
                           {'machine': machine, 'quick': args.quick,
                            'load_average_after_part': status[name]['load_average_after'],
                            name: results[name]})
    machine['load_average_after_1_5_15'] = [round(x, 2) for x in os.getloadavg()]
    for name, (result, state) in earlier_results(args.output / 'suite',
                                                 [p for p in (*PARTS, 'soak')
                                                  if p not in args.parts],
                                                 args.quick).items():
        results[name], status[name] = result, state
    rows = figures(results)
    print()
    print(format_table(rows))
    print(f'\nMachine: {machine["cpus"]} CPUs, load average '
          f'{machine["load_average_1_5_15"][0]:.2f} before, '
          f'{machine["load_average_after_1_5_15"][0]:.2f} after; {NOISE_NOTE}.')
    for name, state in status.items():
        if not state['ok']:
            print(f'part {name} FAILED: {state["error"]}')
    summary = summary_document(machine, args.quick, status, rows)
    if set(status) >= set(PARTS):
        write_json(args.output / 'summary.json', summary)
        print(f'written: {args.output / "summary.json"} and {args.output / "suite"}/*.json')
    else:
        write_json(args.output / 'suite' / 'last_partial_summary.json', summary)
        print(f'written: {args.output / "suite"}/*.json (summary.json once every part has '
              'been run)')
    return 0 if all(s['ok'] for s in status.values()) else 1


if __name__ == '__main__':
    sys.exit(main())
