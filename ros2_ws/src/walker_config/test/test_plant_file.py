"""The plant's own parameter file: the plant gets its robot and sim.*, the rest the model's."""

import pytest
import yaml

from walker_config.core.configuration import load_configuration
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
