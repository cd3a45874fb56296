"""A walk's truss survey file, checked before a walk starts from it (``--truss-survey``).

Both backends start from it: the headless runner takes its content
(:func:`walker_headless.runner.walk`'s ``survey``); the graph's supervisor reads it from
``<out>/truss_survey.yaml`` (``supervisor.truss_survey_file``), where the session puts it
before the graph starts, and writes the walk's survey back into that file.
"""

from __future__ import annotations

from pathlib import Path

from walker_core.truss import Truss
from walker_supervisor.core.survey_file import read_survey
from walker_supervisor.core.truss_map import SurveyFileError, TrussMap

from walker_bringup.session_options import SessionError

__all__ = ['checked_survey', 'survey_map']


def checked_survey(configuration, path: str | Path) -> dict:
    """Return the survey file at ``path``, checked against the configuration's truss.

    Raises
    ------
    SessionError
        (code 2) naming the file and what is wrong with it.
    """
    try:
        content = read_survey(path)  # its errors name the file
    except SurveyFileError as error:
        raise SessionError(str(error)) from None
    try:
        survey_map(configuration, content)
    except SurveyFileError as error:
        raise SessionError(f'the truss survey {path}: {error}') from None
    return content


def survey_map(configuration, content: dict) -> TrussMap:
    """Return the truss map of a survey's content, with the supervisor's uncertainties.

    Raises SurveyFileError if the content does not fit the configuration's truss.
    """
    settings = configuration.supervisor
    return TrussMap.from_dict(Truss.from_parameters(configuration.walker),
                              settings.node_prior_std, settings.joint_reading_std, content)
