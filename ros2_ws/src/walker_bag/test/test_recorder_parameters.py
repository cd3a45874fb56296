"""The recorder's parameters and topic selection: documented defaults, clear refusals."""

import datetime
from pathlib import Path

import pytest

from walker_core.parameter_schema import (
    ParameterError, load_parameter_file, replace_in_section, section_from_flat)
from walker_core.robot_parameters import default_parameter_file

from walker_bag.core.errors import TopicNameError
from walker_bag.core.recorder_parameters import RECORDER_PREFIX, RecorderParameters
from walker_bag.core.topic_selection import TopicSelection, is_hidden_topic

DEFAULTS = section_from_flat(RecorderParameters, load_parameter_file(default_parameter_file()),
                             RECORDER_PREFIX)


def test_the_parameter_file_holds_valid_recorder_defaults():
    assert DEFAULTS.topics == ('*', '/clock')
    assert DEFAULTS.max_chunk_size == 768 * 1024
    assert 0 < DEFAULTS.flush_period <= 1.0
    assert DEFAULTS.directory == 'runs/bags'


def test_the_bag_is_named_after_the_time_unless_a_name_is_given():
    now = datetime.datetime(2026, 3, 4, 5, 6, 7)
    assert DEFAULTS.bag_path(now) == Path('runs/bags/walker_2026_03_04-05_06_07')
    named = replace_in_section(DEFAULTS, {'recorder.bag_name': 'walk1'}, RECORDER_PREFIX)
    assert named.bag_path(now) == Path('runs/bags/walk1')


@pytest.mark.parametrize('name, value, words', [
    ('recorder.flush_period', 0.0, 'below the minimum'),
    ('recorder.flush_period', float('nan'), 'finite'),
    ('recorder.discovery_period', -1.0, 'below the minimum'),
    ('recorder.max_chunk_size', 10, 'below the minimum'),
    ('recorder.max_chunk_size', 1.5, 'expected an integer'),
    ('recorder.queue_depth', 0, 'below the minimum'),
    ('recorder.take_period', 0.0, 'below the minimum'),
    ('recorder.take_period', 2.0, 'above the maximum'),
    ('recorder.topics', [], 'empty'),
    ('recorder.topics', ['joint states'], 'not a valid topic name'),
    ('recorder.topics', ['~/private'], 'not a valid topic name'),
    ('recorder.topics', 'joint_states', 'list of strings'),
    ('recorder.bag_name', 'a/b', 'single directory name'),
    ('recorder.bag_name', '..', 'single directory name'),
    ('recorder.directory', '', 'must not be empty'),
])
def test_invalid_values_are_refused_by_name(name, value, words):
    with pytest.raises(ParameterError, match=words) as error:
        replace_in_section(DEFAULTS, {name: value}, RECORDER_PREFIX)
    assert name.split('.')[-1] in str(error.value)


SELECTION = TopicSelection(['*', '/clock'], '/walker')


@pytest.mark.parametrize('topic, selected', [
    ('/walker/joint_states', True),
    ('/walker/controllers/a_yaw_joint/state', True),
    ('/clock', True),
    ('/walker', False),
    ('/rosout', False),
    ('/parameter_events', False),
    ('/other/joint_states', False),
    ('/walker/step/_action/feedback', False),
    ('/walker/_hidden', False),
])
def test_the_default_selection_is_the_robots_topics_and_the_clock(topic, selected):
    assert SELECTION.matches(topic) is selected


def test_relative_entries_resolve_in_the_namespace_and_exact_names_include_hidden_topics():
    selection = TopicSelection(['joint_states', 'controllers/*/state',
                                '/walker/step/_action/status'], '/walker')
    assert selection.names == ('/walker/joint_states', '/walker/step/_action/status')
    assert selection.patterns == ('/walker/controllers/*/state',)
    assert selection.matches('/walker/controllers/b_yaw_joint/state')
    assert not selection.matches('/walker/controllers/b_yaw_joint/setpoint')
    assert selection.matches('/walker/step/_action/status')
    assert not selection.matches('/walker/tip_pose')


@pytest.mark.parametrize('entries, namespace', [
    ([], '/walker'), (['a b'], '/walker'), (['1abc'], '/walker'), (['a//b'], '/walker'),
    (['a/'], '/walker'), (['a__b'], '/walker'), ([''], '/walker'), ('joint_states', '/walker'),
    (['x'], 'walker'), (['x'], '/wal ker'),
])
def test_invalid_selections_are_refused(entries, namespace):
    with pytest.raises(TopicNameError):
        TopicSelection(entries, namespace)


@pytest.mark.parametrize('name, hidden', [
    ('/walker/_action/status', True), ('/_x', True), ('/walker/joint_states', False),
    ('/a_b/c_', False),
])
def test_hidden_topics_are_those_with_a_token_starting_with_underscore(name, hidden):
    assert is_hidden_topic(name) is hidden
