"""Setpoint validation and selection by stamp, and the input watchdog."""

import math

import pytest

from walker_control.core.config import load_controller_settings
from walker_control.core.inputs import (
    InputWatchdog, Setpoint, SetpointBuffer, SetpointError, StreamPacing,
    carry_forward, validate_setpoint)

DRIVE = load_controller_settings().drive(1)


def test_a_valid_setpoint_passes():
    setpoint = Setpoint(position=0.5, velocity=-0.2, acceleration=3.0, effort=0.1)
    assert validate_setpoint(setpoint, DRIVE) is setpoint


@pytest.mark.parametrize('field', ['position', 'velocity', 'acceleration', 'effort'])
@pytest.mark.parametrize('value', [math.nan, math.inf, -math.inf])
def test_non_finite_setpoints_are_refused_by_field(field, value):
    with pytest.raises(SetpointError, match=f'{field} = {value!r}.*finite'):
        validate_setpoint(Setpoint(**{'position': 0.0, field: value}), DRIVE, 'a_yaw_joint')


@pytest.mark.parametrize('kwargs, words', [
    ({'position': DRIVE.position_max + 0.01}, 'joint limits'),
    ({'position': DRIVE.position_min - 0.01}, 'joint limits'),
    ({'position': 0.0, 'velocity': DRIVE.velocity_limit * 1.01}, 'velocity limit'),
    ({'position': 0.0, 'effort': -DRIVE.torque_limit * 1.01}, 'torque limit'),
])
def test_out_of_range_setpoints_are_refused(kwargs, words):
    with pytest.raises(SetpointError, match=words):
        validate_setpoint(Setpoint(**kwargs), DRIVE)


def test_the_newest_setpoint_not_later_than_the_state_is_selected():
    buffer = SetpointBuffer()
    for stamp in (1.000, 1.002, 1.004, 1.006):
        buffer.add(stamp, Setpoint(position=stamp))
    assert buffer.select(0.999) is None
    assert buffer.select(1.004) == (1.004, Setpoint(position=1.004))
    assert buffer.select(1.005) == (1.004, Setpoint(position=1.004))
    assert buffer.select(2.0) == (1.006, Setpoint(position=1.006))


def test_setpoints_arriving_out_of_order_are_sorted_and_duplicates_replaced():
    buffer = SetpointBuffer()
    buffer.add(1.004, Setpoint(position=4.0))
    buffer.add(1.002, Setpoint(position=2.0))
    buffer.add(1.004, Setpoint(position=5.0))
    assert len(buffer) == 2
    assert buffer.select(1.003) == (1.002, Setpoint(position=2.0))
    assert buffer.select(1.004) == (1.004, Setpoint(position=5.0))


def test_dropping_until_a_stamp_keeps_only_the_later_setpoints():
    buffer = SetpointBuffer()
    for k in range(5):
        buffer.add(k * 0.002, Setpoint(position=float(k)))
    buffer.drop_until(0.004)
    assert len(buffer) == 2 and buffer.select(0.0059) is None
    assert buffer.select(0.006) == (0.006, Setpoint(position=3.0))


def test_the_buffer_is_bounded_and_can_be_cleared():
    buffer = SetpointBuffer(capacity=3)
    for k in range(10):
        buffer.add(float(k), Setpoint(position=float(k)))
    assert len(buffer) == 3 and buffer.select(6.5) is None
    buffer.clear()
    assert buffer.select(100.0) is None and buffer.newest_stamp() is None


T = 0.002  # [s] a control period


def paced_stream(pacing, buffer, states):
    """Answer states 1..states of a stream sent one period ahead, as the planner does."""
    buffer.add(T, Setpoint(position=0.0))
    for k in range(1, states + 1):
        buffer.add((k + 1) * T, Setpoint(position=0.0))  # sent on the state stamped k T
        assert not pacing.owed(k * T, buffer.newest_stamp())
        pacing.used(k * T, buffer.select(k * T)[0])


def test_a_paced_stream_owes_each_state_its_setpoint_until_it_comes():
    pacing, buffer = StreamPacing(), SetpointBuffer()
    assert not pacing.owed(T, None)  # nothing streamed yet: nothing owed
    paced_stream(pacing, buffer, 5)
    assert pacing.paced
    # the stream is late: the setpoint for 7 T (due on the state 6 T) has not come
    assert pacing.owed(7 * T, buffer.newest_stamp())
    buffer.add(7 * T, Setpoint(position=0.1))
    assert not pacing.owed(7 * T, buffer.newest_stamp())
    # stamps computed in another way (another process's float arithmetic) still match
    pacing.used(7 * T + 1e-9, 7 * T)
    assert pacing.owed(8 * T, buffer.newest_stamp())


def test_a_state_answered_without_its_setpoint_ends_the_pacing():
    pacing, buffer = StreamPacing(), SetpointBuffer()
    paced_stream(pacing, buffer, 3)
    assert pacing.owed(5 * T, buffer.newest_stamp())
    pacing.used(5 * T, buffer.select(5 * T)[0])  # waited long enough: the older one used
    assert not pacing.paced and not pacing.owed(6 * T, buffer.newest_stamp())
    pacing.used(6 * T, None)  # holding, or not tracking
    assert not pacing.owed(7 * T, None)
    paced_stream(pacing, buffer, 3)
    pacing.reset()  # a mode change drops the setpoints: nothing owed until paced again
    assert not pacing.owed(5 * T, None)


def test_an_operators_setpoints_are_never_waited_for():
    """Unstamped setpoints take the last state's stamp on arrival; sparse ones their own."""
    pacing, buffer = StreamPacing(), SetpointBuffer()
    last = T
    for k in range(2, 20):
        if k % 3 == 0:  # one arrives now and then, stamped with the last state answered
            buffer.add(last, Setpoint(position=0.01 * k))
        assert not pacing.owed(k * T, buffer.newest_stamp())
        selected = buffer.select(k * T)
        pacing.used(k * T, None if selected is None else selected[0])
        last = k * T


def test_watchdog_state_stream():
    watchdog = InputWatchdog(state_timeout=0.2, setpoint_timeout=0.1)
    assert not watchdog.check(100.0).any  # nothing received yet: not stale
    watchdog.state_received(10.0)
    assert not watchdog.check(10.2).any
    stale = watchdog.check(10.25)
    assert stale.state and not stale.setpoint and 'no joint state' in stale.reason


def test_watchdog_watches_setpoints_only_when_expected_and_after_the_first():
    watchdog = InputWatchdog(state_timeout=0.2, setpoint_timeout=0.1)
    watchdog.setpoint_received(1.0)
    assert not watchdog.check(5.0).setpoint  # not expected (hold)
    watchdog.expect_setpoints(True)
    assert not watchdog.check(5.0).setpoint  # expected, none received since
    watchdog.setpoint_received(5.0)
    assert not watchdog.check(5.1).setpoint
    stale = watchdog.check(5.15)
    assert stale.setpoint and 'no setpoint' in stale.reason
    watchdog.expect_setpoints(False)
    assert not watchdog.check(6.0).any


def test_in_sim_time_a_silence_counts_only_once_the_clock_runs():
    """A clock held still (the supervisor waiting for an answer) owes no states or setpoints.

    The steady silence is the same in each case: the clock decides. On the wall clock (no
    clock given) the steady silence alone counts.
    """
    T = 0.002
    watchdog = InputWatchdog(state_timeout=0.5, setpoint_timeout=0.5, clock_slack=2 * T)
    watchdog.expect_setpoints(True)
    watchdog.state_received(10.0, stamp=4.0)
    watchdog.setpoint_received(10.0)  # came with the state stamped 4 s
    assert not watchdog.check(12.0, clock=4.0).any  # held at the state's time
    assert not watchdog.check(12.0, clock=4.0 + 2 * T).any  # within the slack
    stale = watchdog.check(12.0, clock=4.0 + 3 * T)  # the clock runs: nothing came
    assert stale.state and stale.setpoint
    assert watchdog.check(12.0).state and watchdog.check(12.0).setpoint  # wall clock
    assert not watchdog.check(10.4, clock=5.0).any  # the clock ran, not the steady timeout


def test_in_sim_time_setpoints_silent_while_states_come_are_stale():
    """A planner gone while the plant steps: the states are fresh, the setpoints are not."""
    T = 0.002
    watchdog = InputWatchdog(state_timeout=0.5, setpoint_timeout=0.5, clock_slack=2 * T)
    watchdog.expect_setpoints(True)
    watchdog.state_received(10.0, stamp=4.0)
    watchdog.setpoint_received(10.0)
    for k in range(1, 4):  # a state every 0.3 s: each waited for its setpoint in vain
        watchdog.state_received(10.0 + 0.3 * k, stamp=4.0 + k * T)
    stale = watchdog.check(10.9, clock=4.0 + 3 * T)
    assert stale.setpoint and not stale.state and 'no setpoint' in stale.reason


def test_a_setpoint_too_old_for_the_state_is_stale_by_stamps():
    watchdog = InputWatchdog(state_timeout=0.2, setpoint_timeout=0.1)
    assert watchdog.setpoint_lag(10.05, 10.0) == ''
    assert 'older than the joint state' in watchdog.setpoint_lag(10.2, 10.0)


def test_the_watchdog_reports_when_each_stream_was_last_heard():
    watchdog = InputWatchdog(0.5, 0.5)
    assert watchdog.last_state is None and watchdog.last_setpoint is None
    watchdog.state_received(1.0)
    watchdog.setpoint_received(1.1)
    assert watchdog.last_state == 1.0
    assert watchdog.last_setpoint is None  # setpoints not expected: not watched
    watchdog.expect_setpoints(True)
    watchdog.setpoint_received(1.2)
    assert watchdog.last_setpoint == 1.2


@pytest.mark.parametrize('elapsed', [0.002, 0.01, 0.05])
def test_a_late_setpoint_is_carried_along_its_constant_acceleration_exactly(elapsed):
    """Within a segment of constant acceleration the carried setpoint is the trajectory's."""
    def sample(t):
        return Setpoint(position=0.1 + 0.8 * t + 0.5 * 2.0 * t * t, velocity=0.8 + 2.0 * t,
                        acceleration=2.0, effort=0.3)

    carried = carry_forward(sample(0.0), elapsed, 0.05, DRIVE)
    expected = sample(elapsed)
    assert carried.position == pytest.approx(expected.position, abs=1e-12)
    assert carried.velocity == pytest.approx(expected.velocity, abs=1e-12)
    assert (carried.acceleration, carried.effort) == (2.0, 0.3)


def test_a_setpoint_is_carried_no_longer_than_the_horizon():
    setpoint = Setpoint(position=0.0, velocity=1.0)
    assert carry_forward(setpoint, 0.2, 0.05, DRIVE) == carry_forward(setpoint, 0.05, 0.05, DRIVE)
    assert carry_forward(setpoint, 0.2, 0.05, DRIVE).position == pytest.approx(0.05)


@pytest.mark.parametrize('setpoint, elapsed, horizon', [
    (Setpoint(position=0.4), 0.03, 0.05),                 # at rest: an operator's setpoint
    (Setpoint(position=0.4, velocity=1.0), 0.0, 0.05),    # not late
    (Setpoint(position=0.4, velocity=1.0), -0.002, 0.05),  # applies later (never selected)
    (Setpoint(position=0.4, velocity=1.0), 0.03, 0.0),    # carrying turned off
])
def test_a_setpoint_at_rest_on_time_or_with_carrying_off_is_unchanged(setpoint, elapsed,
                                                                       horizon):
    assert carry_forward(setpoint, elapsed, horizon, DRIVE) is setpoint


def test_a_carried_setpoint_stays_within_the_joint_limits():
    near_end = Setpoint(position=DRIVE.position_max - 0.001, velocity=DRIVE.velocity_limit,
                        acceleration=20.0)
    carried = carry_forward(near_end, 0.05, 0.05, DRIVE)
    assert carried.position == DRIVE.position_max
    assert carried.velocity == DRIVE.velocity_limit
