"""The streamer: one stream at a time on the joint states, its end, and the hold after it."""

import numpy as np
import pytest

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_planner.core.errors import PlanningError
from walker_planner.core.streamer import TrajectoryStreamer
from walker_planner.core.streaming import SampledTrajectory

MS = 1_000_000
PERIOD = 2 * MS
LOOKAHEAD = 4
START = np.array([0.0, 0.8, 1.4, 0.8, 0.0])


class Sent(list):
    def __call__(self, stamp, positions, velocities, accelerations):
        self.append((stamp, list(positions), list(velocities), list(accelerations)))

    @property
    def stamps(self):
        return [s[0] for s in self]


@pytest.fixture
def sent():
    return Sent()


@pytest.fixture
def streamer(sent):
    return TrajectoryStreamer(PERIOD, LOOKAHEAD, 0.01, sent)


def ramp(duration=0.02, start=START):
    """Return a joint-1 ramp of 0.1 rad over ``duration`` seconds."""
    times = np.array([0.0, duration])
    positions = np.array([start, start + [0.1, 0, 0, 0, 0]])
    velocity = np.zeros((2, 5))
    return SampledTrajectory.from_points(PHYSICAL_JOINT_NAMES, times, positions, velocity,
                                         velocity)


def test_a_stream_needs_a_joint_state_starting_where_the_trajectory_starts(streamer):
    with pytest.raises(PlanningError, match='no joint_states'):
        streamer.start(ramp())
    streamer.on_state(0, START + [0.1, 0, 0, 0, 0])
    with pytest.raises(PlanningError, match='a_yaw_joint'):
        streamer.start(ramp())
    assert streamer.active is None


def test_a_stream_asked_for_before_any_state_waits_for_the_first_then_starts(streamer):
    """A goal that came before the plant's states matched (another thread takes them)."""
    import threading

    assert streamer.wait_for_state(0.0) is False  # nothing heard: the wait ends at its limit
    taken = threading.Timer(0.05, streamer.on_state, (0, START))
    taken.start()
    assert streamer.wait_for_state(60.0) is True  # True only when ended by the state
    taken.join()
    assert streamer.start(ramp()).stream.origin == PERIOD
    assert streamer.wait_for_state(0.0) is True  # heard once: no wait again


def test_a_stream_sends_the_lookahead_at_once_then_one_setpoint_a_state(streamer, sent):
    streamer.on_state(10 * PERIOD, START)
    active = streamer.start(ramp(), owner='goal')
    assert active.owner == 'goal' and active.stream.origin == 11 * PERIOD
    assert sent.stamps == [11 * PERIOD, 12 * PERIOD, 13 * PERIOD, 14 * PERIOD]
    assert sent[0][1] == pytest.approx(START)  # time 0 applies a period after the state
    streamer.on_state(11 * PERIOD, START)
    assert sent.stamps[-1] == 15 * PERIOD
    with pytest.raises(PlanningError, match='already running'):
        streamer.start(ramp())


def test_a_stream_ends_at_the_state_one_period_before_its_final_setpoint(streamer, sent):
    streamer.on_state(0, START)
    active = streamer.start(ramp(0.02))  # final setpoint at 2 ms + 20 ms
    stamp = 0
    while streamer.active is not None:
        stamp += PERIOD
        streamer.on_state(stamp, START)
    assert stamp + PERIOD == active.last.stamp == 22 * MS and active.last.final
    assert not active.cancelled and streamer.take_ended() == [active]
    assert streamer.take_ended() == []
    assert active.duration == pytest.approx(0.02)


def test_after_a_stream_its_last_position_is_held_while_the_controllers_track(streamer, sent):
    streamer.on_control_mode(True)
    streamer.on_state(0, START)
    active = streamer.start(ramp(0.004))
    stamp = 0
    while streamer.active is not None:
        stamp += PERIOD
        streamer.on_state(stamp, START)
    last = active.last
    before = len(sent)
    streamer.on_state(last.stamp, START)
    held = sent[before:]
    assert held and all(s[1] == pytest.approx(last.position) and s[2] == [0.0] * 5
                        for s in held)
    assert [s[0] for s in held] == list(range(last.stamp + PERIOD,
                                              last.stamp + LOOKAHEAD * PERIOD + 1, PERIOD))
    streamer.on_control_mode(False)  # HOLD: the controllers need no setpoints
    before = len(sent)
    streamer.on_state(last.stamp + PERIOD, START)
    assert len(sent) == before


def test_tracking_again_without_a_stream_holds_where_the_joints_are(streamer, sent):
    streamer.on_state(0, START)
    streamer.start(ramp(0.004))
    streamer.end_now(streamer.active, 'cancelled')
    streamer.on_control_mode(False)
    measured = START + [0.05, 0, 0, 0, 0]
    streamer.on_state(20 * PERIOD, measured)
    streamer.on_control_mode(True)
    before = len(sent)
    streamer.on_state(21 * PERIOD, measured)
    assert sent[before:] and all(s[1] == pytest.approx(measured) for s in sent[before:])
    assert sent[before][0] == 22 * PERIOD


def test_a_cancelled_stream_stops_at_rest_where_its_sent_setpoints_end(streamer, sent):
    streamer.on_state(0, START)
    active = streamer.start(ramp(1.0))
    last_sent = sent[-1]
    streamer.end_now(active, 'cancelled')
    hold = sent[-1]
    assert hold[0] == last_sent[0] + PERIOD and hold[1] == pytest.approx(last_sent[1])
    assert hold[2] == [0.0] * 5 and hold[3] == [0.0] * 5
    assert active.cancelled and active.message == 'cancelled' and streamer.active is None
    assert streamer.stop() is False  # nothing runs now


def test_a_stream_marked_cancelled_ends_at_the_next_state(streamer, sent):
    streamer.on_state(0, START)
    active = streamer.start(ramp(1.0))
    active.cancel()
    streamer.on_state(PERIOD, START)
    assert streamer.active is None and active.ended and active.message == 'cancelled'


def test_feedback_is_due_every_so_many_setpoints(streamer):
    streamer.on_state(0, START)
    active = streamer.start(ramp(1.0))  # 4 sent
    assert streamer.feedback_due(4) is active
    assert streamer.feedback_due(4) is None
    for k in range(1, 5):
        streamer.on_state(k * PERIOD, START)
    assert streamer.feedback_due(4) is active
    elapsed, fraction = streamer.progress(active)
    assert elapsed == pytest.approx(4 * PERIOD * 1e-9) and fraction == pytest.approx(0.008)
    # the newest state (4 periods) against the trajectory at its own time (3 periods in)
    desired = active.stream.trajectory.sample(3 * PERIOD * 1e-9).position
    assert streamer.tracking_error(active.stream) == pytest.approx(abs(desired[0] - START[0]))
    assert streamer.tracking_error(active.stream) > 0.0


def test_whole_trajectories_are_sent_once_and_end_as_the_stream_would(sent):
    """Sent to controllers that hold trajectories: once, at its origin; nothing per period."""
    whole = []
    streamer = TrajectoryStreamer(PERIOD, LOOKAHEAD, 0.01, sent,
                                  lambda start, trajectory: whole.append((start, trajectory)))
    twin = TrajectoryStreamer(PERIOD, LOOKAHEAD, 0.01, Sent())
    for each in (streamer, twin):
        each.on_state(10 * PERIOD, START)
    trajectory = ramp()
    active, streamed = streamer.start(trajectory), twin.start(ramp())
    assert [(start, t is trajectory) for start, t in whole] == [(11 * PERIOD, True)]
    stamp = 10 * PERIOD
    while twin.active is not None:  # the same states to both, until the stream ends
        stamp += PERIOD
        for each in (streamer, twin):
            each.on_state(stamp, START)
        assert (streamer.active is None) == (twin.active is None)
    assert active.ended and streamed.ended and active.ticks == streamed.ticks
    for _ in range(5):  # no hold streamed after it: the controllers hold the last point
        stamp += PERIOD
        streamer.on_state(stamp, START)
    assert sent == [] and len(whole) == 1


def test_a_cancelled_whole_trajectory_is_replaced_by_a_hold_where_its_setpoints_end(sent):
    whole = []
    streamer = TrajectoryStreamer(PERIOD, LOOKAHEAD, 0.01, sent,
                                  lambda start, trajectory: whole.append((start, trajectory)))
    twin_sent = Sent()
    twin = TrajectoryStreamer(PERIOD, LOOKAHEAD, 0.01, twin_sent)
    for each in (streamer, twin):
        each.on_state(0, START)
        each.start(ramp(duration=0.2))
        each.on_state(PERIOD, START)
        each.end_now(each.active, 'cancelled')
    start, hold = whole[-1]
    held_stamp, held_position, held_velocity, _ = twin_sent[-1]
    assert start == held_stamp
    assert len(hold.times) == 1 and hold.positions[0] == pytest.approx(held_position)
    assert np.all(hold.velocities == 0.0) and held_velocity == pytest.approx([0.0] * 5)


def _whole(sent):
    whole = []
    streamer = TrajectoryStreamer(PERIOD, LOOKAHEAD, 0.01, sent,
                                  lambda start, trajectory: whole.append((start, trajectory)))
    return streamer, whole


def test_a_whole_trajectory_ends_by_the_clock_when_the_states_would_end_it(sent):
    """Its end is a time on the clock: reached with no state heard since the start."""
    streamer, whole = _whole(sent)
    twin = TrajectoryStreamer(PERIOD, LOOKAHEAD, 0.01, Sent())
    for each in (streamer, twin):
        each.on_state(10 * PERIOD, START)
    active, streamed = streamer.start(ramp(0.013)), twin.start(ramp(0.013))
    stamp = 10 * PERIOD
    while twin.active is not None:
        stamp += PERIOD
        twin.on_state(stamp, START)
    assert active.stream.end_stamp == streamed.last.stamp  # the end the stream reached
    streamer.on_clock(stamp - 1)  # the clock between the states: not yet
    assert streamer.active is active and streamer.take_ended() == []
    streamer.on_clock(stamp)
    assert streamer.active is None and streamer.take_ended() == [active]
    assert not active.cancelled and active.last.final and active.ticks == streamed.ticks
    assert active.duration == pytest.approx(streamed.duration)
    assert len(whole) == 1 and sent == []


def test_the_clock_ends_nothing_that_streams_setpoints(streamer, sent):
    streamer.on_state(0, START)
    active = streamer.start(ramp(0.01))
    streamer.on_clock(10**9)
    assert streamer.active is active


def test_a_whole_trajectory_starts_from_the_clock_when_it_ran_past_the_states(sent):
    """Nothing waits for the planner: the plant's clock may be periods past its newest state."""
    streamer, whole = _whole(sent)
    streamer.on_state(10 * PERIOD, START)
    active = streamer.start(ramp(), now=13 * PERIOD + PERIOD // 2)
    assert [start for start, _ in whole] == [14 * PERIOD] == [active.stream.origin]
    early, _ = _whole(Sent())
    early.on_state(10 * PERIOD, START)  # a clock behind the newest state changes nothing
    assert early.start(ramp(), now=9 * PERIOD).stream.origin == 11 * PERIOD


def test_a_cancel_holds_where_the_whole_trajectory_is_on_the_clock(sent):
    streamer, whole = _whole(sent)
    streamer.on_state(0, START)
    active = streamer.start(ramp(duration=0.2))  # computed up to 4 periods ahead
    streamer.end_now(active, 'cancelled', now=20 * PERIOD + 1)
    start, hold = whole[-1]
    assert start == 21 * PERIOD and len(hold.times) == 1
    expected = active.stream.trajectory.sample(active.stream.trajectory_time(20 * PERIOD))
    assert hold.positions[0] == pytest.approx(expected.position)
    assert np.all(hold.velocities == 0.0) and streamer.take_ended() == [active]
    # with the clock behind what was computed ahead, where that ends, as a stream's hold
    streamer.on_state(0, START)
    again = streamer.start(ramp(duration=0.2))
    streamer.stop(now=PERIOD)
    start, hold = whole[-1]
    assert start == again.last.stamp and hold.positions[0] == pytest.approx(
        again.stream.trajectory.sample(again.stream.trajectory_time(4 * PERIOD)).position)
