"""When a silent stream's subscription is made anew."""

import math

import pytest

from walker_core.resubscription import Resubscription


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


@pytest.mark.parametrize('after', [0.0, -1.0, math.nan, math.inf])
def test_a_resubscription_interval_must_be_positive_and_finite(after):
    with pytest.raises(ValueError, match='positive and finite'):
        Resubscription(after)
