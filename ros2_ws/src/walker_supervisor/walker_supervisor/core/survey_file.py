"""The truss survey file: a walk's truss map written to YAML, read back to start another.

The content is :meth:`~walker_supervisor.core.truss_map.TrussMap.to_dict`'s (format
``walker-truss-survey-1``, documented in docs/walking.md): the node that anchors the truss
frame and, per surveyed node, its position [m] and covariance [m^2] in that frame. A walk
writes it as ``truss_survey.yaml`` into its output directory; ``run_all.py --truss-survey FILE``
(and a campaign's ``truss_survey``) starts a walk from it. A supervisor given
``supervisor.truss_survey_file`` starts from that file where it exists and keeps it up to date
(:class:`SurveyKeeper`): the graph's supervisor writes the walk's survey so, and a supervisor
started again after a crash goes on from the map it had.
"""

from __future__ import annotations

from pathlib import Path

import yaml

from walker_supervisor.core.truss_map import SurveyFileError, TrussMap

__all__ = ['SURVEY_FILE_NAME', 'read_survey', 'write_survey', 'load_survey', 'SurveyKeeper']

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


def load_survey(survey: TrussMap, path: str | Path) -> None:
    """Start ``survey`` from the survey file at ``path``.

    Raises SurveyFileError naming the file and the fault; the map is then unchanged.
    """
    content = read_survey(path)
    try:
        survey.load(content)
    except SurveyFileError as error:
        raise SurveyFileError(f'the truss survey {path}: {error}') from None


class SurveyKeeper:
    """Keeps a map in its survey file: read at the start where it exists, written as it changes.

    Parameters
    ----------
    survey : TrussMap
        The map (the supervisor's, changed by its walk).
    path : str or Path
        The survey file; ``''`` keeps nothing (the map starts nominal).

    Raises
    ------
    SurveyFileError
        If the file exists and cannot be read or does not fit the truss (naming the file).
    """

    def __init__(self, survey: TrussMap, path: str | Path) -> None:
        self._map = survey
        self.path = Path(path) if path else None
        if self.path is not None and self.path.exists():
            load_survey(survey, self.path)
        self._written = survey.version

    def write_if_changed(self) -> str | None:
        """Write the map to the file if it has changed since it was read or last written.

        Returns None, or why the file could not be written (the map is then written at the
        next call). The file is replaced at once (written beside it and renamed), so a reader
        never sees half a survey.
        """
        if self.path is None or self._map.version == self._written:
            return None
        partial = self.path.with_name(self.path.name + '.partial')
        try:
            write_survey(partial, self._map)
            partial.replace(self.path)
        except OSError as error:
            return f'the truss survey {self.path} could not be written: {error}'
        self._written = self._map.version
        return None
