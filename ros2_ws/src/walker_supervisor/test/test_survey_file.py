"""The truss survey file a supervisor keeps: started from where it exists, written on changes."""

import numpy as np
import pytest

from walker_core.robot_parameters import load_walker_parameters
from walker_core.truss import Truss
from walker_supervisor.core.survey_file import SurveyKeeper, read_survey, write_survey
from walker_supervisor.core.truss_map import SurveyFileError, TrussMap

TRUSS = Truss.from_parameters(load_walker_parameters())
PRIOR, JOINT = 0.002, 2e-4


def _map() -> TrussMap:
    return TrussMap(TRUSS, PRIOR, JOINT)


def _surveyed() -> TrussMap:
    """Return a map that surveyed n2_1 2.5 mm off its nominal place (a file's content)."""
    survey = _map()
    content = {'format': 'walker-truss-survey-1', 'frame': 'truss', 'anchor': 'n1_1',
               'nodes': {'n1_1': {'position': TRUSS.position('n1_1').tolist(),
                                  'covariance': np.zeros((3, 3)).tolist()},
                         'n2_1': {'position': (TRUSS.position('n2_1')
                                               + [0.0025, 0.0, 0.0]).tolist(),
                                  'covariance': (np.eye(3) * 1e-8).tolist()}}}
    survey.load(content)
    return survey


def test_a_map_kept_in_no_file_starts_nominal_and_writes_nothing(tmp_path):
    survey = _map()
    keeper = SurveyKeeper(survey, '')
    survey.anchor_at('n1_1')
    assert keeper.write_if_changed() is None and list(tmp_path.iterdir()) == []
    assert survey.surveyed_nodes == ['n1_1']


def test_the_map_is_written_when_it_changes_and_a_new_keeper_starts_from_it(tmp_path):
    path = tmp_path / 'truss_survey.yaml'
    survey = _map()
    keeper = SurveyKeeper(survey, path)
    assert survey.surveyed_nodes == [] and not path.exists(), 'no file: the nominal truss'
    assert keeper.write_if_changed() is None and not path.exists(), 'unchanged: not written'
    walked = _surveyed()
    survey.load(walked.to_dict())  # the walk changes the map
    assert keeper.write_if_changed() is None and path.exists()
    assert [p.name for p in tmp_path.iterdir()] == [path.name], 'no partial file is left'
    path.unlink()
    assert keeper.write_if_changed() is None and not path.exists(), 'written once per change'
    write_survey(path, walked)
    restarted = _map()
    SurveyKeeper(restarted, path)
    assert restarted.surveyed_nodes == ['n1_1', 'n2_1']
    np.testing.assert_allclose(restarted.position('n2_1'), walked.position('n2_1'))
    assert read_survey(path) == walked.to_dict()


def test_a_broken_survey_file_is_named_and_the_map_stays_nominal(tmp_path):
    broken = tmp_path / 'broken.yaml'
    broken.write_text('format: walker-truss-survey-1\nnodes: {n9_9: {position: [0, 0, 0]}}\n')
    survey = _map()
    with pytest.raises(SurveyFileError, match='broken.yaml.*n9_9'):
        SurveyKeeper(survey, broken)
    assert survey.surveyed_nodes == [] and survey.version == 0


def test_a_file_that_cannot_be_written_is_named_and_written_at_the_next_call(tmp_path):
    path = tmp_path / 'missing' / 'truss_survey.yaml'
    survey = _map()
    keeper = SurveyKeeper(survey, path)
    survey.anchor_at('n1_1')
    failure = keeper.write_if_changed()
    assert failure is not None and str(path) in failure
    path.parent.mkdir()
    assert keeper.write_if_changed() is None and read_survey(path)['anchor'] == 'n1_1'
