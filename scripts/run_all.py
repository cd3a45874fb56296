#!/usr/bin/env python3
"""walker's main job: set up what is missing, bring up the node graph, walk, report.

Usage: ``python3 scripts/run_all.py`` (no arguments needed).

The node graph (plant, five joint controllers, planner, step-phase supervisor) is being built
package by package; until the walk exists this command sets everything up, validates the
parameter file, shows the robot model it describes, and says which parts of the graph exist.
"""

import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import walker_env


def _parse_arguments() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--params-file', default=None,
                        help='parameter file (default: walker_core/config/walker.yaml)')
    return parser.parse_args()


def main() -> int:
    """Run the main job; return the process exit code."""
    args = _parse_arguments()
    walker_env.reexec_in_environment(os.path.abspath(__file__), sys.argv[1:])

    import numpy as np

    from walker_core.dynamics import RigidModel, diagonal_inertia
    from walker_core.kinematics import WalkerKinematics
    from walker_core.parameter_schema import ParameterError
    from walker_core.robot_parameters import default_parameter_file, load_walker_parameters
    from walker_core.truss import Truss

    path = args.params_file or default_parameter_file()
    try:
        params = load_walker_parameters(path)
    except ParameterError as error:
        print(f'[walker] invalid parameter file {path}: {error}', file=sys.stderr)
        return 2
    kinematics = WalkerKinematics.from_parameters(params)
    truss = Truss.from_parameters(params)
    stance = kinematics.inverse([0.0, truss.spacing, 0.0, 0.0, 0.0])
    inertia = diagonal_inertia(stance, RigidModel.from_parameters(params))
    print(f'[walker] parameter file: {path}')
    print(f'[walker] robot {params.robot.name!r}: l1 = {params.robot.geometry.l1} m, '
          f'l2 = {params.robot.geometry.l2} m; truss {truss.columns} x {truss.rows} nodes, '
          f'spacing {truss.spacing} m')
    print('[walker] stance between neighbouring nodes, J1..J5 [deg]: '
          + ', '.join(f'{v + 0.0:.1f}' for v in np.degrees(stance)))
    print('[walker] rigid-model inertia at that stance, I11..I55 [kg*m^2]: '
          + ', '.join(f'{v:.3f}' for v in inertia))
    print('[walker] the node graph (plant, controllers, planner, supervisor) does not exist '
          'yet: nothing to bring up, no walk to run. Set-up and model check complete.')
    return 0


if __name__ == '__main__':
    sys.exit(main())
