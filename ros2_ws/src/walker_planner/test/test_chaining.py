"""Two motions streamed as one, overlapping: checked against the closed-form sum of the two."""

import numpy as np
import pytest

from walker_planner.core.chaining import chain
from walker_planner.core.errors import InvalidRequestError
from walker_planner.core.streaming import SampledTrajectory

PERIOD = 0.002  # [s] the planner's sample spacing


def minimum_jerk(start, goal, duration):
    """Closed-form minimum-jerk motion between two joint vectors: (q, dq, ddq) of t."""
    start, goal = np.asarray(start, float), np.asarray(goal, float)

    def at(t):
        x = np.clip(np.asarray(t, float) / duration, 0.0, 1.0)[..., None]
        inside = ((np.asarray(t) > 0) & (np.asarray(t) < duration))[..., None]
        s = 10 * x ** 3 - 15 * x ** 4 + 6 * x ** 5
        ds = (30 * x ** 2 - 60 * x ** 3 + 30 * x ** 4) / duration * inside
        dds = (60 * x - 180 * x ** 2 + 120 * x ** 3) / duration ** 2 * inside
        return start + s * (goal - start), ds * (goal - start), dds * (goal - start)
    return at


def sampled(motion, duration):
    times = np.round(np.arange(0.0, duration + PERIOD / 2, PERIOD), 9)
    q, dq, ddq = motion(times)
    return SampledTrajectory(times, q, dq, ddq)


LIFT_START = np.array([0.1, -0.4, 1.2, -0.8, 0.0])
LIFT_END = np.array([0.1, -0.45, 1.25, -0.8, 0.0])
SWEEP_END = np.array([1.67, -0.45, 1.25, -0.8, -1.57])
LIFT = minimum_jerk(LIFT_START, LIFT_END, 0.294)
SWEEP = minimum_jerk(LIFT_END, SWEEP_END, 1.8)


@pytest.mark.parametrize('lead', [0.0, 0.05, 0.2, 0.294])
def test_the_joined_motion_is_the_sum_of_the_two_everywhere(lead):
    joined = chain(sampled(LIFT, 0.294), sampled(SWEEP, 1.8), lead)
    start = 0.294 - lead
    assert joined.duration == pytest.approx(0.294 + 1.8 - lead, abs=1e-9)
    t = np.linspace(0.0, joined.duration, 5003)  # between the points as well as on them
    got = joined.sample(t)
    lift, sweep = LIFT(t), SWEEP(t - start)
    expected = (lift[0] + sweep[0] - LIFT_END, lift[1] + sweep[1], lift[2] + sweep[2])
    np.testing.assert_allclose(got.position, expected[0], atol=1e-9)
    np.testing.assert_allclose(got.velocity, expected[1], atol=1e-6)
    np.testing.assert_allclose(got.acceleration, expected[2], atol=1e-3)


def test_it_starts_where_the_first_starts_and_ends_at_rest_where_the_second_ends():
    joined = chain(sampled(LIFT, 0.294), sampled(SWEEP, 1.8), 0.2)
    np.testing.assert_allclose(joined.positions[0], LIFT_START, atol=1e-12)
    np.testing.assert_allclose(joined.positions[-1], SWEEP_END, atol=1e-12)
    np.testing.assert_allclose(joined.velocities[[0, -1]], 0.0, atol=1e-12)
    assert np.all(np.diff(joined.times) > 0)


def test_before_the_overlap_it_is_the_first_motion_and_after_it_the_second():
    lead = 0.2
    first, second = sampled(LIFT, 0.294), sampled(SWEEP, 1.8)
    joined = chain(first, second, lead)
    before = np.linspace(0.0, 0.294 - lead, 40)
    np.testing.assert_allclose(joined.sample(before).position, first.sample(before).position,
                               atol=1e-12)
    after = np.linspace(0.294, joined.duration, 40)
    np.testing.assert_allclose(joined.sample(after).position,
                               second.sample(after - (0.294 - lead)).position, atol=1e-12)


def test_a_lead_out_of_range_or_motions_that_do_not_meet_are_refused():
    lift, sweep = sampled(LIFT, 0.294), sampled(SWEEP, 1.8)
    with pytest.raises(InvalidRequestError, match='lead'):
        chain(lift, sweep, -0.01)
    with pytest.raises(InvalidRequestError, match='lead'):
        chain(lift, sweep, 0.3)  # longer than the lift
    apart = SampledTrajectory(sweep.times, sweep.positions + 0.01, sweep.velocities,
                              sweep.accelerations)
    with pytest.raises(InvalidRequestError, match='starts 0.01 rad from'):
        chain(lift, apart, 0.1)
    linear = SampledTrajectory(sweep.times, sweep.positions)
    with pytest.raises(InvalidRequestError, match='velocities or accelerations'):
        chain(lift, linear, 0.1)
