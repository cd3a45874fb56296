"""A headless step over a truss as built: its nodes millimetres off their nominal places.

The plant's truss (``sim.imperfections.node_placement``, seed chosen for the geometry below)
has the start stance's other node 1.7 mm and 2.3 mm off along x and y and the target node 2.4
mm off along x, relative to the base node: beyond the gripper's 2 mm insertion tolerance. The
walker knows only the nominal truss; its map, its measured-pose extraction and its search get
it there, and the survey file it writes starts a second walk from where the nodes are.
"""

import numpy as np
import pytest

from walker_config.core.configuration import load_configuration
from walker_core.parameter_file import default_parameter_file
from walker_core.truss import Truss
from walker_headless.runner import walk
from walker_sim.core.imperfections import NodePlacement
from walker_supervisor.core.truss_map import TrussMap

TARGET = 'n1_2'
SEED = 155
STD = 0.0015  # [m]


@pytest.fixture(scope='module')
def configuration(tmp_path_factory):
    text = default_parameter_file().read_text()
    placement = '        node_placement: 0.0 '
    seed = '        seed: 0                         # chosen: seed of the placement'
    assert text.count(placement) == 1 and text.count(seed) == 1
    text = text.replace(placement, f'        node_placement: {STD} ').replace(
        seed, seed.replace('seed: 0  ', f'seed: {SEED}'))
    plant = tmp_path_factory.mktemp('truth') / 'truth.yaml'
    plant.write_text(text)
    loaded = load_configuration(plant_path=plant)
    imperfections = loaded.plant[1].imperfections
    assert (imperfections.node_placement, imperfections.seed) == (STD, SEED)
    return loaded


def _relative(node: str, configuration) -> np.ndarray:
    """Return the plant's placement error [m] of ``node`` relative to the base node's."""
    truss = Truss.from_parameters(configuration.walker)
    placement = NodePlacement(truss.node_names, STD, SEED)
    return placement.offset(node) - placement.offset('n1_1')


def test_a_step_over_displaced_nodes_reaches_its_node_and_maps_it(configuration):
    # the truss is as the docstring says: both nodes beyond the insertion tolerance
    assert np.hypot(*_relative('n2_1', configuration)[:2]) > 0.0025
    assert np.hypot(*_relative('n1_2', configuration)[:2]) > 0.0022
    result = walk(configuration, TARGET)
    assert result.reached, result.message
    (report,) = result.reports
    assert report.success
    survey = TrussMap.from_dict(Truss.from_parameters(configuration.walker), 0.0015, 2e-4,
                                result.survey)
    assert set(survey.surveyed_nodes) == {'n1_1', 'n2_1', 'n1_2'}
