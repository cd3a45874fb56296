"""When a silent stream's subscription is made anew, and when a silence is the subscription's."""

import math

import pytest

from walker_runtime.core.resubscription import Resubscription, clock_ran_past, peers_alive


def test_a_silent_stream_is_resubscribed_after_the_interval_then_every_interval():
    resubscription = Resubscription(1.0)
    assert not resubscription.due(5.0, None)  # never heard from: nothing to heal
    assert not resubscription.due(10.9, 10.0)
    assert resubscription.due(11.0, 10.0)
    assert not resubscription.due(11.5, 10.0)  # just made anew
    assert resubscription.due(12.0, 10.0)
    assert resubscription.attempts == 2
    # heard again, then silent again: the interval counts from the last message
    assert not resubscription.due(12.9, 12.2)
    assert resubscription.due(13.2, 12.2)
    assert resubscription.attempts == 3


def test_a_silence_while_the_peers_are_not_alive_is_theirs_and_counts_no_attempt():
    resubscription = Resubscription(1.0)
    assert resubscription.silent(12.0, 10.0) and not resubscription.silent(10.5, 10.0)
    assert not resubscription.silent(12.0, None)
    assert not resubscription.due(12.0, 10.0, alive=False)
    assert resubscription.attempts == 0
    # the peers back (a publisher rejoined the graph, its clock runs): due at once
    assert resubscription.due(12.1, 10.0, alive=True)
    assert resubscription.attempts == 1


@pytest.mark.parametrize('peers, evidence, alive', [
    (0, True, False),    # no publisher in the graph: gone, or never started
    (0, False, False),
    (1, True, True),     # in the graph, and nothing speaks against it
    (2, True, True),
    (1, False, False),   # in the graph, but its clock stands still: stopped, not unheard
])
def test_peers_are_alive_when_in_the_graph_and_no_evidence_speaks_against_them(peers, evidence,
                                                                                alive):
    assert peers_alive(peers, evidence) is alive


def test_peers_alive_without_other_evidence_is_the_graph_alone():
    assert peers_alive(1) and not peers_alive(0)


@pytest.mark.parametrize('after', [0.0, -1.0, math.nan, math.inf])
def test_a_resubscription_interval_must_be_positive_and_finite(after):
    with pytest.raises(ValueError, match='positive and finite'):
        Resubscription(after)


def test_a_silence_is_the_subscriptions_only_while_the_clock_runs_past_the_newest_message():
    margin = 20_000_000  # [ns]
    newest = 5_000_000_000
    assert clock_ran_past(newest + margin, newest, margin, sim_time=True)
    assert clock_ran_past(newest + margin, newest, margin, sim_time=False)
    # the clock standing still with the stream (held, or a plant stopped): the publisher's
    assert not clock_ran_past(newest + margin - 1, newest, margin, sim_time=True)
    assert not clock_ran_past(newest, newest, margin, sim_time=False)
    # nothing heard: in sim time the clock starts with the publisher, so a clock past the
    # margin means it runs unheard; on the wall clock it may not have started
    assert clock_ran_past(margin, None, margin, sim_time=True)
    assert not clock_ran_past(margin - 1, None, margin, sim_time=True)
    assert not clock_ran_past(newest, None, margin, sim_time=False)
