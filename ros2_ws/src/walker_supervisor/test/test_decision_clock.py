"""The time the supervisor has decided up to, which the sim-time plant waits for."""

import pytest

from walker_supervisor.core.decision_clock import DecisionClock

NOW = 7_000_000_000  # [ns] ROS clock
TICK = 20_000_000  # [ns] to the next tick
WAIT = 4.0  # [s] wall


def test_with_nothing_waited_for_the_plant_may_run_to_the_next_tick():
    clock = DecisionClock(WAIT)
    assert clock.decided_until(NOW, TICK, busy=False, wall=100.0) == NOW + TICK
    assert clock.decided_until(NOW, -5, busy=False, wall=100.0) == NOW  # a tick overdue
    assert clock.decided_until(NOW, None, busy=False, wall=100.0) == NOW  # no tick: hold


def test_a_planner_request_or_awaited_plan_holds_the_clock_as_long_as_it_takes():
    clock = DecisionClock(WAIT)
    assert clock.decided_until(NOW, TICK, busy=True, wall=100.0) == NOW
    assert clock.decided_until(NOW, TICK, busy=True, wall=1e6) == NOW


def test_an_unanswered_gripper_command_holds_the_clock_until_answered():
    clock = DecisionClock(WAIT)
    clock.command_sent('unscrew b', wall=100.0)
    assert clock.decided_until(NOW, TICK, busy=False, wall=100.5) == NOW
    clock.command_answered('unscrew b')
    assert clock.decided_until(NOW, TICK, busy=False, wall=100.6) == NOW + TICK
    clock.command_answered('unscrew b')  # an answer twice, or one never noted: nothing changes
    clock.command_answered('never sent')
    assert clock.decided_until(NOW, TICK, busy=False, wall=100.7) == NOW + TICK


def test_a_gripper_command_never_answered_holds_the_clock_for_the_answer_wait_only():
    """A plant gone (or restarted) never answers: the plant must not be held for good."""
    clock = DecisionClock(WAIT)
    clock.command_sent('screw_in a', wall=100.0)
    assert clock.decided_until(NOW, TICK, busy=False, wall=100.0 + WAIT - 1e-6) == NOW
    assert clock.unanswered(100.0 + WAIT - 1e-6) == 1
    assert clock.decided_until(NOW, TICK, busy=False, wall=100.0 + WAIT) == NOW + TICK
    assert clock.unanswered(100.0 + WAIT) == 0  # given up on, and forgotten
    clock.command_answered('screw_in a')  # the late answer changes nothing
    assert clock.decided_until(NOW, TICK, busy=False, wall=200.0) == NOW + TICK


def test_the_youngest_unanswered_command_is_the_one_that_holds():
    clock = DecisionClock(WAIT)
    clock.command_sent('first', wall=100.0)
    clock.command_sent('second', wall=102.0)
    assert clock.decided_until(NOW, TICK, busy=False, wall=104.5) == NOW  # the second's wait
    assert clock.unanswered(104.5) == 1
    assert clock.decided_until(NOW, TICK, busy=False, wall=106.0) == NOW + TICK


def test_a_plan_awaited_holds_the_clock_from_when_first_awaited_for_the_answer_wait_only():
    """A plan that never comes must not freeze the simulation for good.

    The sequencer's own bound on the wait runs on the simulated clock, which the hold freezes.
    """
    clock = DecisionClock(WAIT)
    assert not clock.plan_awaited(False, wall=100.0)
    assert clock.plan_awaited(True, wall=100.0)
    assert clock.plan_awaited(True, wall=100.0 + WAIT - 1e-6)  # not restarted by each call
    assert not clock.plan_awaited(True, wall=100.0 + WAIT)
    assert not clock.plan_awaited(True, wall=200.0)  # still the same wait: given up on
    assert not clock.plan_awaited(False, wall=201.0)  # over: the next wait holds again
    assert clock.plan_awaited(True, wall=202.0)


@pytest.mark.parametrize('wait', [0.0, -1.0, float('nan')])
def test_a_wait_that_is_not_positive_is_refused(wait):
    with pytest.raises(ValueError, match='answer_wait'):
        DecisionClock(wait)
