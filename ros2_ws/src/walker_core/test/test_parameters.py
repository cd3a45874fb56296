"""The shared parameter file: loading, validation, clear refusals, nothing half-applied."""

import math
import os
import subprocess
import sys

import pytest
from ros_test_support import write_parameter_file

from walker_core.parameter_schema import (
    ParameterError, leaf_specs, load_parameter_file, replace_in_section, section_to_flat)
from walker_core.robot_parameters import (
    WalkerParameters, default_parameter_file, load_walker_parameters)

DEFAULT_FLAT = load_parameter_file(default_parameter_file())
LEAVES = [spec.name for spec in leaf_specs(WalkerParameters)]


def write_params(tmp_path, flat_overrides=None, remove=(), text=None):
    path = tmp_path / 'walker.yaml'
    if text is not None:
        path.write_text(text)
        return path
    flat = {k: v for k, v in DEFAULT_FLAT.items() if k not in remove}
    flat.update(flat_overrides or {})
    return write_parameter_file(path, flat)


def test_default_file_is_valid_and_complete():
    params = load_walker_parameters()
    assert params.robot.geometry.l2 > params.robot.geometry.l1 > 0
    for kind in ('yaw', 'pitch', 'vertex'):
        drive = getattr(params.robot.drive, kind)
        assert drive.friction_torque > 0.10 * drive.torque_limit
    assert params.robot.flexibility.joint1_mode == 18.0
    assert params.robot.flexibility.joints23_mode == 80.0
    assert set(LEAVES) <= set(DEFAULT_FLAT)


def test_every_value_in_the_file_says_where_it_comes_from():
    lines = default_parameter_file().read_text().splitlines()
    leaf_lines = [line for line in lines
                  if ':' in line and not line.strip().startswith('#')
                  and line.split(':', 1)[1].split('#')[0].strip()]
    undocumented = [line for line in leaf_lines
                    if 'paper' not in line and 'chosen' not in line]
    assert not undocumented, f'values without a source: {undocumented}'


@pytest.mark.parametrize('name', LEAVES)
def test_a_missing_parameter_is_named(tmp_path, name):
    with pytest.raises(ParameterError, match=name.replace('.', r'\.')):
        load_walker_parameters(write_params(tmp_path, remove=[name]))


@pytest.mark.parametrize('name, value, words', [
    ('robot.geometry.l2', -0.6, 'below the minimum'),
    ('robot.geometry.l2', math.nan, 'finite'),
    ('robot.geometry.l1', 'long', 'expected a number'),
    ('robot.geometry.l1', True, 'expected a number'),
    ('truss.columns', 2.5, 'expected an integer'),
    ('robot.drive.yaw.friction_torque', 0.5, '10%'),
    ('robot.drive.pitch.stiction_torque', 1.0, 'stiction'),
    ('robot.drive.vertex.position_min', 3.0, 'position_min'),
    ('robot.geometry.l1', 0.7, 'shorter than l2'),
    ('truss.spacing', 1.3, 'reach'),
    ('robot.flexibility.joint1_mode', 90.0, 'lower than'),
    ('robot.name', 'my walker', 'ROS name'),
    ('timing.decision_priority', 100, 'above the maximum'),
])
def test_invalid_values_are_refused_with_the_parameter_named(tmp_path, name, value, words):
    path = write_params(tmp_path, {name: value})
    with pytest.raises(ParameterError, match=words):
        load_walker_parameters(path)


@pytest.mark.parametrize('text, words', [
    ('robot: [1, 2', 'not valid YAML'),
    ('- 1\n- 2\n', 'must map node names'),
    ('/**:\n  parameters: {}\n', 'ros__parameters'),
    ('/**:\n  ros__parameters: 3\n', 'must be a mapping'),
])
def test_malformed_files_are_refused(tmp_path, text, words):
    with pytest.raises(ParameterError, match=words):
        load_walker_parameters(write_params(tmp_path, text=text))


def test_a_missing_file_is_refused(tmp_path):
    with pytest.raises(ParameterError, match='cannot read'):
        load_walker_parameters(tmp_path / 'nowhere.yaml')


def test_node_sections_override_the_shared_section(tmp_path):
    path = tmp_path / 'walker.yaml'
    path.write_text('/**:\n  ros__parameters:\n    a: 1\n    b: 2\n'
                    '/walker/plant:\n  ros__parameters:\n    b: 3\n')
    assert load_parameter_file(path, 'plant') == {'a': 1, 'b': 3}
    assert load_parameter_file(path, '/walker/plant') == {'a': 1, 'b': 3}
    assert load_parameter_file(path, 'planner') == {'a': 1, 'b': 2}


def test_updates_are_validated_as_a_whole_and_change_nothing_when_refused():
    params = load_walker_parameters()
    before = section_to_flat(params)
    with pytest.raises(ParameterError, match='10%'):
        replace_in_section(params, {'robot.drive.yaw.torque_limit': 20.0})
    with pytest.raises(ParameterError, match='unknown'):
        replace_in_section(params, {'robot.geometry.l9': 1.0})
    assert section_to_flat(params) == before
    updated = replace_in_section(params, {'robot.drive.yaw.torque_limit': 12.0})
    assert updated.robot.drive.yaw.torque_limit == 12.0
    assert params.robot.drive.yaw.torque_limit == 10.0


def test_round_trip_through_the_flat_form():
    params = load_walker_parameters()
    assert WalkerParameters.from_flat(section_to_flat(params)) == params


@pytest.mark.parametrize('realtime, decision, expected', [(50, 40, 40), (50, 0, 0), (0, 40, 0)])
def test_the_deciding_processes_never_outrank_the_loop(tmp_path, realtime, decision, expected):
    """The supervisor and the planner ask for a priority only below the loop's, never alone."""
    path = write_params(tmp_path, {'timing.realtime_priority': realtime,
                                   'timing.decision_priority': decision})
    assert load_walker_parameters(path).timing.decision_scheduling_priority == expected


def test_the_parameter_file_is_found_without_ament_prefix_path():
    """Outside a sourced workspace the file beside the package source is used (figures, report)."""
    env = {k: v for k, v in os.environ.items() if k != 'AMENT_PREFIX_PATH'}
    script = ('from walker_core.robot_parameters import default_parameter_file, '
              'load_walker_parameters\n'
              'print(default_parameter_file())\n'
              'print(load_walker_parameters().robot.geometry.l2)\n')
    result = subprocess.run([sys.executable, '-c', script], env=env, capture_output=True,
                            text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    path, l2 = result.stdout.split()
    assert path.endswith('walker_core/config/walker.yaml') and float(l2) > 0.0


def test_no_parameter_file_anywhere_is_a_clear_error(monkeypatch, tmp_path):
    from walker_core import parameter_file

    monkeypatch.delenv('AMENT_PREFIX_PATH', raising=False)
    monkeypatch.setattr(parameter_file, '_source_parameter_file',
                        lambda: tmp_path / 'missing' / 'walker.yaml')
    with pytest.raises(FileNotFoundError, match='AMENT_PREFIX_PATH.*pass the parameter file'):
        parameter_file.default_parameter_file()


def test_real_time_deciders_at_the_loops_priority_are_refused(tmp_path):
    path = write_params(tmp_path, {'timing.realtime_priority': 50,
                                   'timing.decision_priority': 50})
    with pytest.raises(ParameterError, match='must be below timing.realtime_priority'):
        load_walker_parameters(path)
