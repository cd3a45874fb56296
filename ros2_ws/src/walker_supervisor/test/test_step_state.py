"""The step under way kept in a file for a restarted supervisor."""

import math

from walker_supervisor.core.route import PlannedStep
from walker_supervisor.step_state import (
    clear_step_state, read_step_state, step_state_path, write_step_state)


def test_a_step_round_trips_and_is_forgotten(tmp_path, monkeypatch):
    monkeypatch.setenv('ROS_HOME', str(tmp_path))
    path = step_state_path('/walker')
    assert path == tmp_path / 'walker' / 'walker_step.yaml'
    assert read_step_state(path) is None
    write_step_state(path, PlannedStep('a', 'n1_1', 'n2_1', 'n1_2', math.pi / 2), -1.25)
    state = read_step_state(path)
    assert (state.base_gripper, state.base_node, state.from_node, state.to_node) == \
        ('a', 'n1_1', 'n2_1', 'n1_2')
    assert state.heading == -1.25
    clear_step_state(path)
    assert read_step_state(path) is None
    clear_step_state(path)  # forgetting twice is fine


def test_a_foreign_or_broken_file_is_ignored(tmp_path):
    path = tmp_path / 'step.yaml'
    for text in ('', 'not: [yaml', 'base_gripper: a\n', '- 1\n- 2\n'):
        path.write_text(text)
        assert read_step_state(path) is None


def test_the_truss_map_the_step_was_planned_on_is_kept_with_it(tmp_path):
    path = tmp_path / 'step.yaml'
    survey = {'format': 'walker-truss-survey-1', 'frame': 'truss', 'anchor': 'n1_1',
              'nodes': {'n1_1': {'position': [0.9, 0.9, 0.0],
                                 'covariance': [[0.0] * 3] * 3}}}
    write_step_state(path, PlannedStep('a', 'n1_1', 'n2_1', 'n1_2', math.pi / 2), 0.5, survey)
    assert read_step_state(path).survey == survey
    write_step_state(path, PlannedStep('a', 'n1_1', 'n2_1', 'n1_2', math.pi / 2), 0.5)
    assert read_step_state(path).survey is None  # a record without a map: nominal places
