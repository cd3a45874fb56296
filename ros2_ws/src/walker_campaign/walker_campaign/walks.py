"""One walk of a campaign run: the model's and the truth's parameter files in, a summary out.

A *walk function* takes a :class:`WalkRequest` and returns the walk's summary, the mapping
``run_all.py`` writes as ``summary.json`` (``steps``, ``reached``, ``message``; ``timed_out``
when it ran out of wall-clock time). It raises :class:`WalkError` when the walk could not be
carried out at all. Two are provided, each a walk session (:mod:`walker_bringup.session`) in
the worker that runs it, the plant given the truth's file and everything else the model's,
its output (the table, the progress) in ``walk.log``:

* ``headless`` (the default): the cores in one lock-step loop (``Arrangement.HEADLESS``), no
  DDS, many times faster than real time;
* ``graph``: the full sim-time ROS graph with the loop composed (``Arrangement.COMPOSED_LOOP``),
  in a ROS domain of its own taken on the machine that runs it
  (:func:`walker_bringup.domains.isolated_domain`).

Any callable with the same signature serves, named ``module:function`` (the tests use a
fast stand-in).

A walk given a truss survey (:attr:`WalkRequest.truss_survey`) starts from it; a walk that
surveys the truss puts the path of the survey it wrote into its summary
(:data:`SURVEY_FILE_KEY`). :func:`repeated_walk` walks a route several times on the same truss,
each walk after the first from the survey the one before it wrote (a spec's ``route.walks``).
"""

from __future__ import annotations

import contextlib
import dataclasses
import importlib
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

__all__ = ['WalkRequest', 'WalkError', 'WalkFunction', 'graph_walk', 'headless_walk', 'BACKENDS',
           'walk_function', 'repeated_walk', 'SURVEY_FILE_KEY']
_LOG_TAIL = 2000  # characters of a failed walk's output kept in its error
#: The summary's entry naming the truss survey file a walk wrote (absent: it wrote none).
SURVEY_FILE_KEY = 'truss_survey_file'


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
    truss_survey : Path or None
        A truss survey file the walk starts from (``run_all.py --truss-survey``, on the graph
        and headless); None: the nominal truss.
    """

    model_file: Path
    truth_file: Path
    target: str
    out_dir: Path
    walk_timeout: float
    record: bool = False
    truss_survey: Path | None = None


class WalkError(RuntimeError):
    """A walk that could not be carried out (nothing to summarise); the message says why."""


WalkFunction = Callable[[WalkRequest], dict[str, Any]]


def _walk_in_session(request: WalkRequest, arrangement) -> dict[str, Any]:
    """Run a walk session to its end in this process; return ``summary.json``'s mapping.

    Raises
    ------
    WalkError
        A file refused, or the walk wrote no summary: the message says why.
    """
    from walker_bringup.session import SessionError, SessionOptions, WalkSession
    from walker_supervisor.core.survey_file import SURVEY_FILE_NAME
    from walker_config.core.configuration import load_configuration
    from walker_core.parameter_schema import ParameterError

    out = Path(request.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    try:
        configuration = load_configuration(request.model_file, plant_path=request.truth_file)
    except ParameterError as error:
        raise WalkError(f'the parameter files are refused: {error}') from None
    options = SessionOptions(arrangement=arrangement, sim_time=True, record=request.record,
                             report=False, out=out / 'walk', walk_timeout=request.walk_timeout,
                             quiet=True, plant_params_file=Path(request.truth_file).resolve(),
                             truss_survey=request.truss_survey)
    code = None
    with open(out / 'walk.log', 'w') as log, contextlib.redirect_stdout(log):
        session = WalkSession(configuration, options)
        try:
            session.start()
            session.walk(request.target)
        except SessionError as error:
            print(f'[walker] error: {error}')
            code = error.code
        finally:
            session.stop()
    summary_path = out / 'walk' / 'summary.json'
    if not summary_path.is_file():
        tail = (out / 'walk.log').read_text(errors='replace')[-_LOG_TAIL:]
        raise WalkError(f'the {arrangement} walk wrote no summary (exit code {code}); its '
                        f'output ends:\n{tail}')
    summary = json.loads(summary_path.read_text())
    summary['timed_out'] = bool(summary.get('timed_out'))
    survey = out / 'walk' / SURVEY_FILE_NAME
    if survey.is_file():
        summary[SURVEY_FILE_KEY] = str(survey)
    return summary


def repeated_walk(walk: WalkFunction, request: WalkRequest, count: int) -> dict[str, Any]:
    """Walk the request's route ``count`` times on the same truss; return the walks' summary.

    Walk ``k`` writes into ``out_dir/walk_<k>``; each walk after the first starts from the
    survey the one before it wrote (its summary's :data:`SURVEY_FILE_KEY`), the first from
    the request's own survey, if any. Each walk has the request's wall-clock time.

    Returns
    -------
    dict
        :func:`walker_campaign.core.rows.combined_summary` of the walks' summaries.

    Raises
    ------
    WalkError
        A walk could not be carried out, or wrote no survey for the next to start from.
    """
    from walker_campaign.core.rows import combined_summary

    summaries = []
    survey = request.truss_survey
    for number in range(1, count + 1):
        summary = walk(dataclasses.replace(request, out_dir=Path(request.out_dir) /
                                           f'walk_{number}', truss_survey=survey))
        summaries.append(summary)
        if number < count:
            survey = summary.get(SURVEY_FILE_KEY)
            if not survey or not Path(survey).is_file():
                raise WalkError(f'walk {number} of {count} wrote no truss survey for walk '
                                f'{number + 1} to start from')
            survey = Path(survey)
    return combined_summary(summaries)


def headless_walk(request: WalkRequest) -> dict[str, Any]:
    """Walk in the headless lock-step loop (see the module's docstring).

    Raises
    ------
    WalkError
        The runner wrote no summary (a parameter refused, a crash).
    """
    from walker_bringup.session import Arrangement

    return _walk_in_session(request, Arrangement.HEADLESS)


def graph_walk(request: WalkRequest) -> dict[str, Any]:
    """Walk on the sim-time ROS graph, in a ROS domain of its own (see the module's docstring).

    The domain, and a ROS home in the walk's directory, are this process's for the walk (the
    session's client and the graph's processes take them from its environment), and given
    back after it.

    Raises
    ------
    WalkError
        The graph did not write a summary (it did not come up, a node refused its
        parameters): the message ends with the end of its output.
    """
    from walker_bringup.domains import domain_environment, isolated_domain
    from walker_bringup.session import Arrangement

    out = Path(request.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    with isolated_domain() as domain, domain_environment(domain, out / 'ros_home'):
        return _walk_in_session(request, Arrangement.COMPOSED_LOOP)


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
