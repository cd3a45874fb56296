"""Friction compensator: sign of the position error, deadband, continuity."""

import math

import numpy as np
import pytest

from walker_control.core.friction_compensation import FrictionCompensator

COMPENSATOR = FrictionCompensator(level=1.5, deadband=0.001, ramp=0.002)


@pytest.mark.parametrize('error', [0.0, 1e-6, -1e-6, 0.0009, -0.001, 0.001])
def test_zero_inside_the_deadband(error):
    assert COMPENSATOR.torque(error) == 0.0


@pytest.mark.parametrize('error', [0.0011, 0.003, 0.5, 10.0])
def test_sign_follows_the_position_error(error):
    assert COMPENSATOR.torque(error) > 0.0
    assert COMPENSATOR.torque(-error) == -COMPENSATOR.torque(error)


@pytest.mark.parametrize('error', [0.003, 0.01, 1.0])
def test_full_level_beyond_the_ramp(error):
    assert COMPENSATOR.torque(error) == 1.5
    assert COMPENSATOR.torque(-error) == -1.5


def test_continuous_so_it_cannot_chatter():
    errors = np.linspace(-0.01, 0.01, 200001)
    torques = np.array([COMPENSATOR.torque(e) for e in errors])
    step = errors[1] - errors[0]
    assert np.max(np.abs(np.diff(torques))) <= 1.5 / 0.002 * step * (1 + 1e-9)
    assert np.all(np.diff(torques) >= 0.0)  # monotonic: never pushes against the error


@pytest.mark.parametrize('kwargs', [
    {'level': -1.0, 'deadband': 0.0, 'ramp': 0.1},
    {'level': 1.0, 'deadband': -0.1, 'ramp': 0.1},
    {'level': 1.0, 'deadband': 0.0, 'ramp': 0.0},
    {'level': math.nan, 'deadband': 0.0, 'ramp': 0.1},
])
def test_bad_settings_are_refused(kwargs):
    with pytest.raises(ValueError):
        FrictionCompensator(**kwargs)


def test_non_finite_error_is_refused():
    with pytest.raises(ValueError, match='finite'):
        COMPENSATOR.torque(math.nan)
