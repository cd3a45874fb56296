"""``ros2 run walker_headless figure6``: the paper's Figure 6 experiment on the pybullet plant.

Joint 1 moves 0.5 rad in 4 s in COARSE mode (a half-cosine setpoint), the other joints HOLD,
with Ka = 0 and with the file's Ka, gripper a screwed in and gripper b free at the approach
height above its node (the arm free to turn about joint 1, as in the paper's experiment). The
experiment and its table are :mod:`walker_control.analysis.figure6`'s; this is where the plant
core (``walker_sim``) and the controller cores meet, as they do in the headless loop.
``--model two-mass`` runs it on a labelled two-mass model of joint 1 instead (not the plant).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

from walker_control.analysis.command import DEFAULT_OUT
from walker_control.analysis.figure6 import PlantCore, TwoMassJoint1Model, report_figure6

__all__ = ['plant_factory', 'main']


def plant_factory(model: str, params_file: str | None, settings,
                  walker=None) -> tuple[Callable[[], PlantCore], str]:
    """Return a maker of the experiment's plant and its name in the table.

    ``model`` is ``'plant'`` (the pybullet plant, gripper b free at the approach height) or
    ``'two-mass'``; ``params_file`` the parameter file (``None``: the installed one);
    ``walker`` its robot (default: read through the configuration loader).

    Raises
    ------
    ParameterError
        If the file is refused by the configuration loader (the message names the parameter).
    """
    if model == 'two-mass':
        return lambda: TwoMassJoint1Model(settings), 'two-mass model of joint 1 (NOT the plant)'
    from walker_config.core.configuration import load_configuration
    from walker_sim.core import make_plant

    walker = walker or load_configuration(params_file).walker
    height = walker.gripper.approach_height
    return (lambda: make_plant(params_file, other_attached=False,
                               other_height=height)), 'pybullet plant'


def main(argv: Sequence[str] | None = None) -> int:
    """Run the experiment, print its table and draw ``figure6.png``; return the exit code."""
    from walker_config.core.configuration import load_configuration
    from walker_core.parameter_schema import ParameterError

    parser = argparse.ArgumentParser(prog='figure6', description=__doc__.split('\n\n')[0])
    parser.add_argument('--out', type=Path, default=DEFAULT_OUT,
                        help='directory for the figure (default: runs/analysis)')
    parser.add_argument('--params-file', default=None,
                        help='parameter file (default: walker_core/config/walker.yaml)')
    parser.add_argument('--model', choices=('plant', 'two-mass'), default='plant',
                        help='plant to run on (default: the pybullet plant)')
    args = parser.parse_args(argv)
    try:
        configuration = load_configuration(args.params_file)
        settings = configuration.controllers
        factory, what = plant_factory(args.model, args.params_file, settings,
                                      configuration.walker)
    except ParameterError as error:
        print(f'refused: {error}')
        return 2
    report_figure6(factory, what, settings, args.out)
    return 0


if __name__ == '__main__':
    sys.exit(main())
