"""Fixtures of the planner's tests: the default robot, planner parameters, planning context."""

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))  # the tests' own helpers (shooting)

from walker_core.parameter_schema import load_parameter_file, section_from_flat
from walker_core.robot_parameters import default_parameter_file, load_walker_parameters
from walker_planner.core.parameters import PREFIX, PlannerParameters
from walker_planner.core.planning import PlanningContext


@pytest.fixture(scope='session')
def robot():
    return load_walker_parameters()


@pytest.fixture(scope='session')
def planner_parameters():
    return section_from_flat(PlannerParameters, load_parameter_file(default_parameter_file()),
                             PREFIX)


@pytest.fixture(scope='session')
def context(robot, planner_parameters):
    return PlanningContext.from_parameters(robot, planner_parameters)
