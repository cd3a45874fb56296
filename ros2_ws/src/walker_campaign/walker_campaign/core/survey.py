"""A campaign's truss survey: the survey file every walk of the campaign starts from.

A spec's ``truss_survey`` (or ``campaign.py --truss-survey FILE``) names a survey file, the
YAML a walk writes as ``truss_survey.yaml`` and ``run_all.py --truss-survey FILE`` reads
(format ``walker-truss-survey-1``, docs/walking.md). It is read and checked against the
nominal truss once, when the spec is read; its content then travels with each run to the
worker (:class:`~walker_campaign.execution.RunTask`), which writes it next to the run's
parameter files for the walk's session.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from walker_campaign.core.errors import SpecError
from walker_campaign.core.parameter_sets import check_model
from walker_core.truss import Truss
from walker_supervisor.core.survey_file import read_survey
from walker_supervisor.core.truss_map import SurveyFileError, TrussMap

__all__ = ['load_campaign_survey', 'PRIOR_STD_KEY', 'JOINT_STD_KEY']

#: The nominal file's keys of the map's uncertainties (the supervisor's).
PRIOR_STD_KEY = 'supervisor.node_prior_std'
JOINT_STD_KEY = 'supervisor.joint_reading_std'


def load_campaign_survey(path: str | Path, nominal: Mapping[str, Any],
                         where: str = 'truss_survey') -> dict[str, Any]:
    """Read a survey file and check it against the nominal truss; return its content.

    Parameters
    ----------
    path : str or Path
        The survey file.
    nominal : mapping
        The nominal parameter file's flat values (its truss, the supervisor's uncertainties
        [m], [rad]).
    where : str
        What named the file (the spec's field or the option), for the error.

    Raises
    ------
    SpecError
        The file is missing, not YAML, not a survey, or names a node the truss has not; the
        message names ``where``, the file and the fault.
    """
    try:
        content = read_survey(path)  # its errors name the file
    except SurveyFileError as error:
        raise SpecError(f'{where}: {error}') from None
    truss = Truss.from_parameters(check_model(nominal).walker)  # the loader's, cached
    try:
        TrussMap.from_dict(truss, nominal[PRIOR_STD_KEY], nominal[JOINT_STD_KEY], content)
    except SurveyFileError as error:
        raise SpecError(f'{where}: the truss survey {path}: {error}') from None
    return content
