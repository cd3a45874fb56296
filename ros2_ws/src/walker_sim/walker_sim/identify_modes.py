"""Measure the structural modes the joints see (``ros2 run walker_sim identify_modes``).

Rings each joint of the simulated plant with a torque doublet, the other joints held, and fits
the free response (:mod:`walker_sim.core.identification`). Prints a table of the mode seen at
each joint against the paper's figure and, optionally, writes the results as JSON and a plot of
each joint's response. No ROS graph is needed.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_core.parameter_schema import ParameterError
from walker_core.robot_parameters import load_walker_parameters
from walker_sim.core.config import load_sim_parameters
from walker_sim.core.flexibility import IDENTIFIED_JOINTS, default_stance, tune_flexibility
from walker_sim.core.identification import Excitation, JointModes, identify_modes

__all__ = ['main', 'format_table', 'results_document']


def format_table(results: list[JointModes], predicted: dict[str, float]) -> str:
    """Text table: joint, measured mode, damping, predicted, target, error."""
    lines = [f'{"joint":<15} {"role":<5} {"measured":>10} {"damping":>8} {"predicted":>10} '
             f'{"target":>8} {"error":>7}',
             f'{"":<15} {"":<5} {"[rad/s]":>10} {"[-]":>8} {"[rad/s]":>10} {"[rad/s]":>8} '
             f'{"[%]":>7}']
    for result in results:
        role = f'J{PHYSICAL_JOINT_NAMES.index(result.joint) + 1}'
        prediction = predicted.get(result.joint)
        lines.append(
            f'{result.joint:<15} {role:<5} {result.seen.frequency:>10.2f} '
            f'{result.seen.damping:>8.4f} '
            f'{"-" if prediction is None else f"{prediction:.2f}":>10} '
            f'{"-" if result.target is None else f"{result.target:.1f}":>8} '
            f'{"-" if result.error is None else f"{100 * result.error:+.1f}":>7}')
    return '\n'.join(lines)


def results_document(results: list[JointModes], tuning, stance) -> dict:
    """JSON-ready summary of an identification run."""
    return {
        'stance_rad': [float(a) for a in stance],
        'stance': 'gripper a attached, gripper b free one truss spacing away, elbow up, '
                  'grippers vertical; the tested joint frictionless, the others held',
        'bending_stiffness_nm_per_rad': {'in_plane': tuning.in_plane_stiffness,
                                         'out_of_plane': tuning.out_of_plane_stiffness},
        'bending_damping_nms_per_rad': {'in_plane': tuning.in_plane_damping,
                                        'out_of_plane': tuning.out_of_plane_damping},
        'predicted_rad_s': tuning.predicted,
        'clamped_modes_rad_s': list(tuning.clamped),
        'joints': [{'joint': r.joint, 'seen_rad_s': r.seen.frequency,
                    'damping': r.seen.damping, 'target_rad_s': r.target,
                    'error': r.error, 'modes': [dataclasses.asdict(m) for m in r.modes]}
                   for r in results],
    }


def main(argv=None) -> int:
    """Run the identification; exit code 1 when a mode is more than 10% off its target."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--params-file', help='parameter file (default: the installed one)')
    parser.add_argument('--all-joints', action='store_true',
                        help='also ring joints 4 and 5 (no paper figure to compare)')
    parser.add_argument('--duration', type=float, default=Excitation.duration,
                        help='record length after the doublet [s]')
    parser.add_argument('--json', type=Path, help='write the results here')
    parser.add_argument('--plot', type=Path, help='write a plot of the responses here (PNG)')
    args = parser.parse_args(argv)
    try:
        params = load_walker_parameters(args.params_file)
        sim = load_sim_parameters(args.params_file)
    except ParameterError as error:
        print(f'identify_modes: {error}', file=sys.stderr)
        return 2
    joints = PHYSICAL_JOINT_NAMES if args.all_joints else IDENTIFIED_JOINTS
    excitation = Excitation(duration=args.duration)
    tuning = tune_flexibility(params)
    results = identify_modes(params, sim, joints, excitation)
    print(format_table(results, tuning.predicted))
    print(f'stance: gripper a attached, gripper b free one spacing away; joint angles '
          f'{", ".join(f"{a:.3f}" for a in default_stance(params))} rad')
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
    """Plot each joint's free response and its spectrum."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    import numpy as np

    from walker_sim.core.config import StartConfiguration
    from walker_sim.core.identification import (
        RIG_SOLVER_ITERATIONS, RIG_SOLVER_RESIDUAL, ring_joint)
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
            time, velocity = ring_joint(plant, joint, excitation, period)
            row[0].plot(time, velocity, lw=0.8)
            row[0].set(xlabel='time [s]', ylabel='velocity [rad/s]', title=joint)
            spectrum = np.abs(np.fft.rfft((velocity - velocity.mean())
                                          * np.hanning(len(velocity))))
            frequency = 2 * np.pi * np.fft.rfftfreq(len(velocity), period)
            row[1].semilogy(frequency, spectrum + 1e-12, lw=0.8)
            row[1].set(xlabel='frequency [rad/s]', ylabel='|V|', xlim=(0, 400))
    figure.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=110)
    plt.close(figure)


if __name__ == '__main__':
    sys.exit(main())
