"""The supervisor section and every rule across its values (``core.parameters``)."""

import dataclasses

import pytest

from sequencer_world import PARAMS, SUPERVISOR
from walker_core.parameter_schema import ParameterError, load_parameter_file, section_from_flat
from walker_core.robot_parameters import default_parameter_file
from walker_supervisor.core.parameters import (
    SupervisorParameters, check_with_control, check_with_gripper, check_with_planner)

FLAT = load_parameter_file(default_parameter_file())


def test_parameters_refuse_an_alignment_looser_than_the_region():
    with pytest.raises(ParameterError, match='smaller'):
        SupervisorParameters(0.01, 0.02, 0.02, 0.1, 5.0, 2.0, 3, 1.0, 1.0, 0.02, 0.3, 0.1, 0.02,
                             0.03, 0.02, 0.0, 0.0015, 0.0002, 0.0, 3.0)


def test_parameters_refuse_a_search_beyond_the_coarse_to_fine_region():
    with pytest.raises(ParameterError, match='search_radius'):
        dataclasses.replace(SUPERVISOR, search_radius=SUPERVISOR.coarse_to_fine_region)


def test_parameters_refuse_an_axis_tolerance_within_the_descent_region():
    with pytest.raises(ParameterError, match='descent_axis_tolerance'):
        dataclasses.replace(SUPERVISOR, descent_axis_tolerance=SUPERVISOR.descent_region)


def test_parameters_refuse_a_descent_region_outside_alignment_and_region():
    with pytest.raises(ParameterError, match='descent_region'):
        dataclasses.replace(SUPERVISOR, descent_region=0.5 * SUPERVISOR.insertion_alignment)
    with pytest.raises(ParameterError, match='descent_region'):
        dataclasses.replace(SUPERVISOR, descent_region=SUPERVISOR.coarse_to_fine_region)


@pytest.mark.parametrize('changes, words', [
    ({'insertion_alignment': 0.002}, 'smaller than gripper.insertion_position_tolerance'),
    ({'descent_region': 0.003, 'descent_axis_tolerance': 0.004,
      'coarse_to_fine_region': 0.03}, 'must not exceed gripper.insertion_position_tolerance'),
])
def test_parameters_refuse_a_tolerance_wider_than_the_grippers(changes, words):
    settings = dataclasses.replace(SUPERVISOR, **changes)  # within the section's own rules
    with pytest.raises(ParameterError, match=words):
        check_with_gripper(settings, PARAMS.gripper)
    check_with_gripper(SUPERVISOR, PARAMS.gripper)


def test_parameters_refuse_a_coarse_start_the_planner_would_refuse_to_stream_from():
    with pytest.raises(ParameterError, match='planner.stream.start_tolerance'):
        check_with_planner(SUPERVISOR, SUPERVISOR.coarse_start_tolerance)
    check_with_planner(SUPERVISOR, 2 * SUPERVISOR.coarse_start_tolerance)


def test_parameters_refuse_a_relaxation_wait_shorter_than_the_relaxation():
    with pytest.raises(ParameterError, match='control.relaxation.duration'):
        check_with_control(SUPERVISOR, SUPERVISOR.relaxation_wait + 0.01)
    check_with_control(SUPERVISOR, SUPERVISOR.relaxation_wait)


def test_the_shipped_parameter_file_keeps_every_rule():
    settings = section_from_flat(SupervisorParameters, FLAT, 'supervisor.')
    check_with_gripper(settings, PARAMS.gripper)
    check_with_planner(settings, FLAT['planner.stream.start_tolerance'])
    check_with_control(settings, FLAT['control.relaxation.duration'])
