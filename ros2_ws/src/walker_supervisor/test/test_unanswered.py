"""A planner request unanswered is sent again, then, bounded, given up."""

import pytest

from walker_supervisor.core.unanswered import ASK_AGAIN, GIVE_UP, WAIT, UnansweredRequest


def test_a_request_is_waited_for_then_asked_again_then_given_up():
    request = UnansweredRequest(first_sent=100.0, last_sent=100.0, ask_again_after=4.0,
                                give_up_after=20.0)
    assert request.action(103.9) == WAIT
    assert request.action(104.0) == ASK_AGAIN
    times_sent = 1
    now = 104.0
    while request.action(now) == ASK_AGAIN:
        request = request.sent_again(now)
        times_sent += 1
        assert request.action(now + 3.9) == WAIT  # each sending gets its own wait
        now += 4.0
    assert request.action(now) == GIVE_UP
    assert now == 120.0 and times_sent == 5  # first sent, then again at 104, 108, 112, 116
    assert request.first_sent == 100.0  # counted from the first sending throughout


def test_a_request_late_to_be_asked_again_is_given_up_once_past_the_bound():
    request = UnansweredRequest(100.0, 100.0, 4.0, 20.0)
    assert request.action(130.0) == GIVE_UP  # a starved node comes back long after


@pytest.mark.parametrize('first, last, wait, give_up', [
    (100.0, 99.0, 4.0, 20.0), (100.0, 100.0, 0.0, 20.0), (100.0, 100.0, 5.0, 4.0)])
def test_bad_timings_are_refused(first, last, wait, give_up):
    with pytest.raises(ValueError):
        UnansweredRequest(first, last, wait, give_up)
