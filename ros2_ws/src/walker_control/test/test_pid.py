"""PID terms, conditional-integration anti-windup and output clamping."""

import math

import pytest

from walker_control.core.pid import Pid, PidGains


def make(p=10.0, i=4.0, d=2.0, limit=5.0, integral_limit=None):
    return Pid(PidGains(p, i, d, limit, limit if integral_limit is None else integral_limit))


def test_terms():
    pid = make()
    terms = pid.compute_command(0.1, -0.2, 0.01)
    assert terms.proportional == pytest.approx(1.0)
    assert terms.derivative == pytest.approx(-0.4)
    assert terms.integral == pytest.approx(4.0 * 0.1 * 0.01)
    assert terms.command == pytest.approx(1.0 - 0.4 + 0.004)
    assert not terms.saturated
    terms = pid.compute_command(0.1, 0.0, 0.02)
    assert terms.integral == pytest.approx(0.004 + 4.0 * 0.1 * 0.02)


def test_integral_is_a_torque_that_survives_a_gain_change():
    pid = make()
    for _ in range(10):
        pid.compute_command(0.1, 0.0, 0.01)
    before = pid.integral_term
    pid.set_gains(PidGains(20.0, 8.0, 1.0, 5.0, 5.0))
    assert pid.integral_term == before
    assert pid.compute_command(0.0, 0.0, 0.01).integral == before


def test_output_is_clamped_at_the_limit():
    pid = make(limit=5.0)
    terms = pid.compute_command(10.0, 0.0, 0.01)
    assert terms.command == 5.0 and terms.saturated
    terms = pid.compute_command(-10.0, 0.0, 0.01)
    assert terms.command == -5.0 and terms.saturated


def test_integral_does_not_wind_up_while_saturated():
    pid = make(p=10.0, i=4.0, d=0.0, limit=5.0)
    for _ in range(1000):
        terms = pid.compute_command(1.0, 0.0, 0.01)  # P alone is 10 > 5: saturated throughout
        assert terms.saturated
    assert pid.integral_term == 0.0
    # Once the error reverses the output leaves saturation at once (no stored integral).
    assert pid.compute_command(-0.1, 0.0, 0.01).command == pytest.approx(-1.0 - 0.004)


def test_integral_still_unwinds_while_saturated():
    pid = make(p=0.0, i=4.0, d=0.0, limit=5.0, integral_limit=5.0)
    pid.reset(3.0)
    terms = pid.compute_command(-1.0, 0.0, 0.1)
    assert terms.integral == pytest.approx(3.0 - 0.4)


def test_integral_is_bounded_by_its_own_limit():
    pid = make(p=0.0, i=100.0, d=0.0, limit=5.0, integral_limit=2.0)
    for _ in range(100):
        pid.compute_command(1.0, 0.0, 0.01)
    assert pid.integral_term == 2.0


def test_integral_held_on_request():
    pid = make()
    pid.compute_command(0.1, 0.0, 0.01)
    before = pid.integral_term
    pid.compute_command(0.1, 0.0, 0.01, hold_integral=True)
    assert pid.integral_term == before


def test_no_integral_gain_no_integral():
    pid = make(i=0.0)
    for _ in range(100):
        pid.compute_command(0.3, 0.0, 0.01)
    assert pid.integral_term == 0.0


@pytest.mark.parametrize('error, rate, dt', [
    (math.nan, 0.0, 0.01), (0.0, math.inf, 0.01), (0.1, 0.0, 0.0), (0.1, 0.0, -0.01),
    (0.1, 0.0, math.nan)])
def test_bad_inputs_are_refused_and_change_nothing(error, rate, dt):
    pid = make()
    pid.compute_command(0.2, 0.0, 0.01)
    before = pid.integral_term
    with pytest.raises(ValueError):
        pid.compute_command(error, rate, dt)
    assert pid.integral_term == before


@pytest.mark.parametrize('field', ['p', 'i', 'd', 'output_limit', 'integral_limit'])
@pytest.mark.parametrize('value', [-1.0, math.nan, math.inf])
def test_bad_gains_are_refused(field, value):
    values = {'p': 1.0, 'i': 1.0, 'd': 1.0, 'output_limit': 1.0, 'integral_limit': 1.0}
    values[field] = value
    with pytest.raises(ValueError, match=field):
        PidGains(**values)
