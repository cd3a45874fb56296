"""The truss survey file: a walk's truss map written to YAML, read back to start another.

The content is :meth:`~walker_supervisor.core.truss_map.TrussMap.to_dict`'s (format
``walker-truss-survey-1``, documented in docs/walking.md): the node that anchors the truss
frame and, per surveyed node, its position [m] and covariance [m^2] in that frame. A walk
writes it as ``truss_survey.yaml`` into its output directory; ``run_all.py --truss-survey FILE``
(and a campaign's ``truss_survey``) starts a walk from it.
"""

from __future__ import annotations

from pathlib import Path

import yaml

from walker_supervisor.core.truss_map import SurveyFileError, TrussMap

__all__ = ['SURVEY_FILE_NAME', 'read_survey', 'write_survey']

#: The survey file's name in a walk's output directory.
SURVEY_FILE_NAME = 'truss_survey.yaml'


def read_survey(path: str | Path) -> dict:
    """Return a survey file's content; raises SurveyFileError naming the file and the fault."""
    try:
        content = yaml.safe_load(Path(path).read_text())
    except (OSError, yaml.YAMLError) as error:
        raise SurveyFileError(f'cannot read the truss survey {path}: {error}') from None
    if not isinstance(content, dict):
        raise SurveyFileError(f'the truss survey {path} is not a mapping')
    return content


def write_survey(path: str | Path, survey: TrussMap) -> Path:
    """Write the map to ``path`` (YAML); return the path."""
    path = Path(path)
    path.write_text('# the truss as the walker surveyed it (docs/walking.md)\n'
                    + yaml.safe_dump(survey.to_dict(), sort_keys=False))
    return path
