"""Time scalings: boundary conditions, continuity and limits of every profile."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from walker_planner.core.errors import LimitError
from walker_planner.core.profiles import (
    BlendProfile, ConstantVelocityProfile, MinJerkProfile)

rates = st.floats(0.05, 5.0)
accelerations = st.floats(0.05, 20.0)


def dense(profile, count=4001):
    t = np.linspace(0.0, profile.duration, count)
    return t, profile.evaluate(t)


def assert_rest_to_rest(profile):
    s, sd, sdd = profile.evaluate(np.array([0.0, profile.duration]))
    np.testing.assert_allclose(s, [0.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(sd, [0.0, 0.0], atol=1e-12)


def assert_continuous(profile, derivative_tolerance):
    """Position continuous, and velocity the derivative of position (no jumps)."""
    t, (s, sd, sdd) = dense(profile)
    step = t[1] - t[0]
    assert np.max(np.abs(np.diff(s))) <= np.max(np.abs(sd)) * step * (1 + 1e-9) + 1e-15
    # velocity continuous: consecutive samples differ by at most the peak acceleration * dt
    assert np.max(np.abs(np.diff(sd))) <= profile.peak_acceleration * step * (1 + 1e-9) + 1e-15
    central = (s[2:] - s[:-2]) / (2 * step)
    np.testing.assert_allclose(central, sd[1:-1], atol=derivative_tolerance)


@settings(max_examples=60, deadline=None)
@given(rates, accelerations)
def test_blend_by_acceleration_is_rest_to_rest_within_limits_and_fastest(rate, acceleration):
    profile = BlendProfile.by_acceleration(rate, acceleration)
    assert_rest_to_rest(profile)
    assert_continuous(profile, 2 * profile.peak_acceleration * profile.duration / 4000)
    assert profile.peak_rate <= rate * (1 + 1e-12)
    assert profile.peak_acceleration == pytest.approx(acceleration, rel=1e-12)
    # nothing under these limits is faster: full acceleration then full deceleration when
    # that stays under the rate limit (peak rate sqrt(a)), else cruising at the limit between
    if math.sqrt(acceleration) <= rate:
        shortest = 2 * math.sqrt(1 / acceleration)
    else:
        shortest = 1 / rate + rate / acceleration
    assert profile.duration == pytest.approx(shortest, rel=1e-12)


@settings(max_examples=60, deadline=None)
@given(rates, accelerations, st.floats(1.0, 3.0))
def test_blend_by_time_settles_at_the_time_within_limits(rate, acceleration, stretch):
    shortest = BlendProfile.by_acceleration(rate, acceleration).duration
    profile = BlendProfile.by_time(shortest * stretch, rate, acceleration)
    assert profile.duration == pytest.approx(shortest * stretch, rel=1e-12)
    assert_rest_to_rest(profile)
    assert_continuous(profile, 2 * profile.peak_acceleration * profile.duration / 4000)
    assert profile.peak_rate <= rate * (1 + 1e-9)
    assert profile.peak_acceleration <= acceleration * (1 + 1e-9)


def test_blend_by_time_uses_the_least_acceleration():
    profile = BlendProfile.by_time(2.0, max_rate=10.0, max_acceleration=10.0)
    assert profile.acceleration == pytest.approx(1.0)  # 4 / T^2: two parabolas, no cruise
    capped = BlendProfile.by_time(2.0, max_rate=0.75, max_acceleration=10.0)
    assert capped.cruise_rate == pytest.approx(0.75)


def test_a_settling_time_too_short_is_refused_with_the_shortest_possible():
    with pytest.raises(LimitError, match=r'too short .* takes 2 s'):
        BlendProfile.by_time(1.0, max_rate=10.0, max_acceleration=1.0)


@settings(max_examples=40, deadline=None)
@given(rates, accelerations)
def test_min_jerk_is_rest_to_rest_with_zero_end_acceleration_within_limits(rate, acceleration):
    profile = MinJerkProfile.by_limits(rate, acceleration)
    assert_rest_to_rest(profile)
    _, _, sdd = profile.evaluate(np.array([0.0, profile.duration]))
    np.testing.assert_allclose(sdd, 0.0, atol=1e-12)
    t, (s, sd, sdd) = dense(profile)
    assert np.max(sd) <= rate * (1 + 1e-9)
    assert np.max(np.abs(sdd)) <= acceleration * (1 + 1e-9)
    assert max(np.max(sd) / rate, np.max(np.abs(sdd)) / acceleration) == pytest.approx(1, rel=1e-4)
    assert np.all(np.diff(s) >= 0)


def test_constant_velocity_moves_at_one_rate_and_rests_at_the_ends():
    profile = ConstantVelocityProfile(4.0)
    t = np.linspace(0.0, 4.0, 101)
    s, sd, sdd = profile.evaluate(t)
    np.testing.assert_allclose(s, t / 4.0)
    np.testing.assert_allclose(sd, 0.25)
    np.testing.assert_allclose(sdd, 0.0)
