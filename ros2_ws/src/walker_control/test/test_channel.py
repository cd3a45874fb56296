"""One joint's controller with its inputs, without a node: what a controller node decides."""

import math

import pytest

from walker_control.core.channel import ControllerChannel
from walker_control.core.config import load_controller_settings
from walker_control.core.inputs import Setpoint
from walker_control.core.joint_controller import Measurement
from walker_control.core.modes import Mode

SETTINGS = load_controller_settings()
T = SETTINGS.sample_time
STANCE = [0.0, 0.85, 1.45, 0.85, 0.0]  # physical joint angles [rad]
JOINT = 'a_pitch_joint'  # J2 with base a: no acceleration feedback


class Log:
    def __init__(self):
        self.lines = []

    def __call__(self, level, text, throttle):
        self.lines.append((level, text, throttle))

    def said(self, level, words):
        return any(lv == level and words in text for lv, text, _ in self.lines)


@pytest.fixture
def channel():
    log = Log()
    channel = ControllerChannel(SETTINGS, JOINT, log)
    channel.log = log
    return channel


def measurement(position=STANCE[1], velocity=0.0):
    return Measurement(position, velocity, 0.0, [STANCE[0], position, *STANCE[2:]])


def answer(channel, k, position=STANCE[1]):
    return channel.answer(k * T, measurement(position))


def test_a_mode_change_keeps_the_setpoints_sent_ahead_and_a_base_change_drops_them(channel):
    channel.command_mode(Mode.COARSE, 'a', 0.0, 0.0)
    for k in range(1, 6):  # streamed ahead, up to 5 T
        channel.take_setpoint('', Setpoint(STANCE[1] + 0.01 * k), k * T, 0.0)
    assert answer(channel, 1).reference.position == pytest.approx(STANCE[1] + 0.01)
    channel.command_mode(Mode.FINE, 'a', 0.0, 0.0)  # a stream that goes on into FINE
    assert answer(channel, 2).reference.position == pytest.approx(STANCE[1] + 0.02)
    channel.command_mode(Mode.HOLD, 'b', 0.0, 0.0)
    channel.command_mode(Mode.FINE, 'b', 0.0, 0.0)  # another base: nothing of the old stream
    output = answer(channel, 3)
    assert output.role == 4 and output.reference.position == pytest.approx(STANCE[1])
    assert channel.log.said('info', 'mode FINE, base gripper b, role J4')


def test_a_base_change_while_tracking_is_refused_and_the_joint_holds(channel):
    channel.command_mode(Mode.COARSE, 'a', 0.0, 0.0)
    answer(channel, 1)
    channel.command_mode(Mode.COARSE, 'b', 0.0, 0.0)
    output = answer(channel, 2)
    assert output.mode == Mode.HOLD and output.role == 2
    assert channel.log.said('error', 'only while holding')


@pytest.mark.parametrize('name, setpoint, words', [
    ('b_pitch_joint', Setpoint(0.9), 'on the topic of a_pitch_joint'),
    ('', Setpoint(math.nan), 'finite'),
    ('', Setpoint(10.0), 'joint limits'),
])
def test_a_refused_setpoint_holds_the_joint_and_is_not_used(channel, name, setpoint, words):
    channel.command_mode(Mode.FINE, 'a', 0.0, 0.0)
    assert channel.take_setpoint(name, setpoint, T, 0.0) is False
    output = answer(channel, 1)
    assert output.mode == Mode.HOLD and output.reference.position == pytest.approx(STANCE[1])
    assert channel.log.said('error', words)


def test_an_unstamped_setpoint_applies_from_the_next_state(channel):
    channel.command_mode(Mode.FINE, 'a', 0.0, 0.0)
    answer(channel, 1)
    assert channel.take_setpoint('', Setpoint(0.9), 0.0, 0.0)
    assert answer(channel, 2).reference.position == 0.9


def test_a_setpoint_older_than_the_timeout_holds_the_joint_and_reports_stale(channel):
    channel.command_mode(Mode.FINE, 'a', 0.0, 0.0)
    channel.take_setpoint('', Setpoint(0.9, 0.1), T, 0.0)
    late = 1 + math.ceil(SETTINGS.control.setpoint_timeout / T) + 1
    output = answer(channel, late)
    assert output.mode == Mode.HOLD and channel.reports_stale
    assert channel.log.said('warning', 'setpoint stream stale')


def test_a_setpoint_of_a_stream_paced_by_the_states_is_owed_until_it_comes(channel):
    channel.command_mode(Mode.FINE, 'a', 0.0, 0.0)
    channel.take_setpoint('', Setpoint(0.9), T, 0.0)
    answer(channel, 1)  # used at its own stamp: the stream is paced
    assert channel.owes_setpoint(2 * T)
    channel.take_setpoint('', Setpoint(0.9), 2 * T, 0.0)
    assert not channel.owes_setpoint(2 * T)


def test_a_refused_measurement_repeats_the_last_effort(channel):
    first = answer(channel, 1)
    assert channel.answer(2 * T, measurement(position=math.nan)) is None
    assert channel.last_effort == first.effort and channel.controller.mode == Mode.HOLD
    assert channel.log.said('error', 'last effort repeated')
    assert any(throttle > 0 for _, text, throttle in channel.log.lines
               if 'last effort repeated' in text)


def test_controller_states_are_due_at_the_state_rate(channel):
    every = round(1.0 / (SETTINGS.control.state_rate * T))
    due = [k for k in range(1, 4 * every + 1) if channel.state_due(k * T)]
    assert due == list(range(1, 4 * every + 1, every))
    assert channel.state_due(0.5 * T)  # the stamps went back (a plant reset)


# ------------------------------------------------------------------ whole trajectories
def take_ramp(channel, start, first=STANCE[1], last=STANCE[1] + 0.01, duration=10 * T):
    """Give ``channel`` a linear move of JOINT from ``first`` to ``last`` starting at ``start``."""
    return channel.take_trajectory((JOINT,), (0.0, duration), ((first,), (last,)), start=start)


def test_a_trajectory_is_sampled_at_every_state_and_its_end_held(channel):
    channel.command_mode(Mode.COARSE, 'a', 0.0, 0.0)
    answer(channel, 0)
    assert take_ramp(channel, start=T)
    references = [answer(channel, k).reference for k in range(1, 30)]
    assert references[5].position == pytest.approx(STANCE[1] + 0.005)
    assert references[5].velocity == pytest.approx(0.01 / (10 * T))
    assert all(r.position == pytest.approx(STANCE[1] + 0.01) and r.velocity == 0.0
               for r in references[10:])


def test_a_held_trajectory_is_never_waited_for_nor_stale(channel):
    channel.command_mode(Mode.COARSE, 'a', 0.0, 0.0)
    answer(channel, 0)
    take_ramp(channel, start=T)
    for k in range(1, 5):
        assert not channel.owes_setpoint(k * T)
        answer(channel, k)
    # long after any setpoint timeout, on both clocks: the trajectory is still the reference
    late = 100.0 * SETTINGS.control.setpoint_timeout
    assert not channel.check_inputs(late, late).any
    output = channel.answer(late, measurement())
    assert output.mode == Mode.COARSE
    assert output.reference.position == pytest.approx(STANCE[1] + 0.01)


def test_a_new_trajectory_replaces_the_held_one_from_its_start(channel):
    channel.command_mode(Mode.COARSE, 'a', 0.0, 0.0)
    answer(channel, 0)
    take_ramp(channel, start=T, last=STANCE[1] + 0.1, duration=100 * T)
    answer(channel, 1)
    # sent at 2 T to start at 5 T, a hold at its first point
    assert channel.take_trajectory((JOINT,), (0.0,), ((STANCE[1] - 0.2,),), start=5 * T)
    assert answer(channel, 4).reference.position == pytest.approx(STANCE[1] + 0.1 * 3 / 100)
    assert answer(channel, 5).reference.position == pytest.approx(STANCE[1] - 0.2)


@pytest.mark.parametrize('positions, words', [
    (((0.9,), (math.nan,)), 'finite'), (((0.9,), (10.0,)), 'joint limits'), ((), 'no points')])
def test_a_refused_trajectory_changes_nothing(channel, positions, words):
    channel.command_mode(Mode.COARSE, 'a', 0.0, 0.0)
    answer(channel, 0)
    take_ramp(channel, start=T)
    times = (0.0, 1.0)[:len(positions)]
    assert channel.take_trajectory((JOINT,), times, positions, start=T) is False
    output = answer(channel, 5)  # 4 T into the ramp
    assert output.mode == Mode.COARSE
    assert output.reference.position == pytest.approx(STANCE[1] + 0.004)
    assert channel.log.said('error', words)


def test_an_operators_setpoint_takes_over_from_the_trajectory(channel):
    channel.command_mode(Mode.FINE, 'a', 0.0, 0.0)
    answer(channel, 0)
    take_ramp(channel, start=T)
    assert channel.take_setpoint('', Setpoint(STANCE[1] - 0.05), 0.0, 0.0)
    assert answer(channel, 1).reference.position == pytest.approx(STANCE[1] - 0.05)


def test_back_to_tracking_after_an_ended_trajectory_starts_where_the_joint_is(channel):
    channel.command_mode(Mode.COARSE, 'a', 0.0, 0.0)
    answer(channel, 0)
    take_ramp(channel, start=T)
    answer(channel, 12)  # ended: its last point held
    channel.command_mode(Mode.HOLD, 'a', 0.0, 0.0)
    answer(channel, 13, position=STANCE[1] + 0.004)
    channel.command_mode(Mode.COARSE, 'a', 0.0, 0.0)
    output = answer(channel, 14, position=STANCE[1] + 0.004)
    assert output.reference.position == pytest.approx(STANCE[1] + 0.004)


def test_back_to_tracking_during_a_trajectory_goes_on_with_it(channel):
    channel.command_mode(Mode.HOLD, 'a', 0.0, 0.0)
    answer(channel, 0)
    take_ramp(channel, start=T)  # sent while holding, as a stream may start
    answer(channel, 2)
    channel.command_mode(Mode.COARSE, 'a', 0.0, 0.0)
    assert answer(channel, 3).reference.position == pytest.approx(STANCE[1] + 0.002)


def test_a_base_change_drops_the_trajectory(channel):
    channel.command_mode(Mode.COARSE, 'a', 0.0, 0.0)
    answer(channel, 0)
    take_ramp(channel, start=T)
    channel.command_mode(Mode.HOLD, 'a', 0.0, 0.0)
    channel.command_mode(Mode.HOLD, 'b', 0.0, 0.0)
    channel.command_mode(Mode.FINE, 'b', 0.0, 0.0)
    assert not channel.trajectory.holding_trajectory
