#!/usr/bin/env python3
"""Command shaping side by side: the paper's low-pass against each input shaper, one run.

Usage::

    python3 benchmarks/shaping_benchmark.py             # default walk, and the mode corners
    python3 benchmarks/shaping_benchmark.py --nominal   # the default walk alone
    python3 benchmarks/shaping_benchmark.py --docs      # also write the table into
                                                        # docs/controllers.md

Headless walks (deterministic: valid on a loaded machine; run it under the heavy lock), each to
``--target`` from the parameter file's start, under each configuration of joint 1's command:

``paper``
    The shipped file: joint 1's 4th-order Bessel low-pass at 5 rad/s in the loop, no shaper.
``lowpass-2@12``
    The same loop with joint 1's filter 2nd order at 12 rad/s and no shaper (what the shapers
    are added to: it shows what the weaker filter alone lets ring).
``zv`` ``zvd`` ``ei`` ``si``
    That loop with the input shaper on joint 1's setpoints (``control.shaping``) at the
    18 rad/s mode (5 % damping; EI and SI at a 5 % tolerance, SI over +-15 %).

For each: step time / bound (median, p90), tip error at screw-in (median, share under 0.5 mm),
residual vibration (median, largest), failed steps. Unless ``--nominal``, the same walks with
the plant's two modes (``robot.flexibility.joint1_mode`` and ``joints23_mode``, the plant's
alone: the controllers keep the nominal file) at the corners of the campaigns' +-15 %
dispersion, pooled: the worst cases of the dispersed campaign. Writes
``benchmarks/results/shaping.json`` and prints the table.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO_ROOT / 'scripts'))

import walker_env  # noqa: E402

RESULTS = REPO_ROOT / 'benchmarks' / 'results' / 'shaping.json'
DOCS = REPO_ROOT / 'docs' / 'controllers.md'
BEGIN, END = '<!-- shaping table begin -->', '<!-- shaping table end -->'
TARGETS = {'median_bound_ratio': 1.25, 'tip_error': 0.0005, 'tip_error_share': 0.95}
_WEAK_FILTER = {'control.filter.order': [2, 2, 2, 0, 0],
                'control.filter.corner': [12.0, 24.0, 24.0, 0.0, 0.0]}
_MODE = {'control.shaping.frequency': [18.0, 0.0, 0.0, 0.0, 0.0]}
CONFIGURATIONS = {
    'paper': {},
    'lowpass-2@12': dict(_WEAK_FILTER),
    **{kind: {**_WEAK_FILTER, **_MODE, 'control.shaping.kind': kind}
       for kind in ('zv', 'zvd', 'ei', 'si')},
}
MODE_CORNERS = [(a, b) for a in (0.85, 1.15) for b in (0.85, 1.15)]


def _walk(overrides: dict, target: str, modes: tuple[float, float] | None) -> dict:
    from walker_config.core.configuration import (
        configuration_of, load_configuration, plant_sections)
    from walker_core.parameter_file import ParameterFile
    from walker_headless.runner import walk

    if modes is None:
        configuration = load_configuration(overrides=overrides)
    else:
        nominal = ParameterFile.read(None)
        plant_overrides = dict(overrides)
        for name, factor in zip(('robot.flexibility.joint1_mode',
                                 'robot.flexibility.joints23_mode'), modes, strict=True):
            plant_overrides[name] = factor * nominal.values[name]
        plant = plant_sections(ParameterFile.read(None, plant_overrides))
        configuration = configuration_of(ParameterFile.read(None, overrides), plant)
    result = walk(configuration, target)
    return {'reached': result.reached, 'message': result.message,
            'steps': [{'sweep': r.sweep, 'success': r.success, 'duration': r.duration,
                       'bound': r.time_optimal_bound, 'bound_ratio': r.bound_ratio,
                       'tip_error': r.insertion_error, 'residual_vibration': r.residual_vibration,
                       'insertion_attempts': r.insertion_attempts,
                       'phases': dict(zip(r.phase_names, r.phase_durations, strict=True))}
                      for r in result.reports]}


def _quantile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))]


def summary(walks: list[dict]) -> dict:
    """Pool the steps of ``walks`` into the table's figures (SI units)."""
    steps = [s for w in walks for s in w['steps']]
    done = [s for s in steps if s['success']]
    ratios = [s['bound_ratio'] for s in done]
    errors = [s['tip_error'] for s in done]
    vibration = [s['residual_vibration'] for s in done]
    if not done:
        return {'steps': len(steps), 'failed': len(steps), 'walks_failed': len(walks)}
    return {'steps': len(steps), 'failed': len(steps) - len(done),
            'walks_failed': sum(not w['reached'] for w in walks),
            'bound_ratio_median': statistics.median(ratios),
            'bound_ratio_p90': _quantile(ratios, 0.9),
            'tip_error_median': statistics.median(errors),
            'tip_error_p95': _quantile(errors, 0.95),
            'tip_error_under_target': sum(e < TARGETS['tip_error'] for e in errors) / len(errors),
            'vibration_median': statistics.median(vibration),
            'vibration_max': max(vibration),
            'jams': sum(s['insertion_attempts'] > 1 for s in done)}


def table(results: dict) -> str:
    """Return the Markdown table of ``results`` (as written to the JSON)."""
    lines = ['| configuration | plant modes | steps (failed) | time / bound median, p90 '
             '| tip error median, p95 [mm], under 0.5 mm | residual vibration median, max '
             '[mm] | jams |',
             '| --- | --- | --- | --- | --- | --- | --- |']
    for name, rows in results['configurations'].items():
        for label, row in rows.items():
            if 'bound_ratio_median' not in row:
                lines.append(f'| {name} | {label} | {row["steps"]} ({row["failed"]}) | - | - '
                             f'| - | - |')
                continue
            lines.append(
                f'| {name} | {label} | {row["steps"]} ({row["failed"]}) '
                f'| {row["bound_ratio_median"]:.3f}, {row["bound_ratio_p90"]:.3f} '
                f'| {row["tip_error_median"] * 1e3:.2f}, {row["tip_error_p95"] * 1e3:.2f}, '
                f'{row["tip_error_under_target"]:.0%} '
                f'| {row["vibration_median"] * 1e3:.2f}, {row["vibration_max"] * 1e3:.2f} '
                f'| {row["jams"]} |')
    return '\n'.join(lines)


def write_docs(results: dict) -> None:
    """Put the table between the markers of ``docs/controllers.md``."""
    text = DOCS.read_text()
    start, end = text.index(BEGIN) + len(BEGIN), text.index(END)
    DOCS.write_text(text[:start] + '\n' + table(results) + '\n' + text[end:])


def main(argv: list[str] | None = None) -> int:
    """Walk each configuration, print the table, write the JSON; return the exit code."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--target', default='n4_3')
    parser.add_argument('--nominal', action='store_true', help='the nominal plant alone')
    parser.add_argument('--docs', action='store_true', help='write the table into the docs')
    parser.add_argument('--from-json', action='store_true',
                        help='no walks: the table (and --docs) from the results file')
    args = parser.parse_args(argv)
    walker_env.reexec_in_environment(str(Path(__file__).resolve()), sys.argv[1:])
    if args.from_json:
        results = json.loads(RESULTS.read_text())
    else:
        results = {'target': args.target, 'targets': TARGETS, 'configurations': {},
                   'overrides': CONFIGURATIONS}
        for name, overrides in CONFIGURATIONS.items():
            started = time.monotonic()
            rows = {'nominal': summary([_walk(overrides, args.target, None)])}
            if not args.nominal:
                rows['+-15 % corners'] = summary(
                    [_walk(overrides, args.target, corner) for corner in MODE_CORNERS])
            results['configurations'][name] = rows
            print(f'{name}: {time.monotonic() - started:.0f} s', flush=True)
        RESULTS.parent.mkdir(parents=True, exist_ok=True)
        RESULTS.write_text(json.dumps(results, indent=1) + '\n')
    print(table(results))
    if args.docs:
        write_docs(results)
    return 0


if __name__ == '__main__':
    sys.exit(main())
