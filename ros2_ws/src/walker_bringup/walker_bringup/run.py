"""run_all.py: the command line of a walk session (:mod:`walker_bringup.session`).

Bring the walker up on the pybullet plant (its graph in the arrangement the options choose, or
the headless runner), walk to a target node, record, summarise, shut down, report. The options
become a :class:`~walker_bringup.session.SessionOptions` (:mod:`walker_bringup.run_arguments`
holds them); everything else is the session's.
Exit codes: 0 reached, 1 not, 2 refused (nothing started), 3 the graph did not come up, 4 a
process left running, 5 a node given up on, 6 no report, 130 interrupted. See
docs/reliability.md.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
from pathlib import Path

from walker_bringup.core.respawn import RespawnPolicy
from walker_bringup.run_arguments import REALTIME_PRIORITY, SERVE_SPLIT, parse_arguments
from walker_bringup.session import (
    Arrangement, SessionError, SessionOptions, WalkSession, WalkSummary)
from walker_bringup.transport import PROFILES_VARIABLE

__all__ = ['main', 'parse_arguments', 'session_options', 'REALTIME_PRIORITY', 'SERVE_SPLIT']

def session_options(args: argparse.Namespace) -> SessionOptions:
    """Return the session's options for ``run_all.py``'s parsed ``args``."""
    arrangement = Arrangement.HEADLESS if args.headless else Arrangement.COMPOSED \
        if args.composed else Arrangement.COMPOSED_LOOP if args.composed_loop \
        else Arrangement.GROUPED if args.grouped_controllers else Arrangement.PROCESSES
    return SessionOptions(
        arrangement=arrangement, sim_time=args.sim_time, record=args.record,
        report=args.report, out=args.out, namespace=args.namespace,
        respawn=RespawnPolicy(args.respawn_delay, args.respawn_limit),
        startup_timeout=args.startup_timeout, walk_timeout=args.walk_timeout,
        quiet=args.quiet, transport=args.transport, realtime=args.realtime,
        plant_params_file=Path(args.plant_params_file).resolve()
        if args.plant_params_file else None,
        foxglove_port=args.foxglove_port if args.foxglove else None,
        bag_split=(args.max_bag_size, args.max_bag_duration, args.max_bag_files),
        walkers=args.walkers, overrides=tuple(args.params),
        truss_survey=Path(args.truss_survey) if args.truss_survey else None)


def parameter_overrides(args: argparse.Namespace) -> dict:
    """Return ``--param`` values as the parameter files take them (name -> YAML value)."""
    import yaml

    return {name: yaml.safe_load(value) for name, value in args.params}


def main(argv: list[str] | None = None) -> int:
    """Run the main job; return the exit code (0 when every walk reached its target).

    The process's own participant is made with the graph's transport profile; the caller's
    environment is given back as it was, so a later graph started from the same process (a
    test, a campaign) chooses its own transport again.
    """
    before = os.environ.get(PROFILES_VARIABLE)
    try:
        return _run(parse_arguments(argv))
    finally:
        if before is None:
            os.environ.pop(PROFILES_VARIABLE, None)
        else:
            os.environ[PROFILES_VARIABLE] = before


def _run(args: argparse.Namespace) -> int:
    from walker_config.core.configuration import load_configuration, load_plant
    from walker_core.parameter_file import ParameterFile
    from walker_core.parameter_schema import ParameterError
    from walker_core.progress import ProgressLine

    say = ProgressLine(args.quiet, stream=sys.stdout)
    # Everything the command line names is checked before anything is started or written.
    overrides = parameter_overrides(args)
    try:
        unknown = sorted(set(overrides) - set(ParameterFile.read(args.params_file).values))
        if unknown:
            raise ParameterError(f'--param {unknown[0]}: no such parameter in the file')
        configuration = load_configuration(args.params_file, overrides)
    except ParameterError as error:
        say.error(f'[walker] error: {args.params_file or "the installed walker.yaml"}: {error}')
        return 2
    if args.plant_params_file is not None:
        try:
            plant = load_plant(args.plant_params_file, overrides)
        except ParameterError as error:
            say.error(f'[walker] error: --plant-params-file {args.plant_params_file}: {error}')
            return 2
        configuration = dataclasses.replace(configuration, plant=plant)
    if args.walkers > 1 and args.serve:
        say.error('[walker] error: --serve keeps one walker up for walkerctl: leave --walkers '
                  'out')
        return 2
    try:
        session = WalkSession(configuration, session_options(args), say)
        if args.walk and not args.serve and not args.headless:
            session.check_target(args.target)
    except SessionError as error:
        say.error(f'[walker] error: {error}')
        return 2
    code = 0
    try:
        session.start()
        if args.serve:
            session.serve()
        elif args.walk:
            summaries = session.walk(args.target)
            summaries = [summaries] if isinstance(summaries, WalkSummary) else summaries
            code = max(summary.code for summary in summaries)
    except SessionError as error:
        if error.code not in (5, 130):  # those said what happened as they stopped
            say.error(f'[walker] error: {error}')
        code = error.code
    finally:
        stopped = session.stop()  # always: nothing is left running, whatever happened
        code = code or stopped
    return code
