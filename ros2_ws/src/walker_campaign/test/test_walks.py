"""The walk functions: a walk session in the worker, the plant given the truth's file.

The session is replaced by a stand-in that records what it was built with and writes a summary
naming it, so the walk functions' contract with the session is tested in a second; one real
headless walk of one step shows the whole way through.
"""

import dataclasses
import json
import os
from pathlib import Path

import numpy as np
import pytest
import yaml
from ros_test_support import write_parameter_file

import walker_bringup.session
from walker_bringup.session_options import Arrangement, SessionError
from walker_campaign import walks
from walker_campaign.walks import WalkError, WalkRequest, walk_function
from walker_core.parameter_file import default_values


class _StandIn:
    """Stands in for WalkSession: writes a summary of what it was given, or fails as told."""

    def __init__(self, configuration, options):
        self.configuration, self.options = configuration, options

    def start(self):
        return self

    def walk(self, target):
        if target == 'nowhere':
            print('the walk refused its target')
            raise SessionError('the walk refused its target', 2)
        out = Path(self.options.out)
        out.mkdir(parents=True)
        (out / 'summary.json').write_text(json.dumps({
            'steps': [], 'reached': True, 'message': '',
            'arrangement': str(self.options.arrangement), 'sim_time': self.options.sim_time,
            'model': str(self.configuration.path), 'truth': str(self.options.plant_params_file),
            'plant_from_truth': self.configuration.plant is not None,
            'record': self.options.record, 'report': self.options.report,
            'domain': os.environ.get('ROS_DOMAIN_ID'),
            'started_from': str(self.options.truss_survey)}))
        (out / 'truss_survey.yaml').write_text('# the survey this walk wrote\n')

    def stop(self):
        return 0


@pytest.fixture
def stand_in(monkeypatch):
    monkeypatch.setattr(walker_bringup.session, 'WalkSession', _StandIn)


def request(tmp_path: Path, target: str = 'n1_2', record: bool = False) -> WalkRequest:
    flat = dict(default_values())
    model = write_parameter_file(tmp_path / 'model.yaml', flat)
    flat['sim.imperfections.seed'] = 1  # the truth: the plant's own file
    truth = write_parameter_file(tmp_path / 'truth.yaml', flat)
    return WalkRequest(Path(model), Path(truth), target, tmp_path / 'run', 60.0, record)


def test_the_default_walk_is_the_headless_runner():
    from walker_campaign.campaign import DEFAULT_WALK

    assert walk_function(DEFAULT_WALK) is walks.headless_walk
    assert walk_function('graph') is walks.graph_walk


@pytest.mark.parametrize('name, arrangement', [('headless', Arrangement.HEADLESS),
                                               ('graph', Arrangement.COMPOSED_LOOP)])
def test_the_plant_gets_the_truth_and_the_rest_the_model(stand_in, tmp_path, name,
                                                         arrangement, monkeypatch):
    monkeypatch.delenv('ROS_DOMAIN_ID', raising=False)
    summary = walk_function(name)(request(tmp_path))
    assert summary['reached'] and summary['timed_out'] is False
    assert summary['model'] == str((tmp_path / 'model.yaml').resolve())
    assert summary['truth'] == str((tmp_path / 'truth.yaml').resolve())
    assert summary['plant_from_truth'] is True
    assert summary['arrangement'] == arrangement and summary['sim_time'] is True
    assert summary['record'] is False and summary['report'] is False
    # the graph's walk ran in a domain of its own, given back after it
    assert (summary['domain'] is not None) == (name == 'graph')
    assert 'ROS_DOMAIN_ID' not in os.environ


def test_a_recorded_walk_keeps_its_bag(stand_in, tmp_path):
    assert walks.headless_walk(request(tmp_path, record=True))['record'] is True


def test_a_walk_without_a_summary_is_an_error_with_its_output(stand_in, tmp_path):
    with pytest.raises(WalkError, match='refused its target') as error:
        walks.headless_walk(request(tmp_path, target='nowhere'))
    assert 'exit code 2' in str(error.value)


def test_refused_parameter_files_are_an_error_naming_the_parameter(tmp_path):
    flat = dict(default_values())
    flat['sim.start.other_node'] = 'n9_9'
    bad = write_parameter_file(tmp_path / 'truth.yaml', flat)
    with pytest.raises(WalkError, match='sim.start.other_node'):
        walks.headless_walk(WalkRequest(Path(bad), Path(bad), 'n1_2', tmp_path / 'run', 60.0))


def test_a_real_headless_walk_of_one_step_writes_its_summary_and_its_log(tmp_path):
    summary = walks.headless_walk(request(tmp_path))
    assert summary['reached'] and summary['path'] == ['n1_2'] and summary['timed_out'] is False
    assert summary['runner'] == 'headless'
    assert '[walker] reached n1_2 in 1 steps' in (tmp_path / 'run' / 'walk.log').read_text()


def test_an_unknown_walk_function_is_refused_by_name():
    with pytest.raises(ValueError, match='no walk function'):
        walk_function('teleport')
    assert walk_function('json:dumps') is json.dumps


def test_the_session_starts_from_the_requests_survey_and_names_the_one_it_wrote(
        stand_in, tmp_path):
    survey = tmp_path / 'start_survey.yaml'
    summary = walks.headless_walk(dataclasses.replace(request(tmp_path), truss_survey=survey))
    assert summary['started_from'] == str(survey)
    assert summary[walks.SURVEY_FILE_KEY] == str(tmp_path / 'run' / 'walk' / 'truss_survey.yaml')


def test_a_route_walked_twice_gives_the_second_session_the_first_ones_survey(stand_in, tmp_path):
    summary = walks.repeated_walk(walks.headless_walk, request(tmp_path), 2)
    assert [w['reached'] for w in summary['walks']] == [True, True]
    first = tmp_path / 'run' / 'walk_1' / 'walk' / 'truss_survey.yaml'
    assert first.is_file() and (tmp_path / 'run' / 'walk_2' / 'walk' / 'summary.json').is_file()
    second = json.loads((tmp_path / 'run' / 'walk_2' / 'walk' / 'summary.json').read_text())
    assert second['started_from'] == str(first)


def test_a_real_headless_step_walked_twice_gives_the_second_walk_the_first_ones_survey(
        tmp_path):
    summary = walks.repeated_walk(walks.headless_walk, request(tmp_path), 2)
    assert [w['reached'] for w in summary['walks']] == [True, True] and summary['reached']
    assert [s['walk'] for s in summary['steps']] == [1, 2]
    first, second = (yaml.safe_load((tmp_path / 'run' / f'walk_{k}' / 'walk' /
                                     'truss_survey.yaml').read_text()) for k in (1, 2))
    # the second walk kept the first one's frame and knew every node the first surveyed
    assert second['anchor'] == first['anchor'] and set(first['nodes']) <= set(second['nodes'])
    # its survey of the step's node was fused with the first's: known better than after one
    variance = {k: np.trace(survey['nodes']['n1_2']['covariance'])
                for k, survey in (('first', first), ('second', second))}
    assert variance['second'] < variance['first']
