"""The bang-bang planner's numbers for the robot in the parameter file (docs/planner.md).

``python -m walker_planner.report`` prints, for 90 and 180 deg steps at the truss spacing: the
midpoint radius, switch and midpoint times, torque ratio, torques and duration of the nominal
plan and of the time-optimal bound; and, for each, the endpoint error of the planned torques
driven open loop through the fuller models (:mod:`walker_planner.core.simplification`) and the
duration at which those models could follow the same path within the same torques.
"""

from __future__ import annotations

import math
import sys

from walker_core.parameter_schema import load_parameter_file, section_from_flat
from walker_core.robot_parameters import default_parameter_file, load_walker_parameters
from walker_planner.core.bounds import bound_solution
from walker_planner.core.node_to_node import PlanarModel, solve_node_to_node
from walker_planner.core.parameters import PREFIX, PlannerParameters
from walker_planner.core.simplification import (
    PlanarDynamics, feasible_duration, simplification_errors)

__all__ = ['solutions', 'main']


def solutions(robot=None, planner=None) -> dict:
    """Nominal and bound solutions of 90 and 180 deg steps, by name."""
    robot = robot or load_walker_parameters()
    planner = planner or section_from_flat(
        PlannerParameters, load_parameter_file(default_parameter_file()), PREFIX)
    l2 = robot.robot.geometry.l2
    rho = robot.truss.spacing / (2.0 * l2)
    rho_min = min(planner.bang_bang.min_radius / (2.0 * l2), rho)
    nominal = PlanarModel.from_parameters(robot, planner.bang_bang.torque_fraction,
                                          planner.bang_bang.velocity_fraction)
    found = {}
    for sweep in (90, 180):
        half = 0.5 * math.radians(sweep)
        found[f'{sweep} deg nominal'] = solve_node_to_node(nominal, rho, half, rho_min)
        found[f'{sweep} deg bound'] = bound_solution(robot, math.radians(sweep), rho,
                                                     rho_min=rho_min)
    return found


def main(argv: list[str] | None = None) -> int:
    """Print the tables (Markdown)."""
    robot = load_walker_parameters()
    found = solutions(robot)
    print('| step | rho(0) | rho(phi2) | phi1 | phi2 | tau = tau1/tau3 | tau1 [N m] | '
          'tau3 [N m] | duration [s] | set by |')
    print('| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |')
    for name, s in found.items():
        p = s.profile
        print(f'| {name} | {p.rho_start:.4f} | {p.rho_mid:.4f} | {p.phi1:.4f} | {p.phi2:.4f} | '
              f'{p.tau:.4f} | {s.circular_torque:.3f} | {s.radial_torque:.3f} | '
              f'{s.duration:.3f} | {s.binding_limit} |')
    print()
    print('| step | model | endpoint error [m] | radius error [m] | angle error [deg] | '
          'left the workspace at [s] | feasible duration [s] |')
    print('| --- | --- | --- | --- | --- | --- | --- |')
    for name, s in found.items():
        for error in simplification_errors(s, robot):
            dynamics = PlanarDynamics.named(error.model, s, robot)
            feasible = feasible_duration(s, dynamics, s.model.circular_torque,
                                         s.model.radial_torque)
            stopped = f'{error.end_time:.3f}' if error.stopped else '-'
            print(f'| {name} | {error.model} | {error.position:.3g} | {error.radius:.3g} | '
                  f'{math.degrees(error.angle):.3g} | {stopped} | {feasible:.3f} |')
    return 0


if __name__ == '__main__':
    sys.exit(main())
