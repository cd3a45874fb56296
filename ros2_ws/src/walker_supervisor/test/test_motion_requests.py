"""The planner requests of a step's motions: plans, streams, silence (``core.motion_requests``)."""

import dataclasses

import numpy as np
import pytest

from walker_core.kinematics import WalkerKinematics
from walker_core.robot_parameters import load_walker_parameters
from walker_planner.core.errors import PlanningError
from walker_supervisor.core.commands import (
    CancelFollow, FollowMotion, Notice, PlanMotion, RenewPlannerClient, SetControlMode,
    TrajectoryRequest)
from walker_supervisor.core.motion_requests import (
    MotionEnded, MotionPlanned, MotionRequests, MotionStarted, PlannedAhead)
from walker_supervisor.core.prepared_motions import PlanAnswer

KIN = WalkerKinematics.from_parameters(load_walker_parameters())
WAIT, GIVE_UP = 4.0, 20.0  # [s] steady clock
MARGIN = 2.0  # [s] graph clock: supervisor.motion_end_margin
#: Joint angles and tip points of a motion the planner can take (a vertical lift).
JOINTS = KIN.inverse([0.0, 0.9, 0.0, 0.0, 0.0])
ABOVE = KIN.inverse([0.0, 0.9, 0.03, 0.0, 0.0])
LIFT = TrajectoryRequest('extraction', JOINTS, ABOVE, np.array([0.0, 0.9, 0.0]),
                         np.array([0.0, 0.9, 0.03]), 0.0, 'a')


def _answer(label, duration=1.0, bound=0.5, success=True):
    return PlanAnswer(success, '' if success else 'the goal is out of reach', duration, bound,
                      label)


def _join(first, second, lead):
    if second.trajectory == 'unjoinable':
        raise PlanningError('the motions do not meet')
    return f'{first.trajectory}+{second.trajectory}'


def _requests():
    return MotionRequests(KIN, _join, WAIT, GIVE_UP, MARGIN)


def _kinds(items):
    return [type(item).__name__ for item in items]


def _planned(requests, request=LIFT):
    """Ask for ``request`` and answer its plan; return the stream request."""
    (plan,) = requests.request(request)
    requests.sent(plan.ticket, 0.0)
    *_, follow = requests.planned(plan.ticket, _answer('lift'))
    return follow


def test_a_motion_is_planned_then_streamed_in_its_mode_and_its_start_and_end_reported():
    requests = _requests()
    out = requests.request(LIFT)
    assert _kinds(out) == ['PlanMotion']
    (plan,) = out
    assert plan.purpose == 'extraction' and not plan.ahead
    assert plan.call.trajectory_type == 'extraction_line' and plan.call.base_gripper == 'a'
    requests.sent(plan.ticket, 0.0)
    assert requests.awaiting_answer
    out = requests.planned(plan.ticket, _answer('lift', 1.5, 0.4))
    assert out[:2] == [MotionPlanned('extraction', 0.4), SetControlMode('fine', 'a')]
    follow = out[2]
    assert isinstance(follow, FollowMotion)
    assert (follow.trajectory, follow.duration) == ('lift', 1.5)
    requests.sent(follow.ticket, 0.1)
    out = requests.accepted(follow.ticket, True, 0.0)
    assert out[-1] == MotionStarted(1.5, None) and not requests.awaiting_answer
    assert requests.ended(follow.ticket, True, '') == [MotionEnded(True, '')]
    assert requests.ended(follow.ticket, True, '') == [], 'an end is taken once'


def test_a_motion_asked_ahead_streams_from_its_plan_and_one_streamed_with_it_joined():
    requests = _requests()
    coarse = dataclasses.replace(LIFT, purpose='coarse', mode='coarse')
    both = dataclasses.replace(LIFT, then=coarse, lead=0.2, mode='coarse')
    (lift_plan,) = requests.prepare(both)
    (sweep_plan,) = requests.prepare(coarse)
    assert lift_plan.ahead and sweep_plan.ahead
    assert requests.planned(lift_plan.ticket, _answer('lift', 1.0)) == [
        PlannedAhead('extraction', 1.0)]
    assert requests.planned(sweep_plan.ticket, _answer('sweep', 2.0)) == [
        PlannedAhead('coarse', 2.0)]
    out = requests.request(both)  # no new plan: both were asked ahead
    assert _kinds(out) == ['MotionPlanned', 'MotionPlanned', 'SetControlMode', 'FollowMotion']
    follow = out[-1]
    assert (follow.trajectory, follow.duration) == ('lift+sweep', pytest.approx(2.8))
    assert out[2] == SetControlMode('coarse', 'a')
    assert requests.accepted(follow.ticket, True, 0.0)[-1] == MotionStarted(pytest.approx(2.8),
                                                                          1.0)


def test_a_motion_waits_for_its_plan_asked_ahead_and_not_back_yet():
    requests = _requests()
    (ahead,) = requests.prepare(LIFT)
    assert requests.request(LIFT) == []  # nothing asked again: its plan is on its way
    assert not requests.check(0.0, 0.0)  # waited for from now
    out = requests.planned(ahead.ticket, _answer('lift'))
    assert _kinds(out) == ['PlannedAhead', 'MotionPlanned', 'SetControlMode', 'FollowMotion']


def test_a_refused_plan_a_refused_stream_and_a_pair_that_cannot_stream_fail_their_motion():
    requests = _requests()
    (plan,) = requests.request(LIFT)
    out = requests.planned(plan.ticket, _answer('', success=False))
    assert out[-1] == MotionEnded(False, 'planning the extraction motion failed: the goal is '
                                         'out of reach')
    assert isinstance(out[0], Notice) and out[0].level == 'error'
    follow = _planned(requests)
    assert requests.accepted(follow.ticket, False, 0.0) == [
        MotionEnded(False, 'the planner refused to stream the trajectory')]
    coarse = dataclasses.replace(LIFT, purpose='coarse')
    plans = requests.request(dataclasses.replace(LIFT, then=coarse, lead=0.2))
    requests.planned(plans[0].ticket, _answer('lift'))
    out = requests.planned(plans[1].ticket, _answer('unjoinable'))
    assert out[-1] == MotionEnded(False, 'planning the extraction motion failed: it cannot '
                                         'stream with the coarse motion: the motions do not meet')


def test_an_unanswered_plan_is_asked_again_every_wait_then_given_up():
    requests = _requests()
    (plan,) = requests.request(LIFT)
    requests.sent(plan.ticket, 100.0)
    assert requests.check(100.0 + WAIT - 0.01, 0.0) == []
    tickets = [plan.ticket]
    now = 100.0 + WAIT
    while True:
        out = requests.check(now, 0.0)
        if _kinds(out) != ['Notice', 'RenewPlannerClient', 'PlanMotion']:
            break
        assert out[1] == RenewPlannerClient('plan_trajectory')
        tickets.append(out[2].ticket)
        requests.sent(out[2].ticket, now)
        now += WAIT
    assert now == 100.0 + GIVE_UP and len(tickets) == GIVE_UP / WAIT
    assert out[-1] == MotionEnded(False, 'the planner answered no plan_trajectory request in '
                                         '20 s, asked again every 4 s over a new connection')
    # answers to the requests given up on, or sent before, change nothing
    assert all(requests.planned(t, _answer('lift')) == [] for t in tickets)


def test_a_late_answer_to_a_request_sent_again_is_ignored_and_a_late_stream_cancelled():
    requests = _requests()
    (plan,) = requests.request(LIFT)
    requests.sent(plan.ticket, 0.0)
    *_, again = requests.check(WAIT, 0.0)
    assert requests.planned(plan.ticket, _answer('first')) == []
    requests.sent(again.ticket, WAIT)
    follow = requests.planned(again.ticket, _answer('second'))[-1]
    assert follow.trajectory == 'second'
    requests.sent(follow.ticket, WAIT)
    renew, follow_again = requests.check(2 * WAIT, 0.0)[1:]
    assert renew == RenewPlannerClient('follow_trajectory')
    assert follow_again.trajectory == 'second' and follow_again.ticket != follow.ticket
    assert requests.accepted(follow.ticket, True, 0.0) == [CancelFollow(follow.ticket)]
    assert requests.accepted(follow_again.ticket, True, 0.0)[-1] == MotionStarted(1.0, None)


def test_a_request_whose_server_is_not_found_fails_its_motion_naming_the_service():
    requests = _requests()
    (plan,) = requests.request(LIFT)
    assert requests.failed(plan.ticket) == [MotionEnded(False, 'the planner is not available')]
    (plan,) = requests.request(LIFT)
    requests.sent(plan.ticket, 0.0)
    *_, again = requests.check(WAIT, 0.0)
    assert requests.failed(again.ticket) == [
        MotionEnded(False, 'the planner plan_trajectory is not available')]
    (ahead,) = requests.prepare(LIFT)
    assert requests.failed(ahead.ticket) == [PlannedAhead('extraction', None)]


def test_a_cancel_stops_the_stream_and_drops_every_answer_to_come():
    requests = _requests()
    descent = dataclasses.replace(LIFT, purpose='insertion', start=ABOVE, goal=JOINTS)
    (ahead,) = requests.prepare(descent)
    follow = _planned(requests)
    requests.accepted(follow.ticket, True, 0.0)
    assert requests.cancel() == [CancelFollow(follow.ticket)]
    assert requests.ended(follow.ticket, False, 'cancelled') == []
    assert requests.planned(ahead.ticket, _answer('descent')) == []
    assert requests.cancel() == []
    assert isinstance(requests.request(descent)[0], PlanMotion), 'the plan asked ahead is gone'


def test_a_motion_whose_end_is_never_reported_fails_as_unreported_after_its_margin():
    """The planner died mid-motion: its end is waited for ``end_margin`` past the plan, no more."""
    requests = _requests()
    follow = _planned(requests)  # a motion of 1.0 s
    requests.accepted(follow.ticket, True, 10.0)
    end = 10.0 + 1.0
    assert requests.check(end + 0.01, end + 0.01) == []  # past its end: waited for from now
    assert requests.check(end + MARGIN, end + MARGIN) == []
    notice, cancel, ended = requests.check(end + MARGIN + 0.02, end + MARGIN + 0.02)
    assert notice.level == 'error' and cancel == CancelFollow(follow.ticket)
    assert ended == MotionEnded(False, notice.message, unreported=True)
    assert 'the planner did not report the end of the extraction motion (1.00 s planned) ' \
        f'within {MARGIN:g} s of its planned end' in ended.message
    assert requests.check(end + 10.0, end + 10.0) == [], 'a motion fails once'
    assert requests.ended(follow.ticket, True, '') == [], 'its end, come at last, is stale'
    assert requests.cancel() == [], 'nothing left to cancel'


@pytest.mark.parametrize('clock', ['graph', 'steady'])
def test_the_margin_must_pass_on_both_clocks(clock):
    """A held simulation, or one that outruns a slow planner, fails no motion by itself."""
    requests = _requests()
    follow = _planned(requests)
    requests.accepted(follow.ticket, True, 0.0)
    requests.check(1.01, 1.01)  # past the planned end on both
    for later in (MARGIN, 10 * MARGIN, 100 * MARGIN):
        steady, now = (1.01 + later, 1.01) if clock == 'steady' else (1.01, 1.01 + later)
        assert requests.check(steady, now) == [], f'only the {clock} clock ran'
    assert requests.check(1.02 + MARGIN, 1.02 + MARGIN)[-1].unreported


def test_a_motion_end_reported_within_the_margin_is_its_end():
    requests = _requests()
    follow = _planned(requests)
    requests.accepted(follow.ticket, True, 10.0)
    for t in (11.0, 11.0 + MARGIN - 0.01):
        assert requests.check(t, t) == []
    assert requests.ended(follow.ticket, True, '') == [MotionEnded(True, '')]
    assert requests.check(100.0, 100.0) == []


def test_a_changed_margin_applies_to_the_motions_accepted_after_it_and_a_bad_one_is_refused():
    requests = _requests()
    for bad in (0.0, -1.0, float('nan'), float('inf')):
        with pytest.raises(ValueError, match='end_margin'):
            requests.end_margin = bad
        assert requests.end_margin == MARGIN, 'a refused margin changes nothing'
    with pytest.raises(ValueError, match='end_margin'):
        MotionRequests(KIN, _join, WAIT, GIVE_UP, 0.0)
    requests.end_margin = 5.0
    follow = _planned(requests)
    requests.accepted(follow.ticket, True, 0.0)
    assert requests.check(1.01, 1.01) == []
    assert requests.check(1.01 + 5.0, 1.01 + 5.0) == []
    assert requests.check(1.02 + 5.0, 1.02 + 5.0)[-1].unreported


def test_bad_waits_are_refused():
    with pytest.raises(ValueError):
        MotionRequests(KIN, _join, 0.0, GIVE_UP, MARGIN)
    with pytest.raises(ValueError):
        MotionRequests(KIN, _join, WAIT, WAIT / 2, MARGIN)
