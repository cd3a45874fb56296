"""One walk of a campaign run: the model's and the truth's parameter files in, a summary out.

A *walk function* takes a :class:`WalkRequest` and returns the walk's summary, the mapping
``run_all.py`` writes as ``summary.json`` (``steps``, ``reached``, ``message``; ``timed_out``
when it ran out of wall-clock time). It raises :class:`WalkError` when the walk could not be
carried out at all. Two are provided, each running ``run_all.py`` in a process of its own that
ends with its caller (a worker that dies takes its walk down with it), the plant given the
truth's file (``--plant-params-file``) and everything else the model's:

* ``headless`` (the default): the cores in one lock-step loop (``run_all.py --headless``), no
  DDS, many times faster than real time;
* ``graph``: the full sim-time ROS graph (``run_all.py --sim-time --composed-loop``), in a ROS
  domain of its own taken on the machine that runs it
  (:func:`walker_bringup.domains.isolated_domain`).

Any callable with the same signature serves, named ``module:function`` (the tests use a
fast stand-in).
"""

from __future__ import annotations

import dataclasses
import importlib
import json
import os
import signal
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

__all__ = ['WalkRequest', 'WalkError', 'WalkFunction', 'graph_walk', 'headless_walk', 'BACKENDS',
           'walk_function']

_STOP_GRACE = 60.0  # [s] for a walk told to stop to shut its graph down before it is killed
_STARTUP_ALLOWANCE = 300.0  # [s] beyond the walk's own timeout: bringing the graph up and down
_LOG_TAIL = 2000  # characters of a failed walk's output kept in its error


@dataclasses.dataclass(frozen=True)
class WalkRequest:
    """One walk to run.

    Attributes
    ----------
    model_file : Path
        The parameter file of the controllers, planner and supervisor (the model).
    truth_file : Path
        The plant's parameter file (the robot as it really is).
    target : str
        The truss node to walk to.
    out_dir : Path
        Where the walk writes (its summary, logs, and the bag when recorded).
    walk_timeout : float
        Wall-clock seconds the walk may take.
    record : bool
        Record the walk's bag (``out_dir/bag``) for the walk report.
    """

    model_file: Path
    truth_file: Path
    target: str
    out_dir: Path
    walk_timeout: float
    record: bool = False


class WalkError(RuntimeError):
    """A walk that could not be carried out (nothing to summarise); the message says why."""


WalkFunction = Callable[[WalkRequest], dict[str, Any]]


#: The walk's process: it asks for SIGTERM when its parent dies (Linux ``PR_SET_PDEATHSIG``,
#: 1), which run_all.py answers by stopping its graph, then runs run_all.py's main job.
_RUN_ALL = ('import ctypes, signal, sys; ctypes.CDLL(None).prctl(1, signal.SIGTERM); '
            'from walker_bringup.run import main; sys.exit(main(sys.argv[1:]))')


def _run_all_command(request: WalkRequest, options: list[str]) -> list[str]:
    """Return the ``run_all.py`` command of a walk: the two files, the target, the output."""
    command = [sys.executable, '-c', _RUN_ALL, *options, '--quiet',
               '--params-file', str(request.model_file),
               '--plant-params-file', str(request.truth_file),
               '--target', request.target, '--out', str(Path(request.out_dir) / 'walk'),
               '--walk-timeout', f'{request.walk_timeout:g}']
    return command + (['--no-report'] if request.record else ['--no-record'])


def _walk_in_process(request: WalkRequest, command: list[str], env: dict[str, str],
                     what: str) -> dict[str, Any]:
    """Run a walk's process to its end (stopped when it outlives its time); its summary.

    Raises
    ------
    WalkError
        The walk wrote no summary: the message ends with the end of its output.
    """
    out = Path(request.out_dir)
    log_path = out / 'walk.log'
    timed_out = False
    with open(log_path, 'w') as log:
        process = subprocess.Popen(command, env=env, stdout=log, stderr=subprocess.STDOUT)
        try:
            process.wait(timeout=request.walk_timeout + _STARTUP_ALLOWANCE)
        except subprocess.TimeoutExpired:
            timed_out = True
            process.send_signal(signal.SIGINT)  # run_all holds the walker and stops the graph
            try:
                process.wait(timeout=_STOP_GRACE)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
    summary_path = out / 'walk' / 'summary.json'
    if not summary_path.is_file():
        tail = log_path.read_text(errors='replace')[-_LOG_TAIL:]
        raise WalkError(f'the {what} wrote no summary (exit code {process.returncode}'
                        f'{", timed out" if timed_out else ""}); its output ends:\n{tail}')
    summary = json.loads(summary_path.read_text())
    summary['timed_out'] = timed_out or bool(summary.get('timed_out'))
    return summary


def headless_walk(request: WalkRequest) -> dict[str, Any]:
    """Walk in the headless lock-step loop (see the module's docstring).

    Raises
    ------
    WalkError
        The runner wrote no summary (a parameter refused, a crash).
    """
    Path(request.out_dir).mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, PYTHONUNBUFFERED='1')
    return _walk_in_process(request, _run_all_command(request, ['--headless']), env,
                            'headless runner')


def graph_walk(request: WalkRequest) -> dict[str, Any]:
    """Walk on the sim-time ROS graph, in a ROS domain of its own (see the module's docstring).

    Raises
    ------
    WalkError
        The graph did not write a summary (it did not come up, a node refused its
        parameters): the message ends with the end of its output.
    """
    from walker_bringup.domains import isolated_domain

    out = Path(request.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    command = _run_all_command(request, ['--sim-time', '--composed-loop'])
    with isolated_domain() as domain:
        env = dict(os.environ, ROS_DOMAIN_ID=str(domain),
                   ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST', ROS_HOME=str(out / 'ros_home'),
                   PYTHONUNBUFFERED='1')
        return _walk_in_process(request, command, env, 'graph')


#: The walk functions a campaign can name (the default ``headless``; ``--graph``: ``graph``).
BACKENDS: dict[str, WalkFunction] = {'headless': headless_walk, 'graph': graph_walk}


def walk_function(name: str) -> WalkFunction:
    """Return the walk function called ``name``.

    One of :data:`BACKENDS`, or ``module:function`` (a walk function of your own, importable
    where the walks run).

    Raises
    ------
    ValueError
        No walk function has that name.
    """
    if name in BACKENDS:
        return BACKENDS[name]
    module, separator, attribute = name.partition(':')
    if separator and module and attribute:
        try:
            function = getattr(importlib.import_module(module), attribute)
        except (ImportError, AttributeError) as error:
            raise ValueError(f'walk function {name!r} cannot be imported: {error}') from None
        if callable(function):
            return function
    raise ValueError(f'no walk function {name!r}: expected one of '
                     f'{", ".join(sorted(BACKENDS))}, or module:function')
