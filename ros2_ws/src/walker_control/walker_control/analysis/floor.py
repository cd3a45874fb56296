"""``control_analysis floor``: joint 1's fastest sweeps, with and without its command filter."""

from __future__ import annotations

import argparse
import dataclasses
import math
from collections.abc import Sequence


__all__ = ['SweepFloor', 'sweep_floors', 'run_floor', 'FLOOR_SWEEPS', 'FLOOR_SAMPLE_TIME']


#: Sweeps of a step about the base [deg]: the quarter and the half turn of the default truss.
FLOOR_SWEEPS = (90.0, 180.0)
FLOOR_SAMPLE_TIME = 0.01  # [s] the programme's period (2 ms and 10 ms agree within 6 ms)


@dataclasses.dataclass(frozen=True)
class SweepFloor:
    """Joint 1's fastest sweep [s], with no filter and through its command filter."""

    sweep: float        # [deg]
    unfiltered: float   # [s] until the tip is within the tolerance for good, no filter
    filtered: float     # [s] the same, through joint 1's command filter


def sweep_floors(settings, radius: float, tip_tolerance: float,
                 sweeps: Sequence[float] = FLOOR_SWEEPS,
                 sample_time: float = FLOOR_SAMPLE_TIME) -> list[SweepFloor]:
    """Joint 1's fastest sweeps at a stance, at the drive's full limits, with and without filter.

    The acceleration limit is the torque the yaw drive has left after its Coulomb friction over
    joint 1's inertia with the tip at ``radius`` (eq (9)); the rate limit is its velocity limit;
    the move has arrived once the shaped reference is within ``tip_tolerance / radius`` of its
    end for good (:func:`~walker_control.core.fastest_move.fastest_move_through_filter`). No
    plan beats it with the paper's controller structure (the whole command filtered).
    """
    from walker_core.dynamics import RigidModel, role_inertia
    from walker_core.kinematics import WalkerKinematics

    from walker_control.core.fastest_move import fastest_move_through_filter
    from walker_control.core.lowpass import design_lowpass_sos

    geometry = settings.robot.geometry
    joints = WalkerKinematics(geometry.l1, geometry.l2).inverse([0.0, radius, 0.0, 0.0, 0.0])
    inertia = role_inertia(joints, RigidModel.from_parameters(settings), 1)
    drive = settings.drive(1)
    acceleration = (drive.torque_limit - drive.friction_torque) / inertia
    filters = settings.control.filter
    designs = (design_lowpass_sos(0, 0.0, sample_time),
               design_lowpass_sos(filters.order[0], filters.corner[0], sample_time,
                                  filters.kind))
    floors = []
    for sweep in sweeps:
        unfiltered, filtered = (
            fastest_move_through_filter(math.radians(sweep), drive.velocity_limit,
                                        acceleration, sos, sample_time,
                                        tip_tolerance / radius).arrival
            for sos in designs)
        floors.append(SweepFloor(sweep, unfiltered, filtered))
    return floors


def run_floor(args: argparse.Namespace) -> int:
    """Print joint 1's fastest sweeps at ``args.radius`` [m]; 2 if refused."""
    from walker_core.robot_parameters import load_walker_parameters

    from walker_control.core.config import load_controller_settings

    try:
        settings = load_controller_settings(args.params_file)
        radius = args.radius or load_walker_parameters(args.params_file).truss.spacing
        floors = sweep_floors(settings, radius, args.tolerance)
    except ValueError as error:  # invalid parameters, a tip out of reach: said, nothing shown
        print(f'refused: {error}')
        return 2
    filters = settings.control.filter
    print(f"Joint 1's fastest sweep with the tip at {radius:g} m, until the tip is within "
          f'{args.tolerance * 1e3:g} mm of the target for good (full torque and rate; '
          f'{FLOOR_SAMPLE_TIME * 1e3:g} ms programme)')
    print(f' sweep | no filter | through its filter ({filters.kind} {filters.order[0]} '
          f'@ {filters.corner[0]:g} rad/s)')
    for floor in floors:
        print(f' {floor.sweep:5.0f} | {floor.unfiltered:7.2f} s | {floor.filtered:.2f} s')
    return 0
