"""Fixtures of the plant tests: plants built from the default parameters."""

import pytest

from walker_core.robot_parameters import load_walker_parameters
from walker_sim.core.config import StartConfiguration, load_sim_parameters
from walker_sim.core.flexibility import tune_flexibility
from walker_sim.core.plant import WalkerPlant


@pytest.fixture(scope='session')
def params():
    return load_walker_parameters()


@pytest.fixture(scope='session')
def sim():
    return load_sim_parameters()


@pytest.fixture(scope='session')
def tuning(params):
    return tune_flexibility(params)


@pytest.fixture(scope='session')
def one_attached(sim):
    """Start configurations: only the base gripper attached, the other free above its node."""
    def start(base='a', height=0.0):
        return StartConfiguration(base_gripper=base, base_node=sim.start.base_node,
                                  other_node=sim.start.other_node, other_attached=False,
                                  other_height=height)
    return start


@pytest.fixture
def make_plant(params, sim, tuning):
    """Build plants (closed after the test), optionally reset to a start configuration."""
    plants = []

    def make(start=None, flexibility=None, sim_parameters=None):
        plant = WalkerPlant(params, sim_parameters or sim, flexibility or tuning)
        plants.append(plant)
        if start is not None:
            plant.reset(start)
        return plant

    yield make
    for plant in plants:
        plant.close()
