"""The bang-bang planner's numbers for the robot in the parameter file (docs/planner.md).

``python -m walker_planner.report`` prints, for 90 and 180 deg steps at the truss spacing:

* the midpoint radius, switch and midpoint times, torque ratio, torques and duration of the
  nominal plan and of the paper's family minimum (the torque limits alone);
* for each, the endpoint error of the planned torques driven open loop through the fuller
  models (:mod:`walker_planner.core.simplification`) and the duration at which those models
  could follow the same path within the same torques;
* the time-optimal lower bound, the minimum time found by direct optimisation and the family
  minimum side by side, under the torque and rate limits and under the torque limits alone
  (:mod:`walker_planner.core.bounds`); ``--no-direct`` leaves out the direct method (seconds).
"""

from __future__ import annotations

import math
import sys

from walker_core.parameter_file import ParameterFile
from walker_core.robot_parameters import WalkerParameters
from walker_planner.core.bounds import family_minimum_solution, minimum_time_found, move_problem
from walker_planner.core.minimum_time import lower_bound
from walker_planner.core.node_to_node import PlanarModel, solve_node_to_node
from walker_planner.core.parameters import PREFIX, PlannerParameters
from walker_planner.core.simplification import (
    PlanarDynamics,
    feasible_duration,
    simplification_errors,
)

__all__ = ['solutions', 'main']


def solutions(robot=None, planner=None) -> dict:
    """Nominal and family-minimum bang-bang solutions of 90 and 180 deg steps, by name."""
    defaults = ParameterFile.read()
    robot = robot or defaults.section(WalkerParameters)
    planner = planner or defaults.section(PlannerParameters, PREFIX)
    l2 = robot.robot.geometry.l2
    rho = robot.truss.spacing / (2.0 * l2)
    rho_min = min(planner.bang_bang.min_radius / (2.0 * l2), rho)
    nominal = PlanarModel.from_parameters(robot, planner.bang_bang.torque_fraction,
                                          planner.bang_bang.velocity_fraction)
    found = {}
    for sweep in (90, 180):
        half = 0.5 * math.radians(sweep)
        found[f'{sweep} deg nominal'] = solve_node_to_node(nominal, rho, half, rho_min)
        found[f'{sweep} deg family minimum'] = family_minimum_solution(
            robot, math.radians(sweep), rho, rho_min=rho_min)
    return found


def bound_rows(robot=None, planner=None, direct: bool = True) -> list[dict]:
    """Give the three numbers of 90 and 180 deg steps, with and without the rate limits [s].

    Each row has ``step``, ``limits``, ``lower_bound`` (provable), ``minimum_found`` (direct
    optimisation, None without ``direct``), ``family_minimum`` (the paper's family under the
    same limits: at the full torque and, with rate limits, the full velocity limits) and
    ``solve_time`` of the direct method.
    """
    defaults = ParameterFile.read()
    robot = robot or defaults.section(WalkerParameters)
    planner = planner or defaults.section(PlannerParameters, PREFIX)
    radius, min_radius = robot.truss.spacing, planner.bang_bang.min_radius
    l2 = robot.robot.geometry.l2
    rows = []
    for rates, limits in ((True, 'torques and rates'), (False, 'torques alone')):
        family_model = PlanarModel.from_parameters(robot, 1.0, 1.0 if rates else None)
        for sweep in (90, 180):
            problem = move_problem(robot, math.radians(sweep), radius, min_radius, rates)
            move = minimum_time_found(robot, math.radians(sweep), radius, min_radius,
                                      rates) if direct else None
            family = solve_node_to_node(family_model, radius / (2 * l2),
                                        0.5 * math.radians(sweep),
                                        min(min_radius, radius) / (2 * l2))
            rows.append({'step': f'{sweep} deg', 'limits': limits,
                         'lower_bound': lower_bound(problem),
                         'minimum_found': move.duration if move else None,
                         'family_minimum': family.duration,
                         'solve_time': move.solve_time if move else None})
    return rows


def main(argv: list[str] | None = None) -> int:
    """Print the tables (Markdown); ``--no-direct`` skips the direct method."""
    argv = sys.argv[1:] if argv is None else argv
    robot = ParameterFile.read().section(WalkerParameters)
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
    print()
    print('| step | limits | time-optimal lower bound [s] | minimum time found by direct '
          "optimisation [s] | paper's family minimum [s] | direct method solve [s] |")
    print('| --- | --- | --- | --- | --- | --- |')
    for row in bound_rows(robot, direct='--no-direct' not in argv):
        found_cell = '-' if row['minimum_found'] is None else f'{row["minimum_found"]:.4f}'
        solve_cell = '-' if row['solve_time'] is None else f'{row["solve_time"]:.2f}'
        print(f'| {row["step"]} | {row["limits"]} | {row["lower_bound"]:.4f} | {found_cell} | '
              f'{row["family_minimum"]:.4f} | {solve_cell} |')
    return 0


if __name__ == '__main__':
    sys.exit(main())
