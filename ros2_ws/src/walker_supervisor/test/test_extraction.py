"""EXTRACTION: the unscrew, the stance measured after the relaxation, the lift and its sweep.

Each test drives the sequencer through a step in ``sequencer_world``'s ideal world.
"""

import dataclasses
import math

import numpy as np
import pytest

from sequencer_world import (
    DT, KIN, PARAMS, START, SUPERVISOR, TRUSS, World, following_step, hold_during,
    leading_world, remeasuring, resume_step, run_to_the_end, start_next_step)
from walker_supervisor.core.commands import (
    CancelTrajectory, GripperRequest, Notice, PrepareTrajectory, SetControlMode,
    TrajectoryRequest)
from walker_supervisor.core.phases import Phase
from walker_supervisor.core.route import possible_steps
from walker_supervisor.core.sequencer import STANCE_MARGIN, StepSequencer
from walker_supervisor.core.step_geometry import plan_step_targets


def test_the_unscrew_waits_for_the_base_and_never_releases_it():
    world = World()
    world.run_step(possible_steps(TRUSS, world.stance)[1])
    releases = [c for c in world.log if isinstance(c, GripperRequest) and c.action == 'unscrew']
    assert releases == [GripperRequest('b', 'unscrew')]


def test_a_refused_unscrew_aborts_before_anything_moves():
    world = World(refuse_unscrew=True)
    start = world.theta.copy()
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert not outcome.success and 'interlock' in outcome.message
    assert not any(isinstance(c, TrajectoryRequest) for c in world.log)
    np.testing.assert_array_equal(world.theta, start)


def _lift_start(world):
    """[s] When the lift was requested (it streams at once in the World)."""
    return next(t for t, request in world.requested if request.purpose == 'extraction')


def test_with_a_sweep_lead_the_sweep_streams_with_the_lift_and_the_step_is_that_much_shorter():
    """The coarse motion starts ``sweep_lead`` before the lift ends, in one stream with it.

    EXTRACTION lasts as long as the lift, COARSE (and its controller mode) begins at the
    first tick after it, no second request is made for the coarse motion, and the step ends
    ``sweep_lead`` sooner than with the motions one after the other.
    """
    lead = 0.3
    step = possible_steps(TRUSS, START)[0]
    world = leading_world(lead)
    outcome = world.run_step(step)
    assert outcome.success, outcome.message
    requests = [c for c in world.log if isinstance(c, TrajectoryRequest)]
    joined = [c for c in requests if c.then is not None]
    assert len(joined) == 1 and joined[0].purpose == 'extraction'
    assert joined[0].then.purpose == 'coarse' and joined[0].lead == lead
    assert joined[0].mode == 'coarse'  # commanded as the stream begins: Ka as the sweep does
    assert 'coarse' not in [c.purpose for c in requests]
    # both were asked for ahead as they stream, so both plans are taken and can be joined
    # ahead: the lift is not planned again as its gripper comes free
    prepared = [c.request for c in world.log if isinstance(c, PrepareTrajectory)]
    assert [r.purpose for r in prepared] == ['extraction', 'coarse', 'insertion']
    assert prepared[0].then.same_motion(prepared[1]) and prepared[0].lead == lead
    assert joined[0].same_motion(prepared[0]) and joined[0].then.same_motion(prepared[1])
    # the sweep moved while the phase was still EXTRACTION; COARSE from the lift's end
    assert any(phase == Phase.EXTRACTION and sweep > 0 for _, phase, _, sweep in world.joined)
    assert all(lift == 1.0 for _, phase, lift, _ in world.joined if phase == Phase.COARSE)
    lift_end = min(t for t, _, lift, _ in world.joined if lift == 1.0)
    coarse_start = min(t for t, phase, _, _ in world.joined if phase == Phase.COARSE)
    assert lift_end <= coarse_start <= lift_end + DT + 1e-9
    modes = [c.mode for c in world.log if isinstance(c, SetControlMode)]
    assert modes[:2] == ['hold', 'fine']  # FINE as the tip enters the region: no other
    order = [p for i, p in enumerate(world.phases) if i == 0 or world.phases[i - 1] != p]
    assert order[:4] == [Phase.EXTRACTION, Phase.COARSE, Phase.FINE, Phase.INSERTION]
    after = World()
    separate = after.run_step(step)
    assert separate.success, separate.message
    assert outcome.duration == pytest.approx(separate.duration - lead, abs=2 * DT + 1e-9)
    assert outcome.insertion_error <= SUPERVISOR.insertion_alignment


def test_a_motion_asked_ahead_serves_its_request_whatever_mode_and_company_it_streams_in():
    """The plan depends on the motion alone, not on the controller mode or what streams with it.

    A lift asked ahead serves the lift streamed alone (the sweep's plan refused) as well as
    the lift streamed with the sweep; another motion it does not serve.
    """
    step = possible_steps(TRUSS, START)[0]
    world = leading_world(0.3, coarse_plan_delay=math.inf)
    assert world.run_step(step).success
    prepared = next(c.request for c in world.log if isinstance(c, PrepareTrajectory))
    lift = next(c for c in world.log if isinstance(c, TrajectoryRequest))
    assert prepared.then is not None and prepared.mode == 'coarse'
    assert lift.purpose == 'extraction' and lift.then is None and lift.mode == 'fine'
    assert lift.same_motion(prepared) and prepared.same_motion(lift)
    lower = dataclasses.replace(lift, goal_point=lift.goal_point - [0.0, 0.0, 1e-3])
    assert not lower.same_motion(prepared)
    assert not dataclasses.replace(lift, purpose='retry_lift').same_motion(prepared)
    without = World()
    assert without.run_step(step).success
    alone = next(c.request for c in without.log if isinstance(c, PrepareTrajectory))
    assert alone.then is None  # no sweep_lead: the lift is asked for alone


def test_a_freed_gripper_waits_for_a_late_sweep_plan_and_streams_the_two_together():
    """A plan back within ``sweep_lead`` of the gripper coming free is waited for.

    The lift starts when the plan is in (``awaiting_plan`` until then, which holds the sim
    clock in the node), joined with the sweep: the step is longer than with the plan in time
    by that wait only.
    """
    lead, delay = 0.3, 0.15
    step = possible_steps(TRUSS, START)[0]
    on_time = leading_world(lead, gripper_delay=0.1)
    assert on_time.run_step(step).success
    world = leading_world(lead, gripper_delay=0.1, coarse_plan_delay=delay)
    waiting = []
    tick = world.sequencer.tick

    def recording_tick(now, *args):
        commands = tick(now, *args)
        waiting.append((now, world.sequencer.awaiting_plan))
        return commands
    world.sequencer.tick = recording_tick
    outcome = world.run_step(step)
    assert outcome.success, outcome.message
    requests = [c for c in world.log if isinstance(c, TrajectoryRequest)]
    assert requests[0].then is not None and requests[0].then.purpose == 'coarse'
    assert 'coarse' not in [c.purpose for c in requests]
    # planned at 0.15 s, the gripper free at 0.1 s: the lift waited from then until the plan
    assert _lift_start(world) == pytest.approx(delay, abs=DT + 1e-9)
    assert _lift_start(on_time) == pytest.approx(0.1, abs=DT + 1e-9)
    assert [t for t, w in waiting if w] and all(0.1 - 1e-9 <= t < delay + 1e-9
                                                for t, w in waiting if w)
    assert outcome.duration == pytest.approx(on_time.sequencer.outcome.duration + delay - 0.1,
                                             abs=2 * DT + 1e-9)


@pytest.mark.parametrize('answer', ['planned', 'not planned'])
def test_the_wait_for_the_sweeps_plan_ends_with_its_answer_before_any_tick(answer):
    """``awaiting_plan`` turns False as the answer comes, before any tick.

    It holds the sim-time clock in the node: on a held clock no tick would come to end it.
    """
    world = leading_world(0.3, gripper_delay=0.1, coarse_plan_delay=10.0)
    step = possible_steps(TRUSS, START)[0]
    world.targets = plan_step_targets(KIN, world.frame, step, TRUSS.position(step.from_node),
                                      TRUSS.position(step.to_node), world.theta,
                                      PARAMS.gripper.approach_height)
    world.execute(world.sequencer.start(step, world.targets, world.now, dict(world.grippers)))
    while not world.sequencer.awaiting_plan:
        assert world.now < 1.0, 'the freed gripper never waited for the plan'
        world.advance()
    assert world.sequencer.stage == 'unscrewing'
    if answer == 'planned':
        world.sequencer.motion_planned('coarse', 1.0)
    else:
        world.sequencer.motion_not_planned('coarse')
    assert not world.sequencer.awaiting_plan
    world.advance()  # the next tick lifts
    assert world.sequencer.stage == 'lifting'
    lift = world.requested[-1][1]
    assert lift.purpose == 'extraction' and (lift.then is not None) == (answer == 'planned')


@pytest.mark.parametrize('delay', [0.5, math.inf])  # later than the lead; refused
def test_without_the_sweeps_plan_in_time_the_lift_streams_alone_and_the_sweep_follows_it(delay):
    """The lift waits for a late plan at most ``sweep_lead``; for a refused one, not at all."""
    lead = 0.3
    world = leading_world(lead, gripper_delay=0.1, coarse_plan_delay=delay)
    outcome = world.run_step(possible_steps(TRUSS, START)[0])
    assert outcome.success, outcome.message
    requests = [c for c in world.log if isinstance(c, TrajectoryRequest)]
    assert all(c.then is None for c in requests)
    assert [c.purpose for c in requests][:2] == ['extraction', 'coarse']
    waited = lead if delay < math.inf else 0.0
    assert _lift_start(world) == pytest.approx(0.1 + waited, abs=DT + 1e-9)


def test_a_sweep_lead_longer_than_the_whole_stream_still_ends_in_coarse():
    """A joined stream that ends before a tick has seen the lift end goes on in COARSE.

    No second request for the coarse motion: it has streamed already.
    """
    world = leading_world(1.0)  # the World's lift takes 1 s: they start together
    outcome = world.run_step(possible_steps(TRUSS, START)[0])
    assert outcome.success, outcome.message
    purposes = [c.purpose for c in world.log if isinstance(c, TrajectoryRequest)]
    assert purposes[0] == 'extraction' and 'coarse' not in purposes
    order = [p for i, p in enumerate(world.phases) if i == 0 or world.phases[i - 1] != p]
    assert order[:4] == [Phase.EXTRACTION, Phase.COARSE, Phase.FINE, Phase.INSERTION]


@pytest.mark.parametrize('ticks', [30, 80])  # the lift only; the lift and the sweep
def test_a_hold_while_the_sweep_streams_with_the_lift_is_resumed_to_the_step_end(ticks):
    world = leading_world(0.5)
    step = hold_during(world, Phase.EXTRACTION, ticks=ticks)
    assert world.grippers[step.moving_gripper] == 'free'
    assert [c for c in world.log if isinstance(c, CancelTrajectory)]
    resume_step(world)
    run_to_the_end(world)
    assert world.grippers == {'a': 'attached', 'b': 'attached'}


def test_the_coarse_motion_waits_for_a_joint_that_lags_the_extraction_line():
    # Joint J4 is 0.1 rad short when the extraction stream ends (late efforts, friction): a
    # coarse motion planned from the line's end would start that far from it (the planner
    # refuses that); the step waits in EXTRACTION until the joint is there.
    world = World(lift_lag=(3, 0.1, 0.5))
    step = possible_steps(TRUSS, world.stance)[0]
    targets = plan_step_targets(KIN, world.frame, step, TRUSS.position(step.from_node),
                                TRUSS.position(step.to_node), world.theta,
                                PARAMS.gripper.approach_height)
    world.execute(world.sequencer.start(step, targets, world.now, dict(world.grippers)))
    coarse_start = None
    while world.sequencer.busy and world.now < 60.0:
        world.advance()
        request = world.log[-1]
        if coarse_start is None and isinstance(request, TrajectoryRequest) \
                and request.purpose == 'coarse':
            coarse_start = world.now
            gap = np.max(np.abs(world.theta - targets.above_from))
            assert gap <= SUPERVISOR.coarse_start_tolerance
    assert world.sequencer.outcome.success, world.sequencer.outcome.message
    lifted = next(i for i, p in enumerate(world.phases) if p == Phase.COARSE)
    # the joint caught up 0.5 s after the line ended: EXTRACTION lasted that much longer
    assert world.sequencer.outcome.phase_durations['extraction'] > 1.0 + 0.45
    assert coarse_start is not None and lifted > 0


def test_a_joint_that_never_reaches_the_coarse_start_ends_the_step_in_safe_hold():
    world = World(lift_lag=(3, 0.1, 1e9))
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert not outcome.success and 'extraction overran' in outcome.message
    assert world.sequencer.phase == Phase.SAFE_HOLD
    assert world.grippers[world.stance.base_gripper] == 'attached'


def test_the_next_step_measures_its_stance_after_the_relaxation_while_still_attached():
    """A step started during the relaxation takes its targets from the relaxed joints."""
    world = World(gripper_delay=0.5)  # the plant's screw_time
    assert world.run_step(possible_steps(TRUSS, world.stance)[0]).success
    relaxed_at = world.sequencer.relaxed_at
    step, calls = following_step(world), []
    first = len(world.log)
    commands = start_next_step(world, step, remeasuring(world, step, calls))
    assert commands[0] == SetControlMode('hold', step.base_gripper)  # the relaxation runs on
    assert not any(isinstance(c, PrepareTrajectory) for c in commands)  # targets not final
    relaxed = world.theta.copy()
    relaxed[1] += 1e-3  # the dither lets the joints slide out of the bend
    while world.now < relaxed_at - DT / 2:
        world.advance()
    world.theta = relaxed
    while world.sequencer.phase == Phase.EXTRACTION and world.sequencer.stage == 'unscrewing':
        world.advance()
    assert len(calls) == 1
    when, state, theta = calls[0]
    assert when >= relaxed_at - 1e-9 and state == 'unscrewing'
    np.testing.assert_array_equal(theta, relaxed)
    np.testing.assert_array_equal(world.sequencer.targets.start, relaxed)
    prepared = [c.request for c in world.log[first:] if isinstance(c, PrepareTrajectory)]
    assert [r.purpose for r in prepared] == ['extraction', 'coarse']
    while world.sequencer.busy:
        world.advance()
    assert world.sequencer.outcome.success, world.sequencer.outcome.message
    requested = [c for c in world.log[first:] if isinstance(c, TrajectoryRequest)]
    extraction, coarse = (next(r for r in reversed(requested) if r.purpose == purpose)
                          for purpose in ('extraction', 'coarse'))
    assert extraction.same_motion(prepared[0]) and coarse.same_motion(prepared[1])
    np.testing.assert_array_equal(extraction.start, relaxed)


def test_a_step_started_after_the_relaxation_prepares_its_motions_at_once():
    world = World(gripper_delay=0.5)
    step, calls = possible_steps(TRUSS, world.stance)[0], []
    commands = start_next_step(world, step, remeasuring(world, step, calls))
    prepared = [c.request for c in commands if isinstance(c, PrepareTrajectory)]
    assert [r.purpose for r in prepared] == ['extraction', 'coarse']
    while world.sequencer.busy:
        world.advance()
    assert calls == []  # nothing to wait for: the stance at the start is relaxed
    requested = [c for c in world.log if isinstance(c, TrajectoryRequest)]
    assert requested[0].same_motion(prepared[0]) and requested[1].same_motion(prepared[1])
    assert not requested[2].same_motion(prepared[1])  # the insertion is planned when due


def test_a_stance_that_gives_no_targets_after_the_relaxation_keeps_the_first_ones():
    world = World(gripper_delay=0.5)
    assert world.run_step(possible_steps(TRUSS, world.stance)[0]).success
    step, calls = following_step(world), []
    start_next_step(world, step, remeasuring(world, step, calls, fail=True))
    first = world.sequencer.targets
    while world.sequencer.stage == 'unscrewing':
        world.advance()
    assert len(calls) == 1 and world.sequencer.targets is first
    notices = [c.message for c in world.log if isinstance(c, Notice)]
    assert len(notices) == 1 and 'joint 3 beyond its limit' in notices[0]
    assert [c.request.purpose for c in world.log if isinstance(c, PrepareTrajectory)][-2:] \
        == ['extraction', 'coarse']
    while world.sequencer.busy:
        world.advance()
    assert world.sequencer.outcome.success


def test_a_step_may_start_only_when_its_unscrewing_outlasts_the_relaxation():
    slow = dataclasses.replace(SUPERVISOR, relaxation_wait=1.0)
    world = World()
    world.sequencer = StepSequencer(slow, KIN, world.stance.base_gripper, screw_time=0.5)
    assert world.run_step(possible_steps(TRUSS, world.stance)[0]).success
    relaxed_at = world.sequencer.relaxed_at
    earliest = relaxed_at - (0.5 - STANCE_MARGIN)
    assert not world.sequencer.can_start(earliest - 1e-6)
    assert world.sequencer.can_start(earliest)


def test_without_a_relaxation_wait_a_next_step_starts_at_once_and_measures_nothing_again():
    world = World(gripper_delay=0.5)
    world.sequencer = StepSequencer(dataclasses.replace(SUPERVISOR, relaxation_wait=0.0), KIN,
                                    world.stance.base_gripper)
    assert world.run_step(possible_steps(TRUSS, world.stance)[0]).success
    assert world.sequencer.can_start(world.now)
    step, calls = following_step(world), []
    commands = start_next_step(world, step, remeasuring(world, step, calls))
    assert any(isinstance(c, PrepareTrajectory) for c in commands)
    while world.sequencer.busy:
        world.advance()
    assert calls == [] and world.sequencer.outcome.success
