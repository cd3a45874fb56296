#!/usr/bin/env python3
"""Planning time of every trajectory type, and of the bang-bang solve alone (median, p99).

Usage: ``python3 benchmarks/planner_benchmark.py [--runs N] [--out FILE]``. It sets up the
environment like ``scripts/run_tests.py``, times each case many times on this machine, prints a
table and writes ``benchmarks/results/planner.json``. The numbers depend on the machine and on
its load; the JSON records both (CPU count, load average) so runs can be compared honestly.

Cases:

* ``solve``: the bang-bang node-to-node solve (midpoint radius, switch, torque ratio and time
  scale; eqs (23)-(27)) for 90 and 180 deg steps, nominal and at the time-optimal bound. The
  target is under 5 ms.
* ``plan``: a whole ``plan_trajectory`` request of each of the nine types without ROS:
  validation, building, mapping Cartesian paths through the IK at every control period,
  checking the limits and computing the bound. It grows with the trajectory's duration (one
  IK solution per 2 ms sample for Cartesian types).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / 'scripts'))

import walker_env  # noqa: E402


def _cases():
    import math

    from walker_core.parameter_file import ParameterFile
    from walker_core.robot_parameters import WalkerParameters
    from walker_planner.core.bounds import family_minimum_solution, move_problem
    from walker_planner.core.direct_method import solve_minimum_time
    from walker_planner.core.minimum_time import lower_bound
    from walker_planner.core.node_to_node import PlanarModel, solve_node_to_node
    from walker_planner.core.parameters import PREFIX, PlannerParameters
    from walker_planner.core.planning import PlanningContext, PlanRequest, plan

    defaults = ParameterFile.read()
    robot = defaults.section(WalkerParameters)
    planner = defaults.section(PlannerParameters, PREFIX)
    context = PlanningContext.from_parameters(robot, planner)
    nominal = PlanarModel.from_parameters(robot, planner.bang_bang.torque_fraction,
                                          planner.bang_bang.velocity_fraction)
    rho = robot.truss.spacing / (2 * robot.robot.geometry.l2)
    rho_min = planner.bang_bang.min_radius / (2 * robot.robot.geometry.l2)
    h = robot.gripper.approach_height
    above = (0.0, robot.truss.spacing, h)
    stance = tuple(context.kinematics.inverse([*above, 0.0, 0.0]))
    turned = (stance[0] + 0.4, *stance[1:4], stance[4] + 0.4)
    cases = {
        'solve bang_bang 90 deg (nominal)':
            lambda: solve_node_to_node(nominal, rho, math.pi / 4, rho_min),
        'solve bang_bang 180 deg (nominal)':
            lambda: solve_node_to_node(nominal, rho, math.pi / 2, rho_min),
        'solve bang_bang 90 deg (family minimum)':
            lambda: family_minimum_solution(robot, math.pi / 2, rho, None, rho_min),
        'solve bang_bang 180 deg (family minimum)':
            lambda: family_minimum_solution(robot, math.pi, rho, None, rho_min),
    }
    radius, min_radius = robot.truss.spacing, planner.bang_bang.min_radius
    for sweep in (90, 180):
        problem = move_problem(robot, math.radians(sweep), radius, min_radius)
        cases[f'solve time-optimal lower bound {sweep} deg'] = \
            (lambda p=problem: (lower_bound.cache_clear(), lower_bound(p)))
    for rates, what in ((True, 'torque and rate limits'), (False, 'torque limits alone')):
        for sweep in (90, 180):
            problem = move_problem(robot, math.radians(sweep), radius, min_radius, rates)
            cases[f'direct method: minimum time {sweep} deg, {what}'] = \
                (lambda p=problem: solve_minimum_time(p))
    requests = {
        'joint_parabolic_time': PlanRequest('joint_parabolic_time', 'a', stance, turned,
                                            duration=2.0),
        'joint_parabolic_accel': PlanRequest('joint_parabolic_accel', 'a', stance, turned),
        'joint_min_jerk': PlanRequest('joint_min_jerk', 'a', stance, turned),
        'cartesian_parabolic_time': PlanRequest('cartesian_parabolic_time', 'a', above,
                                                (0.1, 0.85, 0.1), duration=3.0),
        'cartesian_parabolic_accel': PlanRequest('cartesian_parabolic_accel', 'a', above,
                                                 (0.1, 0.85, 0.1)),
        'cartesian_line': PlanRequest('cartesian_line', 'a', (0.01, 0.89, h), above),
        'insertion_line': PlanRequest('insertion_line', 'a', above, (0.0, 0.9, 0.0)),
        'extraction_line': PlanRequest('extraction_line', 'a', (0.0, 0.9, 0.0), above),
        'bang_bang_node 90 deg': PlanRequest('bang_bang_node', 'a', above, (-0.9, 0.0, h)),
        'bang_bang_node 180 deg': PlanRequest('bang_bang_node', 'a', above, (0.0, -0.9, h)),
    }
    for name, request in requests.items():
        result = plan(request, context)
        cases[f'plan {name} ({result.duration:.2f} s, {len(result.times)} samples)'] = \
            (lambda r=request: plan(r, context))
    return cases


def _time(function, runs: int) -> list[float]:
    function()  # warm up caches and imports
    samples = []
    for _ in range(runs):
        started = time.perf_counter()
        function()
        samples.append(time.perf_counter() - started)
    return samples


def measure(runs: int, report=print) -> list[dict]:
    """Time every case; return ``{'case', 'median_ms', 'p99_ms', 'runs'}`` per case.

    Solves and joint-space plans run ``runs`` times, Cartesian plans a tenth as often (at
    least 10), the direct method 3 times. ``report`` receives one line per case (None:
    silent).
    """
    import numpy as np

    results = []
    if report:
        report(f'{"case":<72} {"median":>9} {"p99":>9} {"runs":>5}')
    for name, function in _cases().items():
        count = runs if name.startswith('solve') or 'joint' in name else max(10, runs // 10)
        if name.startswith('direct method'):
            count = 3
        samples = np.array(_time(function, count)) * 1e3
        median, p99 = float(np.median(samples)), float(np.percentile(samples, 99))
        results.append({'case': name, 'median_ms': round(median, 4), 'p99_ms': round(p99, 4),
                        'runs': count})
        if report:
            report(f'{name:<72} {median:8.3f}ms {p99:8.3f}ms {count:5d}')
    return results


def main() -> int:
    """Time every case, print the table, write the JSON."""
    walker_env.reexec_in_environment(os.path.abspath(__file__), sys.argv[1:], quiet=True)
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--runs', type=int, default=300,
                        help='runs per solve case (plans of Cartesian types get a tenth)')
    parser.add_argument('--out', type=Path, default=REPO / 'benchmarks' / 'results'
                        / 'planner.json')
    args = parser.parse_args()
    results = measure(args.runs)
    machine = {'cpus': os.cpu_count(), 'load_average': [round(x, 2) for x in os.getloadavg()],
               'python': platform.python_version(), 'machine': platform.machine()}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({'machine': machine, 'target_solve_ms': 5.0,
                                    'results': results}, indent=1) + '\n')
    print(f'machine: {machine}; written to {args.out}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
