"""The drive model: torque limits, refusal of non-finite commands, friction levels."""

import math

import numpy as np
import pytest

from walker_core.robot_parameters import load_walker_parameters
from walker_sim.core.config import load_sim_parameters
from walker_sim.core.motor import DriveModel

DRIVE = DriveModel.from_parameters(load_walker_parameters(), load_sim_parameters())


def test_commands_within_the_limits_pass_unchanged():
    torque = 0.5 * DRIVE.torque_limit * np.array([1, -1, 1, -1, 1])
    command = DRIVE.command(torque)
    np.testing.assert_array_equal(command.torque, torque)
    assert not command.saturated.any() and not command.refused.any()


def test_commands_beyond_the_limits_are_clamped_and_flagged():
    command = DRIVE.command(3.0 * DRIVE.torque_limit * np.array([1, -1, 0.1, 1, -1]))
    assert command.torque[0] == DRIVE.torque_limit[0]
    assert command.torque[1] == -DRIVE.torque_limit[1]
    assert list(command.saturated) == [True, True, False, True, True]


@pytest.mark.parametrize('bad', [math.nan, math.inf, -math.inf])
def test_non_finite_commands_are_refused_and_replaced_by_zero(bad):
    command = DRIVE.command([1.0, bad, 1.0, 1.0, 1.0])
    assert command.torque[1] == 0.0
    assert list(command.refused) == [False, True, False, False, False]
    assert np.all(np.isfinite(command.torque))


@pytest.mark.parametrize('bad', [[1.0] * 4, [[1.0] * 5], 'torque'])
def test_malformed_commands_are_refused_by_shape(bad):
    with pytest.raises(ValueError):
        DRIVE.command(bad)


def test_a_stuck_joint_breaks_away_at_stiction_a_moving_one_slides_at_coulomb():
    slow = DRIVE.stiction_velocity / 2
    fast = DRIVE.stiction_velocity * 2
    levels = DRIVE.friction_level([0.0, slow, -slow, fast, -fast])
    assert levels[:3] == tuple(DRIVE.stiction_torque[:3])
    assert levels[3:] == tuple(DRIVE.friction_torque[3:])


def test_friction_is_above_ten_percent_of_the_torque_limit_as_the_paper_measured():
    assert np.all(DRIVE.friction_torque > 0.1 * DRIVE.torque_limit)
    assert np.all(DRIVE.stiction_torque >= DRIVE.friction_torque)
