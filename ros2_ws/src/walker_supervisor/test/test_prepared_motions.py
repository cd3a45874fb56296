"""Motions planned ahead and joined ahead (``walker_supervisor.core.prepared_motions``)."""

import dataclasses

import numpy as np
import pytest

from walker_planner.core.errors import PlanningError
from walker_supervisor.core.commands import TrajectoryRequest
from walker_supervisor.core.prepared_motions import (
    PENDING, PlanAnswer, PreparedMotions, stream_lead)


def _request(purpose, goal_z=0.0, **changes):
    point = np.array([0.5, 0.0, goal_z])
    request = TrajectoryRequest(purpose, np.zeros(5), np.ones(5), np.zeros(3), point, 0.0, 'a')
    return dataclasses.replace(request, **changes)


COARSE = _request('coarse', mode='coarse')
LIFT = _request('extraction', 0.03, then=COARSE, lead=0.2, mode='coarse')


def _answer(label, duration, success=True):
    """Return a planner's answer whose trajectory is a label."""
    return PlanAnswer(success, '' if success else 'refused', duration, 0.0, label)


class Joiner:
    """Joins two answers into a label, counting the joins; refuses with ``refuse``."""

    def __init__(self, refuse=False):
        self.calls, self.refuse = [], refuse

    def __call__(self, first, second, lead):
        self.calls.append((first, second, lead))
        if self.refuse:
            raise PlanningError('the second motion starts 0.5 rad from where the first ends')
        return f'{first.trajectory}+{second.trajectory}@{stream_lead(first, second, lead):g}'


def test_the_lead_is_within_both_motions():
    assert stream_lead(_answer('a', 1.0), _answer('b', 2.0), 0.2) == 0.2
    assert stream_lead(_answer('a', 0.1), _answer('b', 2.0), 0.2) == 0.1
    assert stream_lead(_answer('a', 1.0), _answer('b', 0.05), 0.2) == 0.05


def test_two_motions_that_stream_together_are_joined_once_both_plans_are_back():
    """Joined ahead once (not before both are in, not twice), and taken by the request."""
    joiner = Joiner()
    motions = PreparedMotions(joiner)
    motions.add(LIFT, 1)
    motions.add(COARSE, 2)
    lift, sweep = _answer('lift', 0.29), _answer('sweep', 1.8)
    assert motions.answered(1, lift) == ('extraction', lift)
    assert joiner.calls == []  # the sweep's plan is not back yet
    assert motions.answered(2, sweep) == ('coarse', sweep)
    motions.join_ahead()
    assert len(joiner.calls) == 1
    # the request (alone, as the sequencer issues it) takes both answers, then the join
    request = dataclasses.replace(LIFT, mode='coarse')
    assert motions.take(request) == (1, lift) and motions.take(request.then) == (2, sweep)
    assert motions.joined(lift, sweep, request.lead) == 'lift+sweep@0.2'
    assert len(joiner.calls) == 1  # joined ahead: nothing joined now
    # a second request for the same pair (a cancelled stream asked again) joins afresh
    assert motions.joined(lift, sweep, request.lead) == 'lift+sweep@0.2'
    assert len(joiner.calls) == 2


def test_a_join_ahead_serves_only_the_same_answers_and_lead():
    joiner = Joiner()
    motions = PreparedMotions(joiner)
    motions.add(LIFT, 1)
    motions.add(COARSE, 2)
    motions.answered(1, _answer('lift', 0.29))
    motions.answered(2, _answer('sweep', 1.8))
    assert len(joiner.calls) == 1
    other = (_answer('lift', 0.29), _answer('sweep', 1.8))  # equal, but new plans
    assert motions.joined(*other, 0.2) == 'lift+sweep@0.2'
    assert motions.joined(*joiner.calls[0][:2], 0.1) == 'lift+sweep@0.1'
    assert len(joiner.calls) == 3


@pytest.mark.parametrize('outcome', ['refused', 'failed', 'not joinable'])
def test_a_pair_that_cannot_be_joined_ahead_is_left_to_its_request(outcome):
    """A refused or failed plan is not taken (it is planned afresh).

    A pair that does not join fails when it is requested, with the reason.
    """
    joiner = Joiner(refuse=outcome == 'not joinable')
    motions = PreparedMotions(joiner)
    motions.add(LIFT, 1)
    motions.add(COARSE, 2)
    lift = _answer('lift', 0.29)
    motions.answered(1, lift)
    sweep = {'refused': _answer('', 0.0, success=False), 'failed': None,
             'not joinable': _answer('sweep', 1.8)}[outcome]
    assert motions.answered(2, sweep) == ('coarse', sweep)  # never raises
    if outcome != 'not joinable':
        assert joiner.calls == [] and motions.answer(COARSE) is None
        assert motions.take(COARSE) is None
        return
    assert len(joiner.calls) == 1
    assert motions.take(LIFT) == (1, lift) and motions.take(COARSE) == (2, sweep)
    with pytest.raises(PlanningError, match='0.5 rad'):
        motions.joined(lift, sweep, LIFT.lead)


def test_answers_are_taken_once_by_the_same_motion_and_forgotten_with_their_step():
    motions = PreparedMotions(Joiner())
    motions.add(LIFT, 1)
    assert motions.answer(LIFT) is None  # not back yet
    assert motions.take(_request('extraction', 0.04)) is None  # another motion
    assert motions.take(dataclasses.replace(LIFT, then=None, mode='fine')) == (1, PENDING)
    assert motions.take(LIFT) is None  # taken
    # its answer still tells what was asked ahead (the step's progress uses it)
    assert motions.answered(1, _answer('lift', 0.29))[0] == 'extraction'
    motions.add(LIFT, 3)
    motions.clear()
    assert motions.take(LIFT) is None
    assert motions.answered(3, _answer('lift', 0.29)) is None, 'an answer for a step gone'


def test_a_motion_asked_ahead_behind_another_is_taken_without_comparing_their_arrays():
    # two lifts of the same kind, to different heights: their requests differ only in arrays
    higher = _request('extraction', 0.04)
    motions = PreparedMotions(Joiner())
    motions.add(LIFT, 1)
    motions.add(higher, 2)
    assert motions.take(higher) == (2, PENDING)
    assert motions.take(LIFT) == (1, PENDING)
    assert motions.take(higher) is None and motions.take(LIFT) is None
