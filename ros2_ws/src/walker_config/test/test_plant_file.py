"""The plant's own parameter file: the plant gets its robot and sim.*, the rest the model's."""

import pytest
import yaml

from walker_config.core.configuration import load_configuration, load_plant
from walker_core.parameter_schema import ParameterError
from walker_core.robot_parameters import default_parameter_file


def _truth_file(tmp_path, offset):
    document = yaml.safe_load(default_parameter_file().read_text())
    values = document['/**']['ros__parameters']
    values['sim']['imperfections']['joint_offset'] = offset
    values['robot']['drive']['yaw']['friction_torque'] *= 1.1
    path = tmp_path / 'truth.yaml'
    path.write_text(yaml.safe_dump(document))
    return path


def test_without_a_plant_file_the_plant_takes_the_model():
    configuration = load_configuration()
    assert configuration.plant == (configuration.walker, configuration.sim)


def test_the_plant_file_reaches_the_plant_alone(tmp_path):
    truth = _truth_file(tmp_path, [1e-4, 0.0, 0.0, 0.0, -1e-4])
    configuration = load_configuration(plant_path=truth)
    model = load_configuration()
    assert configuration.walker == model.walker and configuration.sim == model.sim
    assert configuration.controllers == model.controllers
    assert configuration.planner == model.planner
    plant_walker, plant_sim = configuration.plant
    assert plant_walker.robot.drive.yaw.friction_torque == pytest.approx(
        1.1 * model.walker.robot.drive.yaw.friction_torque)
    assert tuple(plant_sim.imperfections.joint_offset) == (1e-4, 0.0, 0.0, 0.0, -1e-4)


def test_a_plant_file_the_plant_refuses_is_refused(tmp_path):
    with pytest.raises(ParameterError, match='joint_offset'):
        load_configuration(plant_path=_truth_file(tmp_path, [1e-4]))


def test_a_plant_file_named_apart_is_read_as_the_configuration_reads_it(tmp_path):
    """``run_all.py --plant-params-file`` names the file in its error: the same sections."""
    truth = _truth_file(tmp_path, [1e-4, 0.0, 0.0, 0.0, -1e-4])
    assert load_plant(truth) == load_configuration(plant_path=truth).plant
    document = yaml.safe_load(truth.read_text())
    document['/**']['ros__parameters']['sim']['start']['other_node'] = 'n9_9'
    truth.write_text(yaml.safe_dump(document))
    with pytest.raises(ParameterError, match='sim.start.other_node'):  # the rule between two
        load_plant(truth)
