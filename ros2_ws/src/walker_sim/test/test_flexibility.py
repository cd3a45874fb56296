"""The bending springs are sized from the parameters so the model has the paper's modes."""

import dataclasses
import math

import numpy as np
import pytest

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_core.parameter_schema import ParameterError
from walker_core.robot_parameters import load_walker_parameters
from walker_sim.core.flexibility import (
    IDENTIFIED_JOINTS, JOINT_PLANES, default_stance, first_visible_mode, linear_model,
    tune_flexibility)
from walker_sim.core.plant import WalkerPlant

PARAMS = load_walker_parameters()


def with_flexibility(**changes):
    robot = dataclasses.replace(
        PARAMS.robot, flexibility=dataclasses.replace(PARAMS.robot.flexibility, **changes))
    return dataclasses.replace(PARAMS, robot=robot)


def test_the_predicted_modes_are_the_papers_at_the_default_stance(tuning):
    yaw, pitch, vertex = (tuning.predicted[j] for j in IDENTIFIED_JOINTS)
    flexibility = PARAMS.robot.flexibility
    assert yaw == pytest.approx(flexibility.joint1_mode, rel=1e-6)
    assert math.sqrt(pitch * vertex) == pytest.approx(flexibility.joints23_mode, rel=1e-6)
    for mode in (pitch, vertex):
        assert mode == pytest.approx(flexibility.joints23_mode, rel=0.10)


def test_the_mode_seen_at_each_joint_is_the_lowest_held_arm_mode_of_its_plane(tuning):
    """The definition: all five joints held, the lowest mode of the joint's bending plane."""
    model = linear_model(PARAMS)
    frequencies, planes, coupling = model.held_modes(tuning.in_plane_stiffness,
                                                     tuning.out_of_plane_stiffness)
    lowest = {plane: min(f for f, p in zip(frequencies, planes, strict=True) if p == plane)
              for plane in ('in_plane', 'out_of_plane')}
    for joint in IDENTIFIED_JOINTS:
        assert tuning.predicted[joint] == pytest.approx(lowest[JOINT_PLANES[joint]], rel=1e-9)
        # and it rings at that joint: it loads the joint's brake
        mode = int(np.argmin(np.abs(frequencies - tuning.predicted[joint])))
        row = PHYSICAL_JOINT_NAMES.index(joint)
        assert coupling[row, mode] ** 2 > 0.1 * np.max(coupling[row] ** 2)
    assert tuning.held[0] == pytest.approx(PARAMS.robot.flexibility.joint1_mode, rel=1e-9)


def test_the_free_joint_resonances_lie_above_the_held_arm_modes(tuning):
    """A joint left free lets its side of the arm swing: its resonance is higher."""
    for joint in IDENTIFIED_JOINTS:
        assert tuning.free_joint[joint] > 1.5 * tuning.predicted[joint]


def test_stiffness_follows_the_targets():
    """Asking for modes twice as high needs four times the stiffness (omega ~ sqrt(k))."""
    base = tune_flexibility(PARAMS)
    stiffer = tune_flexibility(with_flexibility(joint1_mode=36.0, joints23_mode=160.0))
    assert stiffer.out_of_plane_stiffness == pytest.approx(4 * base.out_of_plane_stiffness,
                                                           rel=1e-6)
    assert stiffer.in_plane_stiffness == pytest.approx(4 * base.in_plane_stiffness, rel=1e-6)


def test_damping_gives_the_target_mode_the_damping_ratio(tuning):
    zeta = PARAMS.robot.flexibility.damping_ratio
    # stiffness-proportional damping c = beta k: mode omega gets beta * omega / 2
    beta_out = tuning.out_of_plane_damping / tuning.out_of_plane_stiffness
    beta_in = tuning.in_plane_damping / tuning.in_plane_stiffness
    assert beta_out * PARAMS.robot.flexibility.joint1_mode / 2 == pytest.approx(zeta)
    assert beta_in * PARAMS.robot.flexibility.joints23_mode / 2 == pytest.approx(zeta)


def test_the_bending_planes_decouple_at_the_stance(tuning):
    """Joint 2 sees nothing of the out-of-plane bending, joint 1 nothing of the in-plane."""
    model = linear_model(PARAMS)
    soft_out = model.free_joint_modes('a_pitch_joint', tuning.in_plane_stiffness, 1e-3)
    assert np.all(soft_out[1][soft_out[0] < 1.0] < 1e-12)
    soft_in = model.free_joint_modes('a_yaw_joint', 1e-3, tuning.out_of_plane_stiffness)
    assert np.all(soft_in[1][soft_in[0] < 1.0] < 1e-12)
    frequencies, planes, coupling = model.held_modes(tuning.in_plane_stiffness,
                                                     tuning.out_of_plane_stiffness)
    in_plane = np.array([p == 'in_plane' for p in planes])
    assert np.all(np.abs(coupling[0, in_plane]) < 1e-9)   # yaw: no in-plane torque
    assert np.all(np.abs(coupling[1, ~in_plane]) < 1e-9)  # pitch: no out-of-plane torque


def test_first_visible_mode_skips_modes_without_residue():
    assert first_visible_mode([5.0, 18.0, 22.0], [0.0, 0.4, 4.0]) == 18.0
    assert first_visible_mode([5.0, 18.0], [1e-9, 1.0]) == 18.0


@pytest.mark.parametrize('frequencies, residues', [([], []), ([5.0, 18.0], [0.0, 0.0])])
def test_first_visible_mode_refuses_when_nothing_is_seen(frequencies, residues):
    with pytest.raises(ValueError, match='no mode is seen'):
        first_visible_mode(frequencies, residues)


def test_the_default_stance_is_the_inverted_v_at_the_truss_spacing():
    angles = default_stance(PARAMS)
    assert angles[2] > 0  # elbow up
    assert angles[1] + angles[2] + angles[3] == pytest.approx(math.pi)  # gripper vertical


def test_more_segments_need_a_faster_physics_step_and_the_plant_says_so(sim):
    fine = with_flexibility(segments_per_link=4)
    tuning = tune_flexibility(fine)
    assert tuning.predicted['a_yaw_joint'] == pytest.approx(18.0, rel=1e-6)
    assert tuning.stiffest > sim.physics_rate
    with pytest.raises(ParameterError, match=r'sim\.physics_rate .* too low .* at least'):
        WalkerPlant(fine, sim, tuning)


def test_the_default_model_is_refused_at_a_physics_rate_below_its_stiffest_mode(sim, tuning):
    """704 rad/s needs at least 704 Hz: 500 Hz (one step per control period) is refused."""
    assert sim.physics_rate >= tuning.minimum_physics_rate() > 500.0
    with pytest.raises(ParameterError, match=r'sim\.physics_rate \(500 Hz\) is too low'):
        WalkerPlant(PARAMS, dataclasses.replace(sim, physics_rate=500.0), tuning)
