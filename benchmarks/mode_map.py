#!/usr/bin/env python3
"""The flexible modes joint 1's coarse motion excites, mapped over configurations and dispersion.

Usage::

    python3 benchmarks/mode_map.py              # compute, print the table, write JSON and figure
    python3 benchmarks/mode_map.py --docs       # also write the table into docs/controllers.md
    python3 benchmarks/mode_map.py --from-json  # no computation: the table from the results

Plant-core linearisation (:mod:`walker_sim.core.driven_modes`; no ROS graph, no simulation:
deterministic, light, seconds). For each configuration, three cases of joint 1:

``held``
    All five joints held (a brake, or joint 1 stuck in its stiction at either end of the
    motion): the springs' definition, 18 rad/s at the default stance.
``paper``
    Every joint under its coarse loop of the shipped file (joint 1: wc 0.6 rad/s, Ka 0.25,
    4th-order Bessel low-pass at 5 rad/s in the loop): joint 1 sliding through the motion.
``lowpass-2@12``
    The same with joint 1's filter weakened to 2nd order at 12 rad/s (the loop the shapers of
    ``benchmarks/shaping_benchmark.py`` are added to).

The configurations: the tip's reach ``r`` from the base yaw axis (the node-to-node motion's
radius) from 0.5 to 1.1 m at ``Theta = 0``; joint 1's angle ``Theta`` from 0 to 180 deg at
one truss spacing; and the quarter and half turns' paths, as the planner plans them (rate
capped: a pure rotation at one spacing) and at the torque bound (the tip pulled in to
``min_radius``). All at the approach height, gripper a as base. Each mode with the plant's two
modes at the corners of the campaigns' +-15 % dispersion too. Joint 1's modes are those of its
(out-of-plane) bending plane, numbered by frequency: each is continuous in the configuration,
while which of them dominates can change. Finally the residual vibration (Singer and Seering's
``V``) each shaper of the shaping benchmark's design leaves at each mode, worst over the
dispersion, at the nodes (one spacing, where joint 1 stops) and along the turns. Writes
``benchmarks/results/mode_map.json`` and ``docs/images/mode_map.png``; prints the table.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO_ROOT / 'scripts'))
sys.path.insert(0, str(REPO_ROOT / 'benchmarks'))

import walker_env  # noqa: E402

RESULTS = REPO_ROOT / 'benchmarks' / 'results' / 'mode_map.json'
FIGURE = REPO_ROOT / 'docs' / 'images' / 'mode_map.png'
DOCS = REPO_ROOT / 'docs' / 'controllers.md'
BEGIN, END = '<!-- mode map table begin -->', '<!-- mode map table end -->'
HELD = 'held'
#: The shapers of the shaping benchmark: at 18 rad/s, 5 % damping, EI and SI at 5 %.
SHAPER_KINDS = ('zv', 'zvd', 'ei', 'si')
REACHES = [round(0.5 + 0.05 * k, 3) for k in range(13)]
SWEEPS_DEG = list(range(0, 181, 15))
PATH_POINTS = 9
#: The shaping benchmark's design frequency [rad/s] (joint 1's held mode).
SHAPED_FREQUENCY = 18.0


def _controllers() -> dict[str, dict]:
    from shaping_benchmark import CONFIGURATIONS

    return {name: CONFIGURATIONS[name] for name in ('paper', 'lowpass-2@12')}


def _coarse_loops(overrides: dict) -> tuple[dict, float]:
    """Every joint's coarse loop of the parameter file with ``overrides``, and the period."""
    import numpy as np

    from walker_control.core.config import ControllerSettings
    from walker_control.core.lowpass import design_lowpass_sos
    from walker_control.core.modes import Mode
    from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
    from walker_core.parameter_file import ParameterFile
    from walker_sim.core.driven_modes import JointLoop

    settings = ParameterFile.read(None, overrides).section(ControllerSettings)
    loops = {}
    for role, name in enumerate(PHYSICAL_JOINT_NAMES, start=1):
        design = settings.loop_design(role, Mode.COARSE)
        sos = np.asarray(design_lowpass_sos(design.filter_order, design.filter_corner,
                                            settings.sample_time, design.filter_kind))
        loops[name] = JointLoop(design.bandwidth, design.damping, design.acceleration_feedback,
                                sos.reshape(-1, 6))
    return loops, settings.sample_time


def _paths(params) -> dict[str, list[tuple[float, float]]]:
    """``(Theta, r)`` along the quarter and half turns, as planned and at the torque bound."""
    import numpy as np

    from walker_core.parameter_file import ParameterFile
    from walker_planner.core.node_to_node import (
        NodeToNodeTrajectory, PlanarModel, solve_node_to_node)
    from walker_planner.core.parameters import PREFIX, PlannerParameters

    nominal = ParameterFile.read(None).section(PlannerParameters, PREFIX).bang_bang
    two_l = 2.0 * params.robot.geometry.l2
    models = {'plan': PlanarModel.from_parameters(params, nominal.torque_fraction,
                                                  nominal.velocity_fraction),
              'torque bound': PlanarModel.from_parameters(params)}
    paths = {}
    for sweep, turn in ((90, 'quarter turn'), (180, 'half turn')):
        for label, model in models.items():
            solution = solve_node_to_node(model, params.truss.spacing / two_l,
                                          math.radians(sweep) / 2.0,
                                          nominal.min_radius / two_l)
            trajectory = NodeToNodeTrajectory(solution, 0.0, 1, 0.0)
            radius, _, _, theta, _, _ = trajectory.polar(
                np.linspace(0.0, trajectory.duration, PATH_POINTS))
            paths[f'{turn} ({label})'] = [(float(t), float(r))
                                          for t, r in zip(theta, radius, strict=True)]
    return paths


def _mode_row(mode) -> dict:
    return {'frequency': mode.frequency, 'damping': mode.damping, 'weight': mode.weight}


def _point(params, tuning, controllers, sweep: float, reach: float, height: float) -> dict:
    """Joint 1's modes in each case at one configuration, nominal and at the corners.

    Every mode of joint 1's (out-of-plane) bending, ascending: branch k is the k-th of them, a
    continuous function of the configuration; ``share`` is each one's weight over the largest.
    """
    from shaping_benchmark import MODE_CORNERS
    from walker_sim.core.driven_modes import (
        Plane, driven_modes, held_modes, stance_at, stance_model)

    stance = stance_model(params, stance_at(params, sweep, reach, height))
    zeta = params.robot.flexibility.damping_ratio
    scales = [None] + [{Plane.OUT_OF_PLANE: a, Plane.IN_PLANE: b} for a, b in MODE_CORNERS]
    cases = {}
    for case in (HELD, *controllers):
        found = []
        for scale in scales:
            if case == HELD:
                modes = held_modes(stance, tuning, zeta, scale, visible=0.0)
            else:
                loops, period = controllers[case]
                modes = driven_modes(stance, tuning, loops, period, scale, visible=0.0)
            found.append([m for m in modes if m.plane == Plane.OUT_OF_PLANE])
        largest = max(m.weight for m in found[0])
        cases[case] = {
            'modes': [{**_mode_row(m), 'share': m.weight / largest} for m in found[0]],
            'dominant': max(range(len(found[0])), key=lambda k: found[0][k].weight),
            'dispersed': [[_mode_row(m) for m in modes] for modes in found[1:]]}
    return {'sweep': sweep, 'reach': reach, 'stance': [float(a) for a in stance.model.stance],
            'inertia': float(stance.inertia[0]), 'cases': cases}


def _branch_rows(points: list[dict], case: str, branch: int, dispersed: bool) -> list[dict]:
    rows = [p['cases'][case]['modes'][branch] for p in points]
    if dispersed:
        rows += [modes[branch] for p in points for modes in p['cases'][case]['dispersed']]
    return rows


def _range(points: list[dict], case: str, branch: int, dispersed: bool) -> dict:
    rows = _branch_rows(points, case, branch, dispersed)
    frequencies = [row['frequency'] for row in rows]
    dampings = [row['damping'] for row in rows]
    shares = [p['cases'][case]['modes'][branch]['share'] for p in points]
    return {'frequency': [min(frequencies), max(frequencies)],
            'damping': [min(dampings), max(dampings)], 'share': [min(shares), max(shares)]}


def _shaper_residuals(points: list[dict], cases: list[str], sample_time: float) -> dict:
    """Worst residual ``V`` each shaper leaves at each case's branches, dispersion included."""
    from walker_control.core.config import ShapingSettings
    from walker_control.core.input_shaping import ShaperKind, design_shaper
    from walker_core.parameter_file import ParameterFile

    shaping = ParameterFile.read(None).section(ShapingSettings, 'control.shaping.')
    frequency = SHAPED_FREQUENCY
    result = {'frequency': frequency, 'damping': shaping.damping,
              'tolerance': shaping.tolerance, 'insensitivity': shaping.insensitivity,
              'worst': {}}
    for kind in SHAPER_KINDS:
        shaper = design_shaper(ShaperKind(kind), frequency, shaping.damping, shaping.tolerance,
                               shaping.insensitivity, sample_time)
        worst = {}
        for case in cases:
            worst[case] = [
                max(float(shaper.residual(row['frequency'], row['damping']))
                    for row in _branch_rows(points, case, branch, True))
                for branch in range(len(points[0]['cases'][case]['modes']))]
        result['worst'][kind] = {'duration': shaper.duration, **worst}
    return result


def compute() -> dict:
    """Compute the whole map (SI units: rad/s, rad, m)."""
    from walker_core.robot_parameters import load_walker_parameters
    from walker_sim.core.flexibility import tune_flexibility

    params = load_walker_parameters()
    tuning = tune_flexibility(params)
    controllers = {name: _coarse_loops(overrides) for name, overrides in _controllers().items()}
    height = params.gripper.approach_height
    grids = {
        'reach': [_point(params, tuning, controllers, 0.0, r, height) for r in REACHES],
        'sweep': [_point(params, tuning, controllers, math.radians(d), params.truss.spacing,
                         height) for d in SWEEPS_DEG],
    }
    for name, path in _paths(params).items():
        grids[name] = [_point(params, tuning, controllers, t, r, height) for t, r in path]
    cases = [HELD, *controllers]
    walk = [p for name, points in grids.items() if 'turn' in name for p in points]
    everything = [p for points in grids.values() for p in points]
    sample_time = next(iter(controllers.values()))[1]
    branches = {case: range(len(walk[0]['cases'][case]['modes'])) for case in cases}
    return {
        'cases': cases, 'grids': grids,
        'summary': {case: [{'walk': _range(walk, case, k, False),
                            'walk dispersed': _range(walk, case, k, True),
                            'map dispersed': _range(everything, case, k, True)}
                           for k in branches[case]]
                    for case in cases},
        'shapers': {'at the nodes': _shaper_residuals(grids['sweep'], cases, sample_time),
                    'along the turns': _shaper_residuals(walk, cases, sample_time)},
        'dispersion': '+-15 % on both plant modes (springs x0.72-1.32), the four corners'}


def _span(pair: list[float], spec: str) -> str:
    return f'{pair[0]:{spec}}-{pair[1]:{spec}}'


def table(results: dict) -> str:
    """Return the Markdown table of ``results`` (as written to the JSON)."""
    lines = ['| joint 1 | mode | at one spacing: w [rad/s], damping, share, tip ring '
             '[um per rad/s^2] | along the turns: w [rad/s] | with +-15 % [rad/s] '
             '| damping | share | reach 0.5-1.1 m, +-15 % [rad/s] '
             '| worst V of ZV, ZVD, EI, SI at 18 rad/s, at the nodes; along the turns |',
             '| --- | --- | --- | --- | --- | --- | --- | --- | --- |']
    spacing = results['grids']['sweep'][0]
    shapers = results['shapers']
    for case in results['cases']:
        for branch, summary in enumerate(results['summary'][case]):
            here = spacing['cases'][case]['modes'][branch]
            ring = ('-' if case == HELD else
                    f'{here["weight"] * spacing["inertia"] * 1e6:.3g}')
            residuals = '; '.join(
                ', '.join(f'{shapers[scope]["worst"][kind][case][branch]:.2f}'
                          for kind in SHAPER_KINDS)
                for scope in ('at the nodes', 'along the turns'))
            walk, dispersed = summary['walk'], summary['walk dispersed']
            lines.append(
                f'| {case} | {branch + 1} | {here["frequency"]:.1f}, {here["damping"]:.3f}, '
                f'{here["share"]:.2f}, {ring} | {_span(walk["frequency"], ".1f")} '
                f'| {_span(dispersed["frequency"], ".1f")} '
                f'| {_span(dispersed["damping"], ".3f")} | {_span(walk["share"], ".2f")} '
                f'| {_span(summary["map dispersed"]["frequency"], ".1f")} | {residuals} |')
    return '\n'.join(lines)


def figure(results: dict) -> None:
    """Joint 1's modes against the reach and along the turns, the dispersion as a band."""
    from walker_control.analysis.plotting import pyplot, save_figure

    plt = pyplot()
    fig, (by_reach, by_sweep) = plt.subplots(1, 2, figsize=(8.0, 3.6), sharey=True)
    colours = {HELD: 'tab:blue', 'paper': 'tab:red', 'lowpass-2@12': 'tab:orange'}
    styles = ('-', '--')
    for case in results['cases']:
        points = results['grids']['reach']
        reach = [p['reach'] for p in points]
        for branch in range(len(points[0]['cases'][case]['modes'])):
            nominal = [p['cases'][case]['modes'][branch]['frequency'] for p in points]
            spread = [[modes[branch]['frequency'] for modes in p['cases'][case]['dispersed']]
                      for p in points]
            by_reach.fill_between(reach, [min(s) for s in spread], [max(s) for s in spread],
                                  color=colours[case], alpha=0.15, linewidth=0)
            by_reach.plot(reach, nominal, styles[branch], color=colours[case],
                          label=f'{case}, mode {branch + 1}')
            dominant = [(r, w) for p, r, w in zip(points, reach, nominal, strict=True)
                        if p['cases'][case]['dominant'] == branch]
            if dominant:
                by_reach.plot(*zip(*dominant, strict=True), 'o', color=colours[case], markersize=3)
            for name, width in (('quarter turn (torque bound)', 1.5),
                                ('half turn (torque bound)', 0.8)):
                path = results['grids'][name]
                by_sweep.plot([math.degrees(p['sweep']) for p in path],
                              [p['cases'][case]['modes'][branch]['frequency'] for p in path],
                              styles[branch], color=colours[case], linewidth=width)
    by_reach.axhline(SHAPED_FREQUENCY, color='grey', linewidth=0.6)
    by_sweep.axhline(SHAPED_FREQUENCY, color='grey', linewidth=0.6)
    by_reach.set_xlabel('reach r of the tip from the base yaw axis [m]')
    by_reach.set_ylabel("joint 1's modes [rad/s]")
    by_reach.set_title('against the reach (dots: dominant; band: +-15 %)', fontsize=8)
    by_reach.legend(fontsize=6, loc='upper right', ncol=2)
    by_sweep.set_xlabel('joint 1 along the turn, Theta [deg]')
    by_sweep.set_title('quarter (thick) and half turn at the torque bound\n'
                       '(as planned: one spacing, constant)', fontsize=8)
    for axes in (by_reach, by_sweep):
        axes.grid(True, alpha=0.3)
    fig.tight_layout()
    save_figure(fig, FIGURE)


def write_docs(results: dict) -> None:
    """Put the table between the markers of ``docs/controllers.md``."""
    text = DOCS.read_text()
    start, end = text.index(BEGIN) + len(BEGIN), text.index(END)
    DOCS.write_text(text[:start] + '\n' + table(results) + '\n' + text[end:])


def main(argv: list[str] | None = None) -> int:
    """Compute the map, print the table, write the JSON and figure; return the exit code."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--docs', action='store_true', help='write the table into the docs')
    parser.add_argument('--from-json', action='store_true',
                        help='no computation: the table (and --docs) from the results file')
    args = parser.parse_args(argv)
    walker_env.reexec_in_environment(str(Path(__file__).resolve()), sys.argv[1:])
    if args.from_json:
        results = json.loads(RESULTS.read_text())
    else:
        started = time.monotonic()
        results = compute()
        RESULTS.parent.mkdir(parents=True, exist_ok=True)
        RESULTS.write_text(json.dumps(results, indent=1) + '\n')
        figure(results)
        print(f'computed in {time.monotonic() - started:.0f} s', flush=True)
    print(table(results))
    if args.docs:
        write_docs(results)
    return 0


if __name__ == '__main__':
    sys.exit(main())
