"""The plant's parameter section: loaded from the shared file, refused by name when invalid."""

import dataclasses

import pytest

from walker_core.parameter_schema import ParameterError, load_parameter_file
from walker_core.robot_parameters import default_parameter_file, load_walker_parameters
from walker_sim.core.config import SimParameters, check_against_walker, load_sim_parameters

FLAT = load_parameter_file(default_parameter_file())
PARAMS = load_walker_parameters()
SIM = load_sim_parameters()


def test_defaults_load_and_agree_with_the_shared_parameters():
    assert SIM.clock_mode in ('sim_time', 'real_time')
    assert SIM.physics_rate >= 1000.0
    check_against_walker(SIM, PARAMS)


@pytest.mark.parametrize('name, value, words', [
    ('sim.clock_mode', 'fast', 'must be one of'),
    ('sim.physics_rate', float('nan'), 'finite'),
    ('sim.physics_rate', 50.0, 'below the minimum'),
    ('sim.lockstep_timeout', -1.0, 'below the minimum'),
    ('sim.start.base_gripper', 'c', 'must be one of'),
    ('sim.start.other_node', 'n1_1', 'must differ'),
    ('sim.start.other_height', 0.01, 'must be 0 when'),
])
def test_invalid_values_are_refused_by_name(name, value, words):
    flat = dict(FLAT, **{name: value})
    with pytest.raises(ParameterError, match=words):
        SimParameters.from_flat(flat)


@pytest.mark.parametrize('change, words', [
    ({'physics_rate': 1250.0}, 'integer multiple'),
    ({'start': 'off-truss'}, 'not on the truss'),
])
def test_rules_across_sections_are_checked(change, words):
    sim = SIM
    if change.get('start') == 'off-truss':
        sim = dataclasses.replace(SIM, start=dataclasses.replace(SIM.start, other_node='n9_9'))
    else:
        sim = dataclasses.replace(SIM, **change)
    with pytest.raises(ParameterError, match=words):
        check_against_walker(sim, PARAMS)
