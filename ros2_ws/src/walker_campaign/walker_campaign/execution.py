"""Carry out one run where it is scheduled: write its two parameter files, walk, make its rows.

:func:`execute_run` is what a Ray task runs on a worker (and what ``campaign.py --run-index``
runs locally): everything it needs travels in a :class:`RunTask` (the nominal file's document
included), so a worker needs no file of the driver's. It never raises for a walk that went
wrong: a refused parameter, a crash of the walk, anything, becomes the run's ``error`` row
with the reason, so a deterministic failure is recorded once and not retried; only the death
of the worker itself leaves a run without a row (and the driver runs it again elsewhere).
"""

from __future__ import annotations

import dataclasses
import os
import socket
import tempfile
import time
import traceback
from pathlib import Path
from typing import Any

import yaml

from walker_campaign.core.parameter_sets import write_parameter_file
from walker_campaign.core.plan import RunPlan
from walker_campaign.core.rows import error_rows, run_rows
from walker_campaign.walks import (
    WalkError, WalkFunction, WalkRequest, repeated_walk, walk_function)

__all__ = ['RunTask', 'execute_run', 'START_SURVEY_FILE']


@dataclasses.dataclass(frozen=True)
class RunTask:
    """Everything a worker needs for one run.

    Attributes
    ----------
    campaign : str
        The campaign's name.
    plan : RunPlan
        The run (its two sets of changed values).
    target : str
        The node to walk to.
    walk_timeout : float
        Wall-clock seconds the walk may take.
    walk : str or callable
        The walk function, by name (:data:`walker_campaign.walks.BACKENDS`) or itself.
    record_dir : str or None
        Keep the walk's output (and its bag) there; ``None``: a scratch directory, removed.
    truss_survey : dict or None
        A truss survey's content the (first) walk starts from; None: the nominal truss.
    walks : int
        Walks of the route on the same truss (:func:`walker_campaign.walks.repeated_walk`).
    """

    campaign: str
    plan: RunPlan
    target: str
    walk_timeout: float
    walk: Any = 'headless'
    record_dir: str | None = None
    truss_survey: dict[str, Any] | None = None
    walks: int = 1


#: The name of the survey file a run's walk starts from, next to its parameter files.
START_SURVEY_FILE = 'start_survey.yaml'


def _execution(started: float, walk: Any) -> dict[str, Any]:
    return {'wall_time': time.monotonic() - started, 'host': socket.gethostname(),
            'pid': os.getpid(), 'walk': walk if isinstance(walk, str) else
            getattr(walk, '__name__', type(walk).__name__)}


def execute_run(task: RunTask, document: dict[str, Any]) -> list[dict[str, Any]]:
    """Run one walk of a campaign and return its rows (step rows, then the run row).

    Parameters
    ----------
    task : RunTask
        The run.
    document : dict
        The nominal parameter file's YAML document.
    """
    started = time.monotonic()
    plan = task.plan
    try:
        walk: WalkFunction = walk_function(task.walk) if isinstance(task.walk, str) else task.walk
    except ValueError as error:
        return error_rows(task.campaign, plan, str(error), _execution(started, task.walk))
    with tempfile.TemporaryDirectory(prefix=f'walker-campaign-{plan.index}-') as scratch:
        out = Path(task.record_dir) if task.record_dir else Path(scratch)
        out.mkdir(parents=True, exist_ok=True)
        try:
            survey = None
            if task.truss_survey is not None:
                survey = out / START_SURVEY_FILE
                survey.write_text(yaml.safe_dump(task.truss_survey, sort_keys=False))
            request = WalkRequest(
                model_file=write_parameter_file(document, plan.model_values, out / 'model.yaml'),
                truth_file=write_parameter_file(document, plan.truth_values, out / 'truth.yaml'),
                target=task.target, out_dir=out, walk_timeout=task.walk_timeout,
                record=task.record_dir is not None, truss_survey=survey)
            summary = walk(request) if task.walks == 1 else repeated_walk(walk, request,
                                                                          task.walks)
        except WalkError as error:
            return error_rows(task.campaign, plan, str(error), _execution(started, task.walk))
        except Exception as error:  # the row says what went wrong; the campaign goes on
            where = traceback.extract_tb(error.__traceback__)[-1]
            return error_rows(task.campaign, plan,
                              f'{type(error).__name__}: {error} ({Path(where.filename).name}:'
                              f'{where.lineno})', _execution(started, task.walk))
    return run_rows(task.campaign, plan, summary, _execution(started, task.walk))
