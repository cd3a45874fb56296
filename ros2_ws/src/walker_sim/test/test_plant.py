"""The plant core: start stance, friction, torque limits, grippers, interlock, stability."""

import dataclasses

import numpy as np
import pytest

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_core.kinematics import WalkerKinematics, invert_transform
from walker_core.gripper_state import GripperState
from walker_sim.core.grippers import GripperCommandError, InterlockError
from walker_sim.core.plant import PlantError

PITCH = PHYSICAL_JOINT_NAMES.index('a_pitch_joint')


def run(plant, torque, seconds):
    period = 1.0 / plant.params.timing.control_rate
    state = plant.state()
    for _ in range(round(seconds / period)):
        state = plant.step(torque, period)
    return state


def test_the_start_stance_puts_each_gripper_in_its_node(make_plant, params, sim):
    plant = make_plant()
    state = plant.state()
    for gripper, node in (('a', sim.start.base_node), ('b', sim.start.other_node)):
        assert state.grippers[gripper].status.mode == GripperState.ATTACHED
        assert state.grippers[gripper].alignment.node == node
        assert state.grippers[gripper].alignment.position_error < 1e-6
        assert state.grippers[gripper].alignment.axis_error < 1e-6
    assert state.base == sim.start.base_gripper and state.time == 0.0


@pytest.mark.parametrize('base', ['a', 'b'])
def test_either_gripper_can_be_the_base(make_plant, one_attached, sim, base):
    plant = make_plant(one_attached(base))
    state = plant.state()
    other = 'b' if base == 'a' else 'a'
    assert state.base == base and state.tip == other
    assert state.grippers[base].status.mode == GripperState.ATTACHED
    assert state.grippers[other].status.mode == GripperState.FREE
    assert state.grippers[other].alignment.node == sim.start.other_node
    assert state.grippers[other].alignment.position_error < 1e-6
    # the tip pose relative to the base is the kinematics of the joints in role order
    kinematics = WalkerKinematics.from_parameters(plant.params)
    roles = state.position if base == 'a' else state.position[::-1]
    relative = invert_transform(state.poses[base].matrix()) @ state.poses[other].matrix()
    np.testing.assert_allclose(relative, kinematics.forward_transform(roles), atol=1e-6)


def test_friction_holds_the_arm_under_a_torque_below_its_level(make_plant, one_attached):
    plant = make_plant(one_attached())
    torque = np.zeros(5)
    torque[PITCH] = 0.8 * plant.drive.friction_torque[PITCH]
    before = plant.state().position
    state = run(plant, torque, 1.0)
    np.testing.assert_allclose(state.position, before, atol=1e-9)
    assert state.friction[PITCH] == pytest.approx(-torque[PITCH], rel=1e-3)


def test_a_torque_above_the_stiction_level_moves_the_arm(make_plant, one_attached):
    plant = make_plant(one_attached())
    torque = np.zeros(5)
    # lifting the free gripper off its node (pushed down, the node's face would hold it)
    torque[PITCH] = -1.5 * plant.drive.stiction_torque[PITCH]
    before = plant.state().position
    state = run(plant, torque, 0.5)
    assert before[PITCH] - state.position[PITCH] > 1e-3
    # sliding: the friction torque is the Coulomb level, against the motion
    assert state.friction[PITCH] == pytest.approx(plant.drive.friction_torque[PITCH], rel=1e-3)


def test_between_coulomb_and_stiction_a_stuck_joint_stays_stuck(make_plant, one_attached):
    plant = make_plant(one_attached())
    level = 0.5 * (plant.drive.friction_torque[PITCH] + plant.drive.stiction_torque[PITCH])
    torque = np.zeros(5)
    torque[PITCH] = level
    before = plant.state().position
    assert run(plant, torque, 0.5).position[PITCH] == pytest.approx(before[PITCH], abs=1e-9)


def test_torques_are_limited_and_non_finite_ones_refused(make_plant, one_attached):
    plant = make_plant(one_attached())
    period = 1.0 / plant.params.timing.control_rate
    state = plant.step([100.0, np.nan, 0.0, -100.0, np.inf], period)
    limit = plant.drive.torque_limit
    np.testing.assert_array_equal(state.effort, [limit[0], 0.0, 0.0, -limit[3], 0.0])
    assert list(state.saturated) == [True, False, False, True, False]
    assert list(state.refused) == [False, True, False, False, True]
    assert np.all(np.isfinite(state.position)) and np.all(np.isfinite(state.velocity))


@pytest.mark.parametrize('dt', [0.0, -0.002, 0.00125, float('nan')])
def test_a_step_that_is_not_whole_physics_steps_is_refused(make_plant, dt):
    plant = make_plant()
    with pytest.raises(PlantError, match='step duration'):
        plant.step(np.zeros(5), dt)
    assert plant.time == 0.0


def test_a_torque_vector_of_the_wrong_length_is_refused(make_plant):
    plant = make_plant()
    with pytest.raises(PlantError, match='5 values'):
        plant.step(np.zeros(4), 0.002)
    assert plant.time == 0.0


def test_insertion_within_tolerance_attaches_the_gripper_rigidly(make_plant, one_attached,
                                                               params):
    plant = make_plant(one_attached(height=0.5 * params.gripper.insertion_position_tolerance))
    outcome = plant.screw_in('b')
    assert outcome.success and outcome.status.mode == GripperState.SCREWING
    state = run(plant, np.zeros(5), params.gripper.screw_time + 0.01)
    assert state.grippers['b'].status.mode == GripperState.ATTACHED
    # drawn into the seat by the thread
    assert state.grippers['b'].alignment.position_error < 1e-4
    held = state.poses['b'].position
    # drive every joint hard: an attached gripper does not move
    state = run(plant, 0.9 * plant.drive.torque_limit * np.array([1, 1, -1, 1, 1]), 0.5)
    np.testing.assert_allclose(state.poses['b'].position, held, atol=5e-4)


def test_insertion_outside_tolerance_jams_and_leaves_the_gripper_free(make_plant,
                                                                     one_attached, params):
    height = 2.5 * params.gripper.insertion_position_tolerance
    plant = make_plant(one_attached(height=height))
    outcome = plant.screw_in('b')
    assert not outcome.success and outcome.status.mode == GripperState.JAMMED
    assert f'position error {height * 1e3:.2f} mm exceeds' in outcome.status.message
    before = plant.state().poses['b'].position
    state = run(plant, 0.5 * plant.drive.torque_limit * np.array([0, 1, 1, 0, 0]), 0.3)
    assert np.linalg.norm(state.poses['b'].position - before) > 1e-3  # free, not held
    assert state.grippers['b'].status.mode == GripperState.JAMMED


def test_releasing_the_only_attached_gripper_is_refused(make_plant, one_attached):
    plant = make_plant(one_attached())
    with pytest.raises(InterlockError, match='interlock'):
        plant.unscrew('a')
    state = run(plant, np.zeros(5), 1.0)
    assert state.grippers['a'].status.mode == GripperState.ATTACHED


def test_a_released_gripper_lets_go_after_the_screw_time(make_plant, params):
    plant = make_plant()
    assert plant.unscrew('b').mode == GripperState.UNSCREWING
    with pytest.raises(InterlockError):
        plant.unscrew('a')
    state = run(plant, np.zeros(5), params.gripper.screw_time + 0.01)
    assert state.grippers['b'].status.mode == GripperState.FREE and state.base == 'a'
    before = state.poses['b'].position
    # lifted off its node (pushed down, the node's face would hold it)
    state = run(plant, -0.5 * plant.drive.torque_limit * np.array([0, 1, 1, 0, 0]), 0.3)
    assert state.poses['b'].position[2] - before[2] > 1e-3


def test_gripper_commands_in_the_wrong_state_are_refused(make_plant):
    plant = make_plant()
    with pytest.raises(GripperCommandError, match='needs a free gripper'):
        plant.screw_in('a')
    with pytest.raises(GripperCommandError, match="unknown gripper 'c'"):
        plant.screw_in('c')
    with pytest.raises(GripperCommandError, match="unknown gripper 'c'"):
        plant.unscrew('c')


def excite(plant):
    plant.enable_friction(False)
    torque = np.array([4.0, -5.0, 5.0, 3.0, 1.0])
    run(plant, torque, 0.02)
    run(plant, -torque, 0.02)


def energy_record(plant, seconds, samples):
    energies = [plant.energy()]
    for _ in range(samples):
        run(plant, np.zeros(5), seconds / samples)
        energies.append(plant.energy())
    return np.array(energies)


@pytest.mark.parametrize('both_attached', [False, True])
def test_energy_never_grows_with_zero_input(make_plant, one_attached, both_attached):
    plant = make_plant(None if both_attached else one_attached())
    excite(plant)
    energy = energy_record(plant, 4.0, 40)
    assert energy[0] > 0
    assert np.all(np.diff(energy) <= 1e-6 * energy[0])
    assert energy[-1] < 0.5 * energy[0]


def test_energy_stays_bounded_without_structural_damping(make_plant, one_attached, tuning):
    undamped = dataclasses.replace(tuning, in_plane_damping=0.0, out_of_plane_damping=0.0)
    plant = make_plant(one_attached(), flexibility=undamped)
    excite(plant)
    energy = energy_record(plant, 8.0, 80)
    # nothing dissipates: the integrator's energy error oscillates with the stiffest mode
    # (omega h = 0.36) by a few per cent; it must stay bounded and not drift upwards
    assert energy.max() < 1.05 * energy[0]
    assert energy[-20:].mean() <= 1.01 * energy[:20].mean()


def test_the_plant_is_deterministic(make_plant, one_attached):
    rng = np.random.default_rng(3)
    torques = rng.uniform(-5.0, 5.0, (200, 5))
    states = []
    for _ in range(2):
        plant = make_plant(one_attached())
        for torque in torques:
            state = plant.step(torque, 0.002)
        states.append(state)
    np.testing.assert_array_equal(states[0].position, states[1].position)
    np.testing.assert_array_equal(states[0].velocity, states[1].velocity)


def test_reset_returns_to_the_start(make_plant, one_attached):
    plant = make_plant(one_attached())
    start = plant.state()
    run(plant, 3.0 * np.ones(5), 0.2)
    again = plant.reset(one_attached())
    assert again.time == 0.0
    np.testing.assert_allclose(again.position, start.position, atol=1e-12)
    np.testing.assert_array_equal(again.velocity, np.zeros(5))


def test_accelerations_are_the_velocity_change_over_the_step(make_plant, one_attached):
    plant = make_plant(one_attached())
    before = plant.state().velocity
    state = plant.step(5.0 * np.ones(5), 0.002)
    np.testing.assert_allclose(state.acceleration, (state.velocity - before) / 0.002)
    assert np.any(np.abs(state.acceleration) > 1.0)


@pytest.mark.parametrize('base', ['a', 'b'])
def test_the_tip_position_is_in_the_base_frame_of_eq_1(make_plant, one_attached, params, base):
    """At rest (links straight) it is the forward kinematics of the role angles."""
    plant = make_plant(one_attached(base, height=0.03))
    state = plant.state()
    roles = state.position if base == 'a' else state.position[::-1]
    expected = WalkerKinematics.from_parameters(params).forward(roles)[:3]
    assert state.tip_position == pytest.approx(expected, abs=1e-6)
    assert state.tip_position[2] == pytest.approx(0.03, abs=1e-6)


def test_make_plant_builds_the_file_plant_with_a_free_tip():
    from walker_core.parameter_schema import ParameterError
    from walker_sim.core import make_plant

    with make_plant(other_attached=False, other_height=0.03) as plant:
        state = plant.reset()
        assert state.statuses['a'].mode == GripperState.ATTACHED
        assert state.statuses['b'].mode == GripperState.FREE
        assert state.tip_position[2] == pytest.approx(0.03, abs=1e-6)
    with pytest.raises(ParameterError, match='other_height'):
        make_plant(other_attached=False, other_height=-0.1)


def test_gripper_commands_are_answered_as_the_gripper_command_service_answers(make_plant,
                                                                              one_attached,
                                                                              params):
    plant = make_plant(one_attached(height=2.5 * params.gripper.insertion_position_tolerance))
    success, message = plant.command_gripper('a', 'unscrew')  # the only one attached
    assert not success and 'interlock' in message
    success, message = plant.command_gripper('b', 'screw_in')  # out of tolerance: jams
    assert not success and 'exceeds' in message
    assert plant.gripper_status('b').mode == GripperState.JAMMED
    assert plant.command_gripper('b', 'twist') == (
        False, "unknown gripper command 'twist': expected 'screw_in' or 'unscrew'")
    assert plant.gripper_status('a').mode == GripperState.ATTACHED
    both = make_plant()
    assert both.command_gripper('b', 'unscrew') == (True, '')
    assert both.gripper_status('b').mode == GripperState.UNSCREWING
