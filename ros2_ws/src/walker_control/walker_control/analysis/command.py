"""Reproduce the paper's section 4: eq (14), Routh-Hurwitz (15)/(16), Figure 5.

Command line (console script ``control_analysis``)::

    control_analysis routh   [--out DIR]   eq (15) against Routh arrays and poles over a grid
    control_analysis bode    [--out DIR]   Figure 5 (wf/wc = 5, several Ka) with its table
    control_analysis design  [--params-file F]  the stability check of every loop in the file
    control_analysis floor   [--radius R] [--tolerance E]   joint 1's fastest sweeps

Each subcommand prints a table and writes PNG figures (matplotlib, Agg backend) into ``--out``
(default ``runs/analysis``); one module per subcommand (:mod:`.routh`, :mod:`.bode`,
:mod:`.design`, :mod:`.floor`). Figure 6 runs on the plant: ``ros2 run walker_headless
figure6`` (:mod:`walker_headless.figure6`; the experiment itself is :mod:`.figure6`).
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Sequence
from pathlib import Path


from walker_control.analysis.bode import run_bode
from walker_control.analysis.design import run_design
from walker_control.analysis.floor import run_floor
from walker_control.analysis.routh import run_routh

__all__ = ['main', 'DEFAULT_OUT']

DEFAULT_OUT = Path('runs') / 'analysis'


def _positive(text: str) -> float:
    """Return an option's value as a finite number > 0 (argparse refuses anything else)."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0.0):
        raise argparse.ArgumentTypeError(f'expected a finite number > 0, got {text!r}')
    return value


def main(argv: Sequence[str] | None = None) -> int:
    """Run a subcommand; return the exit code."""
    parser = argparse.ArgumentParser(prog='control_analysis',
                                     description=__doc__.split('\n\n')[0])
    sub = parser.add_subparsers(dest='command', required=True)
    for name, text in (('routh', 'eq (15) against Routh-Hurwitz and the poles'),
                       ('bode', 'Figure 5 and its bandwidth table'),
                       ('design', 'the stability check of the parameter file'),
                       ('floor', "joint 1's fastest sweeps, with and without its filter")):
        command = sub.add_parser(name, help=text)
        command.add_argument('--out', type=Path, default=DEFAULT_OUT,
                             help='directory for figures (default: runs/analysis)')
        command.add_argument('--params-file', default=None,
                             help='parameter file (default: walker_core/config/walker.yaml)')
        if name == 'floor':
            command.add_argument('--radius', type=_positive, default=None,
                                 help='tip distance from the base yaw axis [m] (default: the '
                                      'truss spacing)')
            command.add_argument('--tolerance', type=_positive, default=0.0005,
                                 help='arrival band at the tip [m] (default: 0.0005, the '
                                      "supervisor's insertion_alignment)")
    args = parser.parse_args(argv)
    runner = {'routh': run_routh, 'bode': run_bode, 'design': run_design,
              'floor': run_floor}[args.command]
    return runner(args)

