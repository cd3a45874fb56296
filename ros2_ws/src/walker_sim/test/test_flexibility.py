"""The bending springs are sized from the parameters so the model has the paper's modes."""

import dataclasses
import math

import numpy as np
import pytest

from walker_core.parameter_schema import ParameterError
from walker_core.robot_parameters import load_walker_parameters
from walker_sim.core.flexibility import (
    IDENTIFIED_JOINTS, default_stance, first_visible_mode, linear_model, tune_flexibility)
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


def test_a_held_joint_sees_lower_modes_than_a_free_one(tuning):
    """Holding every joint clamps the links: the lowest mode drops below joint 1's."""
    assert tuning.clamped[0] < tuning.predicted['a_yaw_joint']


def test_the_bending_planes_decouple_at_the_stance(tuning):
    """Joint 2 sees nothing of the out-of-plane bending, joint 1 nothing of the in-plane."""
    model = linear_model(PARAMS)
    soft_out = model.joint_modes('a_pitch_joint', tuning.in_plane_stiffness, 1e-3)
    assert np.all(soft_out[1][soft_out[0] < 1.0] < 1e-12)
    soft_in = model.joint_modes('a_yaw_joint', 1e-3, tuning.out_of_plane_stiffness)
    assert np.all(soft_in[1][soft_in[0] < 1.0] < 1e-12)


def test_first_visible_mode_skips_modes_without_residue():
    assert first_visible_mode([5.0, 18.0, 22.0], [0.0, 0.4, 4.0]) == 18.0
    assert first_visible_mode([5.0, 18.0], [1e-9, 1.0]) == 18.0


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
