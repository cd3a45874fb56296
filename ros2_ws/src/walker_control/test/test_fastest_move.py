"""The fastest reference a command filter lets the controller ask for: checked independently.

The linear programme's answer is run through the controller's own filter, sample by sample,
and compared with its limits; with no filter it must equal the closed-form bang-coast-bang
time, and a filter can only make it later.
"""

import math

import numpy as np
import pytest

from walker_control.core.fastest_move import _solve, fastest_move_through_filter
from walker_control.core.lowpass import LowPassFilter, design_lowpass_sos

T = 0.01  # [s] a coarse period keeps each programme small; the method does not depend on it
RATE, ACCELERATION = 1.5, 2.7   # [rad/s], [rad/s^2]
NONE = design_lowpass_sos(0, 0.0, T)


@pytest.mark.parametrize('distance', [0.3, math.pi / 2])  # bang-bang, and bang-coast-bang
def test_with_no_filter_the_move_takes_the_closed_form_time(distance):
    if distance * ACCELERATION <= RATE ** 2:
        exact = 2.0 * math.sqrt(distance / ACCELERATION)
    else:
        exact = distance / RATE + RATE / ACCELERATION
    move = fastest_move_through_filter(distance, RATE, ACCELERATION, NONE, T, 0.0)
    # on the sample grid the discrete move can be at most a couple of periods off the
    # continuous one
    assert move.arrival == pytest.approx(exact, abs=2.5 * T)


def test_a_filter_delays_the_arrival_and_a_lower_corner_more():
    arrivals = [fastest_move_through_filter(1.0, RATE, ACCELERATION,
                                            design_lowpass_sos(order, corner, T, 'bessel'), T,
                                            0.001).arrival
                for order, corner in ((0, 0.0), (4, 10.0), (4, 5.0))]
    assert arrivals[0] < arrivals[1] < arrivals[2]


@pytest.mark.parametrize('kind', ['bessel', 'critical'])
def test_the_setpoints_found_respect_every_limit_through_the_controllers_own_filter(kind):
    distance, tolerance = 1.0, 0.001
    sos = design_lowpass_sos(4, 5.0, T, kind)
    move = fastest_move_through_filter(distance, RATE, ACCELERATION, sos, T, tolerance)
    slack = 1e-7
    assert np.all(np.abs(move.acceleration) <= ACCELERATION + slack)
    assert np.all(np.abs(move.velocity) <= RATE + slack)
    assert move.position[-1] == pytest.approx(distance, abs=slack)
    # the controller's filter, run on the setpoints as the controller would
    shaper = LowPassFilter(4, 5.0, T, kind)
    shaped = np.array([shaper.update(p) for p in move.position])
    np.testing.assert_allclose(shaped, move.reference, atol=1e-6)
    assert np.all(np.abs(np.diff(np.concatenate([[0.0], shaped]))) / T <= RATE + 1e-5)
    arrived = move.times >= move.arrival - 1e-12
    assert np.all(np.abs(shaped[arrived] - distance) <= tolerance + 1e-6)
    assert np.abs(shaped[~arrived][-1] - distance) > tolerance - 1e-6  # it arrived just then


def test_one_period_sooner_is_impossible():
    sos = design_lowpass_sos(4, 5.0, T, 'bessel')
    move = fastest_move_through_filter(1.0, RATE, ACCELERATION, sos, T, 0.001, tail=0.6)
    entry = round(move.arrival / T) - 1
    settle = round(1.0 / T)
    assert _solve(1.0, RATE, ACCELERATION, sos, T, 0.001, entry, entry + round(0.6 / T),
                  settle) is not None
    assert _solve(1.0, RATE, ACCELERATION, sos, T, 0.001, entry - 1,
                  entry - 1 + round(0.6 / T), settle) is None


@pytest.mark.parametrize('name, value', [
    ('distance', 0.0), ('distance', math.nan), ('rate_limit', -1.0),
    ('acceleration_limit', math.inf), ('sample_time', 0.0), ('tolerance', -0.001),
    ('tail', 0.0), ('resolution', 0)])
def test_bad_arguments_are_refused_by_name(name, value):
    arguments = {'distance': 1.0, 'rate_limit': RATE, 'acceleration_limit': ACCELERATION,
                 'sos': NONE, 'sample_time': T, 'tolerance': 0.0, 'tail': 0.6,
                 'resolution': 1}
    arguments[name] = value
    with pytest.raises(ValueError, match=name):
        fastest_move_through_filter(**arguments)
