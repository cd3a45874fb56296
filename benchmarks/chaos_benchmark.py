#!/usr/bin/env python3
"""Seeded chaos on a served graph: faults injected, recovered, grip losses, time to recover.

Usage: ``python3 benchmarks/chaos_benchmark.py [--seed S] [--faults N]``. Brings the graph up
with ``run_all.py --serve --sim-time`` (each node a process of its own, recorded, supervised) in
a ROS domain of its own, walks it between two truss nodes and applies N faults planned from the
seed over the nine nodes and the four phases of a step (``SIGKILL``, answered by the bring-up's
restart, or ``SIGSTOP`` for 2-5 s), resuming each hold as an operator would
(``tests/chaos_run.py``, ``walker_bringup.chaos_driver``). Prints a table per node and kind,
and writes ``benchmarks/results/chaos.json``: the faults by kind, node and phase, how many were
held and recovered, the grip losses (live and in the bag), the time to recover (median and
maximum, wall clock) and the resumes needed, with every fault's outcome.

Times are wall-clock seconds on a shared 2-core machine: they include the restart of a Python
node (several seconds under load) and the supervisor's refusals of ``resume`` until the graph
is well again.
"""

import argparse
import os
import statistics
import sys
import tempfile
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO_ROOT / 'scripts'))
sys.path.insert(0, str(REPO_ROOT / 'benchmarks'))
sys.path.insert(0, str(REPO_ROOT / 'tests'))

import walker_env  # noqa: E402

walker_env.reexec_in_environment(os.path.abspath(__file__), sys.argv[1:])

from bench_support import NOISE_NOTE, RESULTS, machine_info, write_json  # noqa: E402


def table(outcomes: list[dict]) -> str:
    """Rows per node and kind: faults, held, recovered, median and max time to recover [s]."""
    rows = {}
    for outcome in outcomes:
        rows.setdefault((outcome['node'], outcome['kind']), []).append(outcome)
    lines = [f'{"node":<19} {"kind":<8} {"faults":>6} {"held":>5} {"recovered":>9} '
             f'{"resumes":>7} {"median [s]":>10} {"max [s]":>8}']
    for (node, kind), group in sorted(rows.items()):
        times = [o['time_to_recover'] for o in group if o['recovered']]
        lines.append(f'{node:<19} {kind:<8} {len(group):>6} {sum(o["held"] for o in group):>5} '
                     f'{sum(o["recovered"] for o in group):>9} '
                     f'{sum(o["resumes"] for o in group):>7} '
                     f'{statistics.median(times) if times else float("nan"):>10.1f} '
                     f'{max(times, default=float("nan")):>8.1f}')
    return '\n'.join(lines)


def main() -> int:
    """Run the chaos walk, print its table, write its JSON; exit 1 if a check failed."""
    from chaos_run import run_chaos

    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--seed', type=int, default=41, help='seed of the plan')
    parser.add_argument('--faults', type=int, default=30, help='number of faults')
    parser.add_argument('--out', default=None, help='run directory (default: a temporary one)')
    parser.add_argument('--results', default=str(RESULTS / 'chaos.json'),
                        help='the JSON written (default: %(default)s)')
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix='walker-chaos-') as scratch:
        out = Path(args.out) if args.out else Path(scratch) / 'run'
        result = run_chaos(out, args.seed, args.faults, in_step_order=True,
                           say=lambda line: print(line, flush=True))
    figures = result['figures']
    print('\n' + table(result['outcomes']))
    print(f'\nfaults {figures["faults"]}, held {figures["held"]}, recovered '
          f'{figures["recovered"]}, grip losses {figures["grip_losses"]}, time to recover '
          f'{figures["time_to_recover"]} s, resumes {figures["resumes"]}; walk reached: '
          f'{result["reached"]}; left running: {result["left_running"]}; stale shared memory: '
          f'{len(result["stale_shared_memory"])}; bag files {len(result["bag"]["files"])}, '
          f'{result["bag"]["messages"]} messages; {result["wall_time"]:.0f} s')
    if result['error']:
        print(f'error: {result["error"]}')
    document = {'benchmark': 'chaos', 'note': NOISE_NOTE, 'machine': machine_info(),
                'seed': args.seed, 'figures': figures, 'reached': result['reached'],
                'error': result['error'], 'exit_code': result['exit_code'],
                'left_running': result['left_running'],
                'stale_shared_memory': result['stale_shared_memory'],
                'bag': result['bag'], 'grip_instants': result['grip_instants'],
                'processes': result['processes'], 'wall_time': result['wall_time'],
                'outcomes': result['outcomes']}
    write_json(Path(args.results), document)
    print(f'written {args.results}')
    survived = (not result['error'] and result['reached'] and result['exit_code'] == 0
                and figures['recovered'] == figures['faults']
                and figures['grip_losses'] == {'live': 0, 'bag': 0}
                and not result['left_running'] and not result['stale_shared_memory'])
    return 0 if survived else 1


if __name__ == '__main__':
    sys.exit(main())
