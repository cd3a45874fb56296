"""A sim-time decision waits for the joint state of its own time, and never for a silent source."""

import pytest

from walker_supervisor.core.current_state import STATE_WAIT, CurrentState

MS = 1_000_000  # [ns]


def test_a_decision_waits_only_for_a_state_older_than_its_time():
    current = CurrentState()
    assert current.awaits(newest=98 * MS, now=100 * MS)  # the plant's previous state
    assert not current.awaits(newest=100 * MS, now=100 * MS)  # the state of its time
    assert not current.awaits(newest=110 * MS, now=100 * MS)  # the plant ran ahead
    assert not current.awaits(newest=None, now=100 * MS)  # nothing heard yet: nothing to wait


def test_after_a_wait_that_ran_out_none_waits_again_until_a_state_comes_on_time():
    current = CurrentState()
    assert current.awaits(98 * MS, 100 * MS)
    current.waited(98 * MS, 100 * MS)  # the plant froze: no newer state within the bound
    assert (current.waits, current.timeouts) == (1, 1)
    assert not current.awaits(98 * MS, 120 * MS)  # a silent source does not slow every tick
    assert not current.awaits(98 * MS, 140 * MS)
    assert not current.awaits(160 * MS, 160 * MS)  # states come on time again
    assert current.awaits(178 * MS, 180 * MS)  # and a late one is waited for again


def test_a_wait_that_brought_the_state_is_counted_and_waiting_goes_on():
    current = CurrentState()
    current.waited(100 * MS, 100 * MS)
    assert (current.waits, current.timeouts) == (1, 0)
    assert current.awaits(118 * MS, 120 * MS)


@pytest.mark.parametrize('wait', [0.0, -1.0, float('nan')])
def test_a_wait_bound_that_is_not_positive_is_refused(wait):
    with pytest.raises(ValueError, match='wait must be > 0 s'):
        CurrentState(wait)
    assert CurrentState().wait == STATE_WAIT
