"""The one configuration entry point: every section from one reading, every rule between them."""

import math

import pytest
from ros_test_support import write_parameter_file

import walker_core.parameter_file as parameter_file
from walker_bag.core.recorder_parameters import RECORDER_PREFIX, RecorderParameters
from walker_config.core.configuration import load_configuration
from walker_control.core.config import load_controller_settings
from walker_core.parameter_file import ParameterFile, default_parameter_file, default_values
from walker_core.parameter_schema import ParameterError
from walker_core.robot_parameters import load_walker_parameters
from walker_core.settling import SETTLING_PREFIX, SettlingWindow
from walker_planner.core.parameters import PREFIX, PlannerParameters
from walker_sim.core.config import load_sim_parameters
from walker_supervisor.core.parameters import SupervisorParameters
from walker_supervisor.core.teleop import TeleopParameters
from walker_viz.core.parameters import VIZ_PREFIX, VizParameters


def _file(tmp_path, changes=None, remove=()):
    """Write the installed file with some flat values changed or left out."""
    flat = {k: v for k, v in default_values().items() if k not in remove}
    flat.update(changes or {})
    return write_parameter_file(tmp_path / 'walker.yaml', flat)


@pytest.fixture(scope='module')
def defaults():
    return load_configuration()


def test_every_section_is_what_the_nodes_build_from_the_same_file(defaults):
    default = ParameterFile.read()
    assert defaults.path == default_parameter_file().resolve()
    assert defaults.walker == load_walker_parameters()
    assert defaults.sim == load_sim_parameters()
    assert defaults.controllers == load_controller_settings()
    assert defaults.planner == default.section(PlannerParameters, PREFIX)
    assert defaults.supervisor == default.section(SupervisorParameters, 'supervisor.')
    assert defaults.teleop == default.section(TeleopParameters, 'teleop.')
    assert defaults.recorder == default.section(RecorderParameters, RECORDER_PREFIX)
    assert defaults.viz == default.section(VizParameters, VIZ_PREFIX)


def test_the_file_is_parsed_once_and_the_defaults_once_per_process(tmp_path, monkeypatch):
    path = _file(tmp_path, {'sim.start.base_node': 'n2_1', 'sim.start.other_node': 'n3_1'})
    parsed = []
    original = parameter_file.load_parameter_file
    monkeypatch.setattr(parameter_file, 'load_parameter_file',
                        lambda p, *a: parsed.append(str(p)) or original(p, *a))
    parameter_file.default_values.cache_clear()
    try:
        load_configuration(path)
        assert parsed == [str(path.resolve())]
        load_configuration()
        load_configuration()
        assert parsed[1:] == [str(default_parameter_file())], 'the defaults once per process'
    finally:
        parameter_file.default_values.cache_clear()


def test_a_file_gives_every_section_its_values(tmp_path, defaults):
    path = _file(tmp_path, {'sim.start.base_node': 'n2_1', 'sim.start.other_node': 'n3_1',
                            'supervisor.settle_time': 0.7})
    configuration = load_configuration(path)
    assert (configuration.sim.start.base_node, configuration.sim.start.other_node) == \
        ('n2_1', 'n3_1')
    assert configuration.walker == defaults.walker
    assert configuration.controllers == defaults.controllers
    assert configuration.path == path.resolve()
    # the report's settling window is the supervisor's parameter, declared once in the model
    assert configuration.supervisor.settle_time == 0.7
    assert ParameterFile.read(path).section(SettlingWindow, SETTLING_PREFIX).settle_time == 0.7


def test_overrides_apply_over_the_file(defaults):
    configuration = load_configuration(overrides={'sim.clock_mode': 'real_time'})
    assert configuration.sim.clock_mode == 'real_time'
    assert configuration.values['sim.clock_mode'] == 'real_time'


@pytest.mark.parametrize('changes, remove, words', [
    # a value, within its section; a parameter left out
    ({'sim.physics_rate': -5.0}, (), "parameter 'sim.physics_rate' = -5.0: below the minimum"),
    ({'timing.control_rate': math.nan}, (), "'timing.control_rate'"),
    ({}, ('planner.stream.lookahead',), "parameter 'planner.stream.lookahead' is missing"),
    ({}, ('recorder.directory',), "parameter 'recorder.directory' is missing"),
    ({'viz.tf_rate': 0.0}, (), "parameter 'viz.tf_rate' = 0.0: below the minimum"),
    # a section's own rule
    ({'teleop.joint_speed': 1.2, 'teleop.max_joint_speed': 1.0}, (), 'teleop.joint_speed'),
    # the rules between sections
    ({'sim.start.other_node': 'n9_9'}, (), 'sim.start.other_node'),
    ({'sim.physics_rate': 1250.0}, (), 'integer multiple of timing.control_rate'),
    ({'supervisor.insertion_alignment': 0.004, 'supervisor.coarse_to_fine_region': 0.01,
      'supervisor.descent_region': 0.005, 'supervisor.descent_axis_tolerance': 0.006,
      'supervisor.search_radius': 0.006}, (),
     'smaller than gripper.insertion_position_tolerance'),
    ({'control.hold.bandwidth': [6.0, 5.0, 5.0, 8.0, 8.0]}, (), 'role J1, mode hold'),
])
def test_a_bad_file_is_refused_naming_the_parameter(tmp_path, changes, remove, words):
    with pytest.raises(ParameterError) as refused:
        load_configuration(_file(tmp_path, changes, remove))
    assert words in str(refused.value)


@pytest.mark.parametrize('text, words', [
    ('/**:\n  ros__parameters:\n    sim: [unclosed\n', 'is not valid YAML'),
    ('just text\n', 'must map node names to sections'),
])
def test_a_file_that_is_not_a_parameter_file_is_refused(tmp_path, text, words):
    path = tmp_path / 'bad.yaml'
    path.write_text(text)
    with pytest.raises(ParameterError, match=words):
        load_configuration(path)
    with pytest.raises(ParameterError, match='cannot read parameter file'):
        load_configuration(tmp_path / 'missing.yaml')
