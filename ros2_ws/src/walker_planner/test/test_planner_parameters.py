"""The planner's section of the parameter file: every value present, checked, refused by name."""

import dataclasses

import pytest

from walker_core.parameter_schema import (
    ParameterError, leaf_specs, load_parameter_file, replace_in_section)
from walker_core.robot_parameters import default_parameter_file
from walker_planner.core.parameters import PREFIX, PlannerParameters

LEAVES = [spec.name for spec in leaf_specs(PlannerParameters, PREFIX)]


def test_every_planner_parameter_is_in_the_one_file():
    flat = load_parameter_file(default_parameter_file())
    assert set(LEAVES) <= set(flat)
    # every one may change at run time but the way trajectories go to the controllers, which
    # a running node keeps (a change mid-motion would mix a stream with a whole trajectory)
    fixed = {spec.name for spec in leaf_specs(PlannerParameters, PREFIX) if spec.read_only}
    assert fixed == {'planner.send_whole_trajectories'}


@pytest.mark.parametrize('name, value, words', [
    ('planner.bang_bang.torque_fraction', 1.5, 'above the maximum'),
    ('planner.bang_bang.torque_fraction', 0.0, 'below the minimum'),
    ('planner.joint.max_acceleration', 3.0, 'must not exceed planner.joint.acceleration_limit'),
    ('planner.cartesian.max_acceleration', 5.0, 'acceleration_limit'),
    ('planner.stream.start_tolerance', float('nan'), 'finite'),
    ('planner.cartesian.fine_speed', 'slow', 'expected a number'),
])
def test_invalid_planner_values_are_refused_and_change_nothing(planner_parameters, name, value,
                                                               words):
    before = dataclasses.asdict(planner_parameters)
    with pytest.raises(ParameterError, match=words):
        replace_in_section(planner_parameters, {name: value}, PREFIX)
    assert dataclasses.asdict(planner_parameters) == before
