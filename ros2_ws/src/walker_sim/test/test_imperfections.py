"""The truth's errors against the model: truss node placement and joint sensor errors."""

import numpy as np
import pytest

from walker_core.parameter_schema import ParameterError, replace_in_section
from walker_sim.core.imperfections import JointSensors, NodePlacement
from walker_sim.core.plant import Pose


def imperfect(sim, **values):
    return replace_in_section(sim, {f'sim.imperfections.{k}': v for k, v in values.items()},
                              'sim.')


def run(plant, seconds, torque=None):
    period = 1.0 / plant.params.timing.control_rate
    states = []
    for _ in range(round(seconds / period)):
        states.append(plant.step(np.zeros(5) if torque is None else torque, period))
    return states


def test_the_shipped_file_has_no_imperfection(sim):
    assert sim.imperfections.node_placement == 0.0
    assert not any(sim.imperfections.joint_offset) and not any(sim.imperfections.joint_noise)


@pytest.mark.parametrize('values, named', [
    ({'joint_offset': [0.0] * 4}, 'joint_offset'),
    ({'joint_noise': [0.001] * 6}, 'joint_noise'),
    ({'node_placement': -0.001}, 'node_placement'),
    ({'seed': -1}, 'seed')])
def test_bad_imperfections_are_refused_naming_the_parameter(sim, values, named):
    with pytest.raises(ParameterError, match=named):
        imperfect(sim, **values)


def test_node_placement_is_drawn_from_the_seed_alone():
    names = [f'n{c}_{r}' for r in range(4) for c in range(5)]
    first = NodePlacement(names, 0.001, seed=7)
    again = NodePlacement(names, 0.001, seed=7)
    other = NodePlacement(names, 0.001, seed=8)
    assert first.errors == again.errors
    assert first.errors != other.errors
    drawn = np.array(list(first.errors.values()))
    assert drawn.shape == (20, 3)
    assert 0.0003 < drawn.std() < 0.003
    assert NodePlacement(names, 0.0, seed=7).errors == {}
    np.testing.assert_array_equal(NodePlacement(names, 0.0, 7).offset('n1_1'), np.zeros(3))


def test_sensor_noise_restarts_from_its_seed():
    sensors = JointSensors([0.001, 0, 0, 0, 0], [0.0, 0.002, 0, 0, 0], seed=3)
    readings = []
    for _ in range(50):
        sensors.sample()
        readings.append(sensors.read(np.zeros(5)))
    readings = np.array(readings)
    np.testing.assert_array_equal(readings[:, 0], 0.001)
    assert 0.001 < readings[:, 1].std() < 0.004
    np.testing.assert_array_equal(readings[:, 2:], 0.0)
    sensors.restart()
    sensors.sample()
    np.testing.assert_array_equal(sensors.read(np.zeros(5)), readings[0])


def test_no_imperfection_leaves_the_plant_bit_identical(make_plant, sim):
    """All zeros: the readings are the true angles and the run repeats exactly."""
    plant = make_plant()
    states = run(plant, 0.2, torque=np.array([1.0, -1.0, 2.0, 0.5, -0.5]))
    np.testing.assert_array_equal(states[-1].position, plant.true_joint_positions())
    seeded = make_plant(sim_parameters=imperfect(sim, seed=12345))
    again = run(seeded, 0.2, torque=np.array([1.0, -1.0, 2.0, 0.5, -0.5]))
    for a, b in zip(states, again, strict=True):
        np.testing.assert_array_equal(a.position, b.position)
        np.testing.assert_array_equal(a.poses['b'].position, b.poses['b'].position)


def test_the_joint_readings_err_while_the_physics_does_not(make_plant, sim):
    offset = [0.002, -0.001, 0.0, 0.0, 0.003]
    exact = make_plant()
    erring = make_plant(sim_parameters=imperfect(
        sim, joint_offset=offset, joint_noise=[0.0005] * 5, seed=9))
    torque = np.array([1.0, -1.0, 2.0, 0.5, -0.5])
    truth, read = run(exact, 0.1, torque), run(erring, 0.1, torque)
    for a, b in zip(truth, read, strict=True):
        np.testing.assert_array_equal(a.poses['b'].position, b.poses['b'].position)
        np.testing.assert_array_equal(a.velocity, b.velocity)
    errors = np.array([b.position - a.position for a, b in zip(truth, read, strict=True)])
    np.testing.assert_allclose(errors.mean(axis=0), offset, atol=0.0003)
    assert 0.0003 < errors.std(axis=0).min() and errors.std(axis=0).max() < 0.0008
    np.testing.assert_array_equal(erring.true_joint_positions(), exact.true_joint_positions())
    # a reset plant reads the same noise again
    erring.reset()
    np.testing.assert_array_equal(run(erring, 0.1, torque)[-1].position, read[-1].position)


def test_displaced_nodes_move_the_holes_the_start_and_the_seats(make_plant, sim):
    """The grippers start in the displaced holes, where the plant measures them."""
    plant = make_plant(sim_parameters=imperfect(sim, node_placement=0.002, seed=4))
    state = plant.state()
    for gripper, node in (('a', sim.start.base_node), ('b', sim.start.other_node)):
        error = plant.placement.offset(node)
        assert np.linalg.norm(error) > 1e-4
        np.testing.assert_allclose(state.poses[gripper].position,
                                   plant.truss.position(node) + error, atol=1e-6)
        assert state.grippers[gripper].alignment.node == node
        assert state.grippers[gripper].alignment.position_error < 1e-6


def test_a_gripper_where_the_model_puts_a_displaced_hole_misses_it(make_plant, sim):
    """Aimed at the model's place, the tip is off the real hole by the node's error."""
    plant = make_plant(sim_parameters=imperfect(sim, node_placement=0.005, seed=4))
    node = 'n3_2'
    ex, ey, ez = plant.placement.offset(node)
    vertical = plant.state().poses[sim.start.base_gripper].orientation
    alignment = plant.state().measure(Pose(plant.truss.position(node), vertical))
    assert alignment.node == node
    assert alignment.position_error == pytest.approx(np.hypot(np.hypot(ex, ey), max(-ez, 0.0)),
                                                     abs=1e-9)
    assert alignment.position_error > plant.params.gripper.insertion_position_tolerance
