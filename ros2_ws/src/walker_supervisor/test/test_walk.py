"""Walk progression and the residual-vibration meter."""

import math

import numpy as np
import pytest

from walker_supervisor.core.route import PlannedStep, Stance
from walker_supervisor.core.phases import StepOutcome
from walker_supervisor.core.walk import VibrationMeter, Walk

ROUTE = [PlannedStep('a', 'n1_1', 'n2_1', 'n0_1', math.pi),
         PlannedStep('b', 'n0_1', 'n1_1', 'n0_2', -math.pi / 2)]


def outcome(success=True):
    return StepOutcome(success, '' if success else 'jammed', {}, 5.0, 0.0, 1)


def test_a_walk_takes_its_steps_in_order():
    walk = Walk('n0_2', list(ROUTE))
    start = Stance('a', 'n1_1', 'n2_1')
    assert walk.next_step() is ROUTE[0] and walk.stance(start) == start
    walk.outcomes.append(outcome())
    assert walk.next_step() is ROUTE[1]
    assert walk.stance(start) == Stance('b', 'n0_1', 'n1_1')
    walk.outcomes.append(outcome())
    assert walk.finished and walk.reached and walk.path == ['n0_1', 'n0_2']
    with pytest.raises(IndexError):
        walk.next_step()


def test_a_failed_or_cancelled_walk_is_finished_but_not_reached():
    failed = Walk('n0_2', list(ROUTE), [outcome(False)])
    assert failed.finished and failed.failed and not failed.reached
    cancelled = Walk('n0_2', list(ROUTE), [outcome()], cancel_requested=True)
    assert cancelled.finished and not cancelled.reached and cancelled.path == ['n0_1']


def test_a_walk_under_way_is_to_be_cancelled_and_one_ending_waited_for():
    walk = Walk('n0_2', list(ROUTE), [outcome()])
    assert walk.refusal(step_running=False) == 'a walk to n0_2 is running: cancel it first'
    walk.cancel_requested = True  # the step under way finishes first
    assert 'cancel it first' in walk.refusal(step_running=True)
    walk.outcomes.append(outcome())  # the last step screwed in, the joints still relax
    assert walk.refusal(step_running=False).startswith('the walk to n0_2 is ending')
    assert 'again in a moment' in walk.refusal(step_running=False)


def test_vibration_amplitude_of_a_sine_over_the_window():
    meter = VibrationMeter(window=0.5)
    for k in range(1000):  # 2 s at 500 Hz: a 1 mm vibration about a fixed point
        t = k / 500
        meter.add(t, np.array([1.0 + 0.001 * math.sin(2 * math.pi * 10 * t), 2.0, 0.0]))
    assert meter.amplitude() == pytest.approx(0.001, rel=0.02)
    np.testing.assert_allclose(meter.mean(), [1.0, 2.0, 0.0], atol=1e-4)
    last = 999 / 500
    np.testing.assert_allclose(
        meter.latest(), [1.0 + 0.001 * math.sin(2 * math.pi * 10 * last), 2.0, 0.0])
    meter.clear()
    assert math.isnan(meter.amplitude()) and np.all(np.isnan(meter.latest()))
    with pytest.raises(ValueError):
        VibrationMeter(0.0)
