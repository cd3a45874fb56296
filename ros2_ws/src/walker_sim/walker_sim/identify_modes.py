"""Measure the structural modes the joints see (``ros2 run walker_sim identify_modes``).

Strikes each joint of the simulated plant with a torque doublet, then holds all joints and
records the reaction torque at the struck joint's brake, and fits the modes
(:mod:`walker_sim.core.identification`): the mode seen at the joint is the lowest that rings
there. Also measures, for information, each joint's free-joint resonance (joint free, the
others held). Prints a table against the paper's figures and the eigen-analysis and, optionally,
writes the results as JSON and a plot of each record. No ROS graph is needed.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_core.parameter_schema import ParameterError
from walker_core.parameter_file import ParameterFile
from walker_sim.core.config import plant_sections
from walker_sim.core.flexibility import (
    IDENTIFIED_JOINTS, FlexTuning, default_stance, tune_flexibility)
from walker_sim.core.identification import Excitation, JointModes, identify_modes

__all__ = ['main', 'format_table', 'results_document']


def _cell(value: float | None, spec: str) -> str:
    return '-' if value is None else format(value, spec)


def format_table(results: list[JointModes], tuning: FlexTuning | None = None) -> str:
    """Text table: joint, held-arm mode measured, damping, amplitude, predicted, target, error.

    The amplitude is the mode's reaction torque at the brake when the joints are all held: a
    joint whose record holds nothing but solver noise (of the order of 1e-6 N*m) sees no mode.
    """
    predicted = {} if tuning is None else tuning.predicted
    free_predicted = {} if tuning is None else tuning.free_joint
    lines = [f'{"joint":<15} {"role":<5} {"measured":>9} {"damping":>8} {"amplitude":>9} '
             f'{"predicted":>9} {"target":>7} {"error":>6}   {"free-joint resonance":>22}',
             f'{"":<15} {"":<5} {"[rad/s]":>9} {"[-]":>8} {"[N*m]":>9} {"[rad/s]":>9} '
             f'{"[rad/s]":>7} {"[%]":>6}   {"measured / predicted":>22}']
    for result in results:
        role = f'J{PHYSICAL_JOINT_NAMES.index(result.joint) + 1}'
        free = result.free_joint
        free_text = (f'{_cell(None if free is None else free.frequency, ".2f")} / '
                     f'{_cell(free_predicted.get(result.joint), ".2f")}')
        lines.append(
            f'{result.joint:<15} {role:<5} {result.seen.frequency:>9.2f} '
            f'{result.seen.damping:>8.4f} {result.seen.amplitude:>9.2g} '
            f'{_cell(predicted.get(result.joint), ".2f"):>9} '
            f'{_cell(result.target, ".1f"):>7} '
            f'{_cell(None if result.error is None else 100 * result.error, "+.1f"):>6}   '
            f'{free_text:>22}')
    lines.append("measured: lowest mode ringing at the joint's brake, all five joints held; "
                 'free-joint resonance: the joint free, the others held (for the filters)')
    return '\n'.join(lines)


def _mode_list(modes) -> list[dict]:
    return [dataclasses.asdict(mode) for mode in modes]


def results_document(results: list[JointModes], tuning: FlexTuning, stance) -> dict:
    """JSON-ready summary of an identification run."""
    return {
        'stance_rad': [float(a) for a in stance],
        'stance': 'gripper a attached, gripper b free one truss spacing away, elbow up, '
                  'grippers vertical',
        'method': 'the joint, frictionless, struck by a torque doublet with the others held; '
                  'then all five held and the reaction torque at its brake recorded (held-arm '
                  'modes); separately, its velocity recorded while it rings free (free-joint '
                  'resonance)',
        'bending_stiffness_nm_per_rad': {'in_plane': tuning.in_plane_stiffness,
                                         'out_of_plane': tuning.out_of_plane_stiffness},
        'bending_damping_nms_per_rad': {'in_plane': tuning.in_plane_damping,
                                        'out_of_plane': tuning.out_of_plane_damping},
        'predicted_rad_s': tuning.predicted,
        'predicted_free_joint_rad_s': tuning.free_joint,
        'held_modes_rad_s': list(tuning.held),
        'joints': [{'joint': r.joint, 'seen_rad_s': r.seen.frequency,
                    'damping': r.seen.damping, 'target_rad_s': r.target, 'error': r.error,
                    'free_joint_rad_s': None if r.free_joint is None else r.free_joint.frequency,
                    'modes': _mode_list(r.modes), 'free_modes': _mode_list(r.free_modes)}
                   for r in results],
    }


def main(argv=None) -> int:
    """Run the identification; exit code 1 when a mode is more than 10% off its target."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--params-file', help='parameter file (default: the installed one)')
    parser.add_argument('--all-joints', action='store_true',
                        help='also ring joints 4 and 5 (no paper figure to compare)')
    parser.add_argument('--duration', type=float, default=Excitation.duration,
                        help='length of each record after the strike [s]')
    parser.add_argument('--no-free-joint', action='store_true',
                        help='skip the free-joint resonances (half the time)')
    parser.add_argument('--json', type=Path, help='write the results here')
    parser.add_argument('--plot', type=Path, help='write a plot of the records here (PNG)')
    args = parser.parse_args(argv)
    try:
        params, sim = plant_sections(ParameterFile.read(args.params_file))
        excitation = Excitation(duration=args.duration)
    except (ParameterError, ValueError) as error:
        print(f'identify_modes: {error}', file=sys.stderr)
        return 2
    joints = PHYSICAL_JOINT_NAMES if args.all_joints else IDENTIFIED_JOINTS
    tuning = tune_flexibility(params)
    results = identify_modes(params, sim, joints, excitation,
                             free_joint=not args.no_free_joint)
    print(format_table(results, tuning))
    print(f'stance: gripper a attached, gripper b free one spacing away; joint angles '
          f'{", ".join(f"{a:.3f}" for a in default_stance(params))} rad; physics '
          f'{sim.physics_rate:g} Hz')
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(
            results_document(results, tuning, default_stance(params)), indent=2) + '\n')
        print(f'wrote {args.json}')
    if args.plot:
        _plot(params, sim, joints, excitation, args.plot)
        print(f'wrote {args.plot}')
    off = [r for r in results if r.error is not None and abs(r.error) > 0.10]
    return 1 if off else 0


def _plot(params, sim, joints, excitation: Excitation, path: Path) -> None:
    """Plot each joint's brake torque (all joints held) and its spectrum."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    import numpy as np

    from walker_sim.core.config import StartConfiguration
    from walker_sim.core.identification import (
        RIG_SOLVER_ITERATIONS, RIG_SOLVER_RESIDUAL, strike_and_hold)
    from walker_sim.core.plant import WalkerPlant

    figure, axes = plt.subplots(len(joints), 2, figsize=(11, 2.6 * len(joints)),
                                squeeze=False)
    with WalkerPlant(params, sim) as plant:
        plant.set_solver(RIG_SOLVER_ITERATIONS, RIG_SOLVER_RESIDUAL)
        base = sim.start.base_node
        start = StartConfiguration('a', base, plant.truss.neighbors(base)[0], False, 0.0)
        period = 1.0 / params.timing.control_rate
        for row, joint in zip(axes, joints, strict=True):
            plant.reset(start)
            time, torque = strike_and_hold(plant, joint, excitation, period)
            row[0].plot(time, torque, lw=0.8)
            row[0].set(xlabel='time since all joints held [s]', ylabel='brake torque [N*m]',
                       title=joint)
            spectrum = np.abs(np.fft.rfft((torque - torque.mean()) * np.hanning(len(torque))))
            frequency = 2 * np.pi * np.fft.rfftfreq(len(torque), period)
            row[1].semilogy(frequency, spectrum + 1e-12, lw=0.8)
            row[1].set(xlabel='frequency [rad/s]', ylabel='|torque spectrum|', xlim=(0, 400))
    figure.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=110)
    plt.close(figure)


if __name__ == '__main__':
    sys.exit(main())
