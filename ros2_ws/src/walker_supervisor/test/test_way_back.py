"""The way back above a step's target: which straight tip lines the arm can follow."""

import math

import numpy as np
import pytest

from walker_core.kinematics import KinematicsError, WalkerKinematics
from walker_core.robot_parameters import load_walker_parameters
from walker_supervisor.core.health import controller_trouble, tell_mode_again
from walker_supervisor.core.way_back import (
    ik_branch, line_is_followable, lowest_tip_height, vertical_configuration, vertical_ik)

KIN = WalkerKinematics.from_parameters(load_walker_parameters())
ABOVE_TARGET = np.array([0.0, -0.9, 0.03])  # half a turn from (0, 0.9)


def tip_at(radius, angle, height=0.03):
    return KIN.inverse([radius * math.cos(angle), radius * math.sin(angle), height, 0.0, 0.0],
                       reference=KIN.inverse([0.0, 0.9, 0.03, 0.0, 0.0]))


@pytest.mark.parametrize('radius, angle, followable', [
    (0.205, math.pi / 2 + 0.9, False),  # folded near the base: the line passes closer still
    (0.25, math.pi / 2 + 0.9, False),
    (0.25, math.pi, True),  # far enough round: the line keeps its distance from the base
    (0.6, math.pi + 0.3, True),
])
def test_a_tip_line_is_followable_only_where_the_arm_stays_within_its_limits(radius, angle,
                                                                             followable):
    theta = tip_at(radius, angle)
    assert line_is_followable(KIN, theta, ABOVE_TARGET) == followable
    if not followable:  # the planner agrees: some point of the line has no joint solution
        start = KIN.forward(theta)[:3]
        closest = min(np.linalg.norm((start + f * (ABOVE_TARGET - start))[:2])
                      for f in np.linspace(0.0, 1.0, 200))
        assert closest < radius


def test_the_joint_line_between_two_configurations_at_one_height_stays_at_that_height():
    start, goal = tip_at(0.205, math.pi / 2 + 0.9), KIN.inverse([*ABOVE_TARGET, 0.0, 0.0])
    assert lowest_tip_height(KIN, start, goal) == pytest.approx(0.03, abs=1e-3)
    low = tip_at(0.205, math.pi / 2 + 0.9, height=0.005)
    assert lowest_tip_height(KIN, low, goal) < 0.01


def test_the_branch_is_the_elbow_and_reach_of_the_joints():
    assert ik_branch(KIN, KIN.inverse([0.0, 0.9, 0.03, 0.0, 0.0])) == ('up', 'forward')
    for elbow in ('up', 'down'):
        for reach in ('forward', 'backward'):
            theta = KIN.inverse([0.0, 0.9, 0.03, 0.0, 0.0], elbow, reach, check_limits=False)
            assert ik_branch(KIN, theta) == (elbow, reach)


def test_the_vertical_configuration_turns_a_tilted_gripper_upright_where_the_tip_is():
    level = KIN.inverse([0.3, 0.6, 0.004, 0.0, 0.2])
    tilted = level + np.array([0.0, 0.02, -0.03, 0.055, 0.0])  # a fault at the mouth
    tip = KIN.forward(tilted)[:3]
    for upright in (vertical_ik(KIN, tip, tilted), vertical_configuration(KIN, tip, tilted)):
        pose = KIN.forward(upright)
        np.testing.assert_allclose(pose[:3], tip, atol=1e-9)  # the tip stays
        assert pose[3] == pytest.approx(0.0, abs=1e-9)  # the gripper vertical
        assert pose[4] == pytest.approx(KIN.forward(tilted)[4], abs=1e-9)  # its yaw kept
        assert ik_branch(KIN, upright) == ik_branch(KIN, tilted)
        assert np.max(np.abs(upright - tilted)) > 0.02  # it is a move, not the joints again


def test_without_a_vertical_configuration_the_checked_one_refuses_and_the_other_stays():
    theta = KIN.inverse([0.0, 0.9, 0.03, 0.0, 0.0])
    out_of_reach = np.array([0.0, 3.0, 0.03])
    with pytest.raises(KinematicsError):
        vertical_ik(KIN, out_of_reach, theta)
    np.testing.assert_array_equal(vertical_configuration(KIN, out_of_reach, theta), theta)


@pytest.mark.parametrize('stale, holding, tracking, words', [
    (False, False, True, ''),
    (True, True, True, 'stale'),
    (False, True, True, 'follows no motion'),  # fresh again, still holding in a step
    (False, True, False, ''),  # holding between steps, as commanded
])
def test_a_controller_holding_in_a_step_is_trouble_even_once_its_inputs_are_fresh(
        stale, holding, tracking, words):
    trouble = controller_trouble(stale, holding, tracking)
    assert (words in trouble) if words else trouble == ''


@pytest.mark.parametrize('stale, holding, tracking, told', [
    (False, True, True, True),  # fell back on a stall, fresh again: follow the motion again
    (True, True, True, False),  # still stale: it holds, and the watchdog decides
    (False, False, True, False),  # tracking already
    (False, True, False, False),  # holding as commanded
])
def test_a_controller_that_fell_back_on_a_stall_is_told_its_mode_again(stale, holding,
                                                                       tracking, told):
    assert tell_mode_again(stale, holding, tracking) == told
