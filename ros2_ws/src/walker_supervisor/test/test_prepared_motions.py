"""Motions planned ahead and joined ahead (``walker_supervisor.prepared_motions``)."""

import dataclasses

import numpy as np
import pytest

from walker_planner.core.errors import PlanningError
from walker_supervisor.core.sequencer import TrajectoryRequest
from walker_supervisor.prepared_motions import PreparedMotions, plan_answer, stream_lead


@dataclasses.dataclass
class Answer:
    """A ``plan_trajectory`` response: its trajectory is a label here."""

    trajectory: str
    duration: float
    success: bool = True


class Pending:
    """A future answered later (``answer``), or failed (``fail``)."""

    def __init__(self):
        self._result, self._error, self._done = None, None, False

    def answer(self, result):
        self._result, self._done = result, True
        return self

    def fail(self):
        self._error, self._done = RuntimeError('the call failed'), True
        return self

    def done(self):
        return self._done

    def result(self):
        if self._error is not None:
            raise self._error
        return self._result


def _request(purpose, goal_z=0.0, **changes):
    point = np.array([0.5, 0.0, goal_z])
    request = TrajectoryRequest(purpose, np.zeros(5), np.ones(5), np.zeros(3), point, 0.0, 'a')
    return dataclasses.replace(request, **changes)


COARSE = _request('coarse', mode='coarse')
LIFT = _request('extraction', 0.03, then=COARSE, lead=0.2, mode='coarse')


class Joiner:
    """Joins two answers into a label, counting the joins; refuses with ``refuse``."""

    def __init__(self, refuse=False):
        self.calls, self.refuse = [], refuse

    def __call__(self, first, second, lead):
        self.calls.append((first, second, lead))
        if self.refuse:
            raise PlanningError('the second motion starts 0.5 rad from where the first ends')
        return f'{first.trajectory}+{second.trajectory}@{stream_lead(first, second, lead):g}'


def test_a_failed_call_answers_nothing():
    assert plan_answer(Pending().fail()) is None
    answer = Answer('lift', 0.29)
    assert plan_answer(Pending().answer(answer)) is answer


def test_the_lead_is_within_both_motions():
    assert stream_lead(Answer('a', 1.0), Answer('b', 2.0), 0.2) == 0.2
    assert stream_lead(Answer('a', 0.1), Answer('b', 2.0), 0.2) == 0.1
    assert stream_lead(Answer('a', 1.0), Answer('b', 0.05), 0.2) == 0.05


def test_two_motions_that_stream_together_are_joined_once_both_plans_are_back():
    """Joined ahead once (not before both are in, not twice), and taken by the request."""
    joiner = Joiner()
    motions = PreparedMotions(joiner)
    lift, sweep = Pending(), Pending()
    motions.add(LIFT, lift)
    motions.add(COARSE, sweep)
    lift.answer(Answer('lift', 0.29))
    motions.join_ahead()
    assert joiner.calls == []  # the sweep's plan is not back yet
    sweep.answer(Answer('sweep', 1.8))
    motions.join_ahead()
    motions.join_ahead()
    assert len(joiner.calls) == 1
    # the request (alone, as the sequencer issues it) takes both answers, then the join
    request = dataclasses.replace(LIFT, mode='coarse')
    first, second = motions.take(request), motions.take(request.then)
    assert first is lift and second is sweep
    assert motions.joined(first.result(), second.result(), request.lead) == 'lift+sweep@0.2'
    assert len(joiner.calls) == 1  # joined ahead: nothing joined now
    # a second request for the same pair (a cancelled stream asked again) joins afresh
    assert motions.joined(first.result(), second.result(), request.lead) == 'lift+sweep@0.2'
    assert len(joiner.calls) == 2


def test_a_join_ahead_serves_only_the_same_answers_and_lead():
    joiner = Joiner()
    motions = PreparedMotions(joiner)
    motions.add(LIFT, Pending().answer(Answer('lift', 0.29)))
    motions.add(COARSE, Pending().answer(Answer('sweep', 1.8)))
    motions.join_ahead()
    assert len(joiner.calls) == 1
    other = (Answer('lift', 0.29), Answer('sweep', 1.8))  # equal, but new plans
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
    sweep = Pending()
    if outcome == 'refused':
        sweep.answer(Answer('', 0.0, success=False))
    elif outcome == 'failed':
        sweep.fail()
    else:
        sweep.answer(Answer('sweep', 1.8))
    motions.add(LIFT, Pending().answer(Answer('lift', 0.29)))
    motions.add(COARSE, sweep)
    motions.join_ahead()  # never raises
    if outcome != 'not joinable':
        assert joiner.calls == [] and motions.answer(COARSE) is None
        assert motions.take(COARSE) is None
        return
    assert len(joiner.calls) == 1
    first, second = motions.take(LIFT).result(), motions.take(COARSE).result()
    with pytest.raises(PlanningError, match='0.5 rad'):
        motions.joined(first, second, LIFT.lead)


def test_answers_are_taken_once_by_the_same_motion_and_forgotten_with_their_step():
    motions = PreparedMotions(Joiner())
    lift, later = Pending(), Pending()
    motions.add(LIFT, lift)
    assert motions.answer(LIFT) is None  # not back yet
    assert motions.take(_request('extraction', 0.04)) is None  # another motion
    assert motions.take(dataclasses.replace(LIFT, then=None, mode='fine')) is lift
    assert motions.take(LIFT) is None  # taken
    batch = motions.batch
    motions.add(LIFT, later)
    motions.clear()
    assert motions.batch == batch + 1 and motions.take(LIFT) is None
