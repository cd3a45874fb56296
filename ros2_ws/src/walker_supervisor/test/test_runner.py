"""The walk runner in a headless world (``runner_world``).

Walks, their steps' figures, restarts, resume, the release interlock, a silent planner and the
goals it refuses.
"""

import dataclasses

import numpy as np
import pytest

from runner_world import PARAMS, SETTINGS, START, World
from walker_supervisor.core.adoption import RecordedStep
from walker_supervisor.core.commands import (
    CancelFollow, Feedback, FollowMotion, ForgetRecordedStep, GoalEnded, GripperRequest,
    Notice, PhaseRecord, PlanMotion, RecordStep, RenewPlannerClient, SetControlMode,
    StepRecord, StopJog, StopOrphanStream)
from walker_supervisor.core.controller_watch import ControllerReport
from walker_supervisor.core.goals import GoalRefusedError
from walker_supervisor.core.phases import Phase, SequencerError
from walker_supervisor.core.runner import ANSWER_GIVE_UP, ANSWER_WAIT, WATCH_PERIOD, WalkRunner

SCREW_TIME = PARAMS.gripper.screw_time


# ---------------------------------------------------------------------- a walk
def test_a_walk_takes_its_steps_in_order_records_each_and_ends_with_its_result():
    world = World()
    ended = world.goal('walk_to', 'n3_2')
    assert (ended.goal, ended.status, ended.message) == ('walk_to', 'succeeded', '')
    assert ended.steps_taken == 3 and ended.path == ['n1_2', 'n2_2', 'n3_2']
    records = world.of(StepRecord)
    assert [(r.step_index, r.step_count, r.step.to_node, r.outcome.success)
            for r in records] == [(0, 3, 'n1_2', True), (1, 3, 'n2_2', True),
                                  (2, 3, 'n3_2', True)]
    assert ended.duration == pytest.approx(sum(r.outcome.duration for r in records))
    assert (ended.base_gripper, ended.base_node) == ('b', 'n3_2')
    assert world.grippers == {'a': ('attached', 'n2_2'), 'b': ('attached', 'n3_2')}
    # every screw-in over its hole: the figures are of the tip as the plant measured it
    assert all(r.insertion_error < 1e-6 and r.residual_vibration < 1e-6 for r in records)
    # a walk ends once its last screw-in has relaxed, not at the screw-in
    (end,) = world.when(GoalEnded)
    assert end - world.when(StepRecord)[-1] >= SETTINGS.relaxation_wait - 0.02
    assert world.runner.walk is None


def test_the_insertion_error_is_the_plants_from_the_real_hole_when_it_says_it():
    """On a truss as built the drawing's hole is not the real one: the plant's figure counts."""
    world = World()
    world.position_errors = {'a': 7e-4, 'b': 7e-4}  # the tip 0.7 mm from the real hole's axis
    ended = world.goal('step', 'n1_2')
    assert ended.status == 'succeeded', ended.message
    (record,) = world.of(StepRecord)
    assert record.insertion_error == pytest.approx(7e-4)
    # and the figure from the drawing's hole without it
    drawing = World()
    drawing.goal('step', 'n1_2')
    assert drawing.of(StepRecord)[0].insertion_error < 1e-6


def test_a_walk_keeps_each_step_on_record_until_it_completes():
    world = World()
    world.goal('walk_to', 'n2_2')
    kept = [(type(c).__name__, getattr(c, 'step', None) and c.step.to_node) for c in world.log
            if isinstance(c, (RecordStep, ForgetRecordedStep))]
    # each step recorded as it starts (and again once its stance is measured after the
    # relaxation of the screw-in before it), forgotten once screwed in
    assert kept == [('RecordStep', 'n1_2'), ('ForgetRecordedStep', None),
                    ('RecordStep', 'n2_2'), ('RecordStep', 'n2_2'),
                    ('ForgetRecordedStep', None)]


def test_feedback_and_phase_follow_the_walk_with_a_progress_that_grows_to_one():
    world = World()
    world.goal('walk_to', 'n2_2')
    feedback = world.of(Feedback)
    assert {f.goal for f in feedback} == {'walk_to'} and {f.step_count for f in feedback} == {2}
    assert [f.step_index for f in feedback] == sorted(f.step_index for f in feedback)
    assert {(f.step_index, f.to_node) for f in feedback if f.to_node} == {(0, 'n1_2'),
                                                                           (1, 'n2_2')}
    assert all(0.0 <= f.phase_progress <= 1.0 for f in feedback)
    phases = [r for r in world.of(PhaseRecord) if r.phase not in (Phase.IDLE, Phase.SAFE_HOLD)]
    runs = {}
    for record in phases:
        runs.setdefault((record.step_index, record.phase), []).append(record.phase_progress)
    timed = (Phase.EXTRACTION, Phase.COARSE, Phase.INSERTION)
    assert {key for key in runs if key[1] in timed} == {(i, p) for i in (0, 1) for p in timed}
    for key, values in runs.items():
        assert values == sorted(values) and values[-1] <= 1.0, (key, values)
        if key[1] in timed:  # published again by quarters of its plan
            assert len(values) >= 4 and values[-1] >= 0.75, (key, values)


def test_a_step_goal_reports_its_phase_progress_in_its_feedback():
    world = World()
    ended = world.goal('step', 'n1_2')
    assert ended.success and ended.path == ['n1_2']
    feedback = world.of(Feedback)
    assert {f.goal for f in feedback} == {'step'}
    assert all(0.0 <= f.phase_progress <= 1.0 for f in feedback)
    for phase in (Phase.EXTRACTION, Phase.COARSE):
        values = [f.phase_progress for f in feedback if f.phase == phase]
        assert values == sorted(values) and values[-1] > 0.5, (phase, values)


def test_a_cancelled_walk_finishes_the_step_under_way_and_starts_no_other():
    world = World()
    world.execute(world.runner.start_goal('walk_to', 'n3_2', world.now, world.now))
    world.run_until(lambda: world.phases and world.phases[-1] == Phase.COARSE)
    world.runner.cancel_goal()
    world.run_until(lambda: world.of(GoalEnded))
    (ended,) = world.of(GoalEnded)
    assert (ended.status, ended.steps_taken, ended.path) == ('canceled', 1, ['n1_2'])
    assert ended.message == 'cancelled after 1 of 3 steps'
    assert world.grippers == {'a': ('attached', 'n1_1'), 'b': ('attached', 'n1_2')}
    assert len(world.of(StepRecord)) == 1 and world.phases[-1] == Phase.IDLE


def test_the_same_events_give_the_same_commands():
    def walked() -> list:
        world = World()
        world.goal('walk_to', 'n2_2')
        return [(t, _plain(command)) for t, command in zip(world.stamps, world.log, strict=True)]

    first, second = walked(), walked()
    assert len(first) > 100 and first == second


def _plain(value):
    """Return a command as plain values (arrays as lists), for comparison."""
    if dataclasses.is_dataclass(value):
        return (type(value).__name__, tuple((field.name, _plain(getattr(value, field.name)))
                                            for field in dataclasses.fields(value)))
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (list, tuple)):
        return [_plain(item) for item in value]
    if isinstance(value, dict):
        return sorted((key, _plain(item)) for key, item in value.items())
    return value


# ---------------------------------------------------------------------- a step's bound
def test_a_steps_bound_counts_its_screw_actions_and_its_planned_motions_once_each():
    """Two screw actions, the extraction, the coarse motion and the insertion, once each.

    A jam plans a second descent; it and the lift back after the jam are not in the bound.
    """
    world = World(dataclasses.replace(SETTINGS, search_radius=0.0))
    world.jam = 1
    ended = world.goal('step', 'n1_2')
    (record,) = world.of(StepRecord)
    assert record.outcome.success and record.outcome.insertion_attempts == 2
    purposes = [purpose for purpose, _ in world.planned]
    assert purposes.count('insertion') == 2 and 'retry_lift' in purposes
    first = {}
    for purpose, answer in world.planned:
        first.setdefault(purpose, answer.time_optimal_bound)
    expected = 2 * SCREW_TIME + first['extraction'] + first['coarse'] + first['insertion']
    assert first['coarse'] > 0 and record.time_optimal_bound == pytest.approx(expected)
    assert record.bound_ratio == pytest.approx(record.outcome.duration / expected)
    assert (ended.time_optimal_bound, ended.step_duration) == (record.time_optimal_bound,
                                                               record.outcome.duration)


# ---------------------------------------------------------------------- a restart
def _restarted_in_coarse_motion(recorded=None):
    """Restart the supervisor while the step n2_1 -> n1_2 is in its coarse motion.

    Returns the world of the new supervisor (joints and grippers as the old one left them)
    and the step the old one kept on record.
    """
    old = World()
    old.execute(old.runner.start_goal('step', 'n1_2', old.now, old.now))
    old.run_until(lambda: old.phases and old.phases[-1] == Phase.COARSE)
    for _ in range(30):
        old.period()
    old.stream = None  # the old supervisor's stream stops with it
    (kept,) = [c for c in old.log if isinstance(c, RecordStep)][-1:]
    record = recorded or RecordedStep(kept.step.base_gripper, kept.step.base_node,
                                      kept.step.from_node, kept.step.to_node, kept.heading)
    world = World(recorded_step=record, grippers=old.grippers, positions=old.positions,
                  frame=(old.anchor, old.frame))
    world.period()
    return world, kept.step


def test_a_restarted_supervisor_holds_takes_the_step_up_and_resume_completes_it():
    world, step = _restarted_in_coarse_motion()
    assert world.grippers['b'][0] == 'free'
    assert world.of(StopOrphanStream), 'a stream of the old supervisor may still run'
    assert world.phases[-1] == Phase.SAFE_HOLD
    reason = world.of(PhaseRecord)[-1].reason
    assert reason == 'restarted in the middle of the step n2_1 -> n1_2: resume to complete it'
    assert not world.of(GripperRequest) and not world.of(PlanMotion), 'nothing moves by itself'
    answer, commands = world.runner.resume(world.now, world.now)
    assert answer == 'resumed: completing the step to n1_2'
    world.execute(commands)
    world.run_until(lambda: world.phases[-1] == Phase.IDLE, 60.0)
    assert world.grippers == {'a': ('attached', 'n1_1'), 'b': ('attached', 'n1_2')}
    assert isinstance([c for c in world.log if isinstance(c, (RecordStep, ForgetRecordedStep))
                       ][-1], ForgetRecordedStep)
    assert 'step n2_1 -> n1_2 completed after resume' in ' '.join(world.notices)
    # its outcome is not the first step of the next walk
    assert world.goal('walk_to', 'n0_2').steps_taken == 1


def test_a_latched_mode_heard_after_the_step_was_taken_up_does_not_change_its_base():
    world, step = _restarted_in_coarse_motion()
    other = 'b' if step.base_gripper == 'a' else 'a'
    world.runner.latched_mode(other)  # a mode on record naming the free gripper, heard late
    answer, commands = world.runner.resume(world.now, world.now)
    assert answer == f'resumed: completing the step to {step.to_node}'


def test_a_record_that_does_not_describe_the_walker_is_forgotten_and_not_taken_up():
    wrong = RecordedStep('a', 'n2_2', 'n2_1', 'n1_2', 0.0)  # another base node
    world, _ = _restarted_in_coarse_motion(wrong)
    assert any('does not describe the walker now' in n for n in world.notices)
    assert world.of(ForgetRecordedStep)
    assert world.phases[-1] == Phase.SAFE_HOLD
    assert world.of(PhaseRecord)[-1].reason == 'started with gripper b not attached'
    with pytest.raises(SequencerError, match='no step to complete'):
        world.runner.resume(world.now, world.now)


def test_a_record_found_with_both_grippers_attached_is_not_taken_up():
    world = World(recorded_step=RecordedStep('a', 'n1_1', 'n2_1', 'n1_2', 0.0))
    world.run_until(lambda: world.now > 1.0)
    assert set(world.phases) == {Phase.IDLE} and not world.of(GripperRequest)


# ---------------------------------------------------------------------- resume
def test_resume_is_refused_outside_safe_hold_and_while_a_source_is_silent():
    world = World()
    with pytest.raises(SequencerError, match='not in SAFE_HOLD'):
        world.runner.resume(world.now, world.now)
    world.execute(world.runner.hold('hold requested by an operator', world.now))
    assert world.phases[-1] == Phase.SAFE_HOLD and world.of(StopJog)
    world.silent.add('vertex_joint')
    world.run_until(lambda: world.now > SETTINGS.watchdog_timeout + 0.5)
    with pytest.raises(SequencerError,
                       match='cannot resume while controller vertex_joint: silent for'):
        world.runner.resume(world.now, world.now)
    assert world.phases[-1] == Phase.SAFE_HOLD, 'a refused resume changes nothing'
    world.silent.clear()
    world.period()
    answer, _ = world.runner.resume(world.now, world.now)
    assert answer == 'resumed: ready for a step or a walk'


def test_resume_without_joint_states_is_refused():
    runner = WalkRunner(PARAMS, SETTINGS, join=None)
    runner.joint_states(None, None, 0.0)  # heard, but not one usable state
    runner.gripper_states({'a': ('attached', 'n1_1'), 'b': ('attached', 'n2_1')}, 0.0, 0.0)
    runner.controller_states({j: ControllerReport(0.0, False, True) for j in
                              ('a_yaw_joint', 'a_pitch_joint', 'vertex_joint',
                               'b_pitch_joint', 'b_yaw_joint')}, 0.0, 0.0)
    runner.hold('hold requested by an operator', 0.0)
    with pytest.raises(SequencerError, match='no joint states from the plant'):
        runner.resume(0.1, 0.1)


# ---------------------------------------------------------------------- the release interlock
def test_the_release_interlock_needs_the_other_gripper_freshly_reported_attached():
    world = World()
    assert world.runner.release_refusal('b', world.now) == ''
    world.grippers['a'] = ('jammed', 'n1_1')
    world.period()
    assert world.runner.release_refusal('b', world.now) == \
        'interlock: gripper a is jammed, not attached'
    world.grippers['a'] = ('attached', 'n1_1')
    world.period()
    world.silent.add('grippers')
    world.run_until(lambda: world.now > SETTINGS.watchdog_timeout + 0.5)
    assert world.runner.release_refusal('b', world.now) == \
        'interlock: the gripper states are not fresh'


def test_a_walk_releases_no_gripper_while_the_gripper_states_are_stale():
    """A walk's next step asks for no unscrew once the gripper states have gone silent.

    The walk ends, its base still screwed in.
    """
    settings = dataclasses.replace(SETTINGS, watchdog_timeout=0.2, relaxation_wait=1.0)
    world = World(settings)
    world.execute(world.runner.start_goal('walk_to', 'n2_2', world.now, world.now))
    world.run_until(lambda: world.of(StepRecord))
    world.silent.add('grippers')
    world.run_until(lambda: world.of(GoalEnded))
    (ended,) = world.of(GoalEnded)
    assert ended.status == 'aborted' and ended.steps_taken == 1
    assert ended.message == ('unscrewing gripper a failed: interlock: the gripper states are '
                             'not fresh')
    assert [r.action for r in world.of(GripperRequest)] == ['unscrew', 'screw_in']
    assert world.grippers == {'a': ('attached', 'n1_1'), 'b': ('attached', 'n1_2')}


# ---------------------------------------------------------------------- a silent planner
def test_an_unanswered_plan_is_asked_again_over_a_new_client_then_given_up_in_safe_hold():
    world = World(dataclasses.replace(SETTINGS, phase_timeout=60.0))
    world.planner_silent = True
    ended = world.goal('step', 'n1_2', limit=60.0)
    assert ended.status == 'aborted'
    assert ended.message == (f'lifting trajectory failed: the planner answered no '
                             f'plan_trajectory request in {ANSWER_GIVE_UP:.0f} s, asked again '
                             f'every {ANSWER_WAIT:g} s over a new connection')
    renewals = world.when(RenewPlannerClient)
    assert len(renewals) == ANSWER_GIVE_UP / ANSWER_WAIT - 1
    assert np.diff(renewals) == pytest.approx(ANSWER_WAIT, abs=0.11)
    assert world.phases[-1] == Phase.SAFE_HOLD
    assert world.grippers['a'] == ('attached', 'n1_1'), 'the base holds the walker'


def test_a_plan_answered_after_it_was_asked_again_streams_and_late_first_answers_do_not():
    world = World()
    world.planner_silent, world.heard_after_renewal = True, True
    world.execute(world.runner.start_goal('step', 'n1_2', world.now, world.now))
    world.run_until(lambda: world.of(RenewPlannerClient), 30.0)
    world.run_until(lambda: world.stream is not None, 10.0)
    streams = len(world.of(FollowMotion))
    for late in world.unanswered:  # the first requests answered at last: too late to count
        if isinstance(late, PlanMotion):
            world.execute(world.runner.plan_answered(late.ticket, world.plan(late.call),
                                                     world.now))
    assert len(world.of(FollowMotion)) == streams
    world.run_until(lambda: world.of(GoalEnded), 60.0)
    assert world.of(GoalEnded)[0].success


def test_a_stream_accepted_after_it_was_asked_again_is_cancelled():
    world = World()
    world.acceptances_lost = 1  # the planner streams, but its acceptance never comes back
    world.execute(world.runner.start_goal('step', 'n1_2', world.now, world.now))
    world.run_until(lambda: len(world.of(FollowMotion)) == 2, 30.0)
    assert world.of(RenewPlannerClient)[-1].service == 'follow_trajectory'
    first, again = world.of(FollowMotion)
    assert again.trajectory is first.trajectory and again.ticket != first.ticket
    world.execute(world.runner.follow_accepted(first.ticket, True, world.now))
    assert world.of(CancelFollow)[-1].ticket == first.ticket
    world.run_until(lambda: world.of(GoalEnded), 60.0)
    assert world.of(GoalEnded)[0].success


def test_a_planner_that_dies_mid_motion_holds_the_walker_after_the_motions_end_and_margin():
    """The controllers finish a whole trajectory without the planner; its end never comes.

    The walker holds once the motion's planned end and ``motion_end_margin`` have passed on
    the graph's clock, not before, naming the planner, with the base attached and the
    controllers told to hold; with the planner back, resume completes the step.
    """
    world = World()
    world.execute(world.runner.start_goal('step', 'n1_2', world.now, world.now))
    world.run_until(lambda: world.phases and world.phases[-1] == Phase.COARSE, 30.0)
    ticket, trajectory, started = world.stream
    world.planner_dead = True
    world.run_until(lambda: world.of(GoalEnded), 60.0)
    assert world.phases[-1] == Phase.SAFE_HOLD
    held_at = world.when(GoalEnded)[0]
    due = started + trajectory.duration + SETTINGS.motion_end_margin
    assert due < held_at <= due + 2 * WATCH_PERIOD, (held_at, due)
    reason = world.of(PhaseRecord)[-1].reason
    assert reason.startswith('fault: the planner did not report the end of the') \
        and f'within {SETTINGS.motion_end_margin:g} s of its planned end' in reason, reason
    assert world.of(GoalEnded)[0].status == 'aborted'
    assert world.grippers['a'] == ('attached', 'n1_1'), 'the base holds the walker'
    assert world.of(CancelFollow)[-1].ticket == ticket
    assert [c.mode for c in world.of(SetControlMode)][-1] == 'hold'
    # the controllers hold: the arm stands where it is, a fraction of a milliradian off the
    # plan's end as the plant's does (the ideal arm's exact end leaves a way back nothing to move)
    world.stream, world.positions = None, world.positions + 2e-4
    world.period()
    world.planner_dead = False  # started again
    answer, commands = world.runner.resume(world.now, world.now)
    assert answer.startswith('resumed'), answer
    world.execute(commands)
    world.run_until(lambda: world.phases[-1] == Phase.IDLE, 60.0)
    assert world.grippers == {'a': ('attached', 'n1_1'), 'b': ('attached', 'n1_2')}


def test_motion_ends_reported_late_but_within_the_margin_hold_nothing():
    """A planner that reports each end late, within ``motion_end_margin``, is no fault."""
    world = World()
    world.end_delay = 0.8 * SETTINGS.motion_end_margin
    ended = world.goal('step', 'n1_2', limit=120.0)
    assert ended.status == 'succeeded', ended.message
    assert Phase.SAFE_HOLD not in world.phases


# ---------------------------------------------------------------------- goals refused
@pytest.mark.parametrize('goal, target, words', [
    ('walk_to', 'n99_99', 'not on the truss'),
    ('walk_to', 'n4_03', 'not a node name'),
    ('step', 'n4_3\n', 'not a node name'),
    ('walk_to', 'node7', 'not a node name'),
    ('step', 'n3_2', 'not one step away'),
    ('fly_to', 'n1_2', 'unknown goal'),
])
def test_unknown_malformed_and_unreachable_targets_are_refused_and_nothing_moves(goal, target,
                                                                                 words):
    world = World()
    with pytest.raises(GoalRefusedError, match=words):
        world.runner.start_goal(goal, target, world.now, world.now)
    assert world.runner.walk is None
    world.run_until(lambda: world.now > 1.0)
    assert np.array_equal(world.positions, START)
    assert not world.of(GripperRequest) and not world.of(PlanMotion)


def test_goals_are_refused_while_another_runs_in_safe_hold_and_during_an_operators_command():
    world = World()
    world.execute(world.runner.start_goal('walk_to', 'n2_2', world.now, world.now))
    with pytest.raises(GoalRefusedError, match='a walk to n2_2 is running: cancel it first'):
        world.runner.start_goal('step', 'n1_2', world.now, world.now)
    world.run_until(lambda: world.of(GoalEnded), 60.0)
    world.execute(world.runner.hold('hold requested by an operator', world.now))
    with pytest.raises(GoalRefusedError, match=r'safe hold \(hold requested by an operator\): '
                                               r'call resume first'):
        world.runner.start_goal('step', 'n1_1', world.now, world.now)
    world.execute(world.runner.resume(world.now, world.now)[1])
    world.runner.teleop_operation = 'jog of b_yaw_joint by +0.1000 rad'
    with pytest.raises(GoalRefusedError, match='a teleoperation command is under way'):
        world.runner.start_goal('step', 'n1_1', world.now, world.now)
    world.runner.teleop_operation = ''
    world.silent.add('vertex_joint')
    silent_since = world.now
    world.run_until(lambda: world.now > silent_since + SETTINGS.watchdog_timeout + 0.1)
    with pytest.raises(GoalRefusedError, match='cannot start while controller vertex_joint'):
        world.runner.start_goal('step', 'n1_1', world.now, world.now)


def test_a_walk_to_a_node_a_gripper_is_in_ends_at_once_with_no_step():
    world = World()
    ended = world.goal('walk_to', 'n2_1')
    assert (ended.status, ended.steps_taken, ended.path) == ('succeeded', 0, [])
    assert not world.of(GripperRequest)


# ---------------------------------------------------------------------- faults in a step
def test_a_controller_falling_silent_in_a_step_holds_the_walker_and_names_it():
    world = World()
    world.execute(world.runner.start_goal('step', 'n1_2', world.now, world.now))
    world.run_until(lambda: world.phases and world.phases[-1] == Phase.COARSE)
    world.silent.add('vertex_joint')
    world.run_until(lambda: world.of(GoalEnded), 10.0)
    assert world.phases[-1] == Phase.SAFE_HOLD
    reason = world.of(PhaseRecord)[-1].reason
    assert reason.startswith('fault: controller vertex_joint: silent for'), reason
    assert world.of(GoalEnded)[0].status == 'aborted'
    assert world.grippers['a'] == ('attached', 'n1_1')
    assert any(isinstance(c, SetControlMode) and c.mode == 'hold' for c in world.log[-10:])
    assert any(isinstance(n, Notice) and n.level == 'error' for n in world.log)


def test_a_controller_that_fell_back_to_hold_in_a_step_is_told_its_mode_again():
    world = World()
    world.execute(world.runner.start_goal('step', 'n1_2', world.now, world.now))
    world.run_until(lambda: world.phases and world.phases[-1] == Phase.COARSE)
    stamp = world.now + 0.5  # a report well after the COARSE command, holding
    commands = world.runner.controller_states(
        {'vertex_joint': ControllerReport(stamp, False, True)}, stamp, world.now)
    assert commands[-1] == SetControlMode('coarse', 'a')
    assert 'fell back to HOLD' in commands[-2].message


# ---------------------------------------------------------------------- its own stall
def _stall(world, seconds: float) -> None:
    """Stand the runner's process still ``seconds``; on waking its watchdog runs first."""
    world.now = round(world.now + seconds, 9)
    world.next_watch = world.now + WATCH_PERIOD
    world.execute(world.runner.watch(world.now, world.now))


def test_a_supervisor_that_itself_stalled_in_a_step_names_its_own_stall_not_its_inputs():
    """Frozen 3.3 s, it blamed the plant: 'plant gripper states: silent for 3.29 s'."""
    world = World()
    world.execute(world.runner.start_goal('step', 'n1_2', world.now, world.now))
    world.run_until(lambda: world.phases and world.phases[-1] == Phase.COARSE)
    _stall(world, 3.3)
    assert world.phases[-1] == Phase.SAFE_HOLD
    reason = world.of(PhaseRecord)[-1].reason
    assert reason.startswith('fault: the supervisor itself stalled 3.3 s'), reason
    assert 'silent' not in reason, reason
    # its sources are heard again: nothing is silent, and resume is possible
    end = world.now + 0.5
    world.run_until(lambda: world.now >= end, 1.0)
    assert not world.runner.health.faults(world.now, include_trouble=False)
    assert world.of(PhaseRecord)[-1].reason == reason


def test_a_supervisor_that_stalled_between_steps_says_so_and_faults_nothing():
    world = World()
    _stall(world, 3.3)
    assert Phase.SAFE_HOLD not in world.phases
    assert any('the supervisor itself stalled 3.3 s' in n for n in world.notices)
    assert not world.runner.health.faults(world.now, include_trouble=False)


# ---------------------------------------------------------------------- the truss as built
def test_a_hole_off_its_place_is_found_by_the_search_and_surveyed_with_the_base_attached():
    """A hole 3 mm from the node's nominal place: jams, probes, screws in, maps the node."""
    world = World()
    world.holes['n1_2'] = (0.0, 0.003)
    ended = world.goal('step', 'n1_2')
    assert ended.status == 'succeeded', ended.message
    (record,) = world.of(StepRecord)
    outcome = record.outcome
    assert outcome.success and outcome.search_probes >= 1
    assert outcome.insertion_attempts == outcome.search_probes + 1
    assert 0.0 < outcome.hole_offset <= SETTINGS.search_radius
    # the map now has the node within the insertion tolerance of its hole
    estimate = world.runner.mapped.map.estimate('n1_2')
    hole = world.runner.truss.position('n1_2') + np.array([0.0, 0.003, 0.0])
    assert estimate.surveyed
    assert np.linalg.norm(estimate.position[:2] - hole[:2]) \
        <= PARAMS.gripper.insertion_position_tolerance
    # the base gripper was never asked to let go
    assert all(r.gripper == 'b' for r in world.of(GripperRequest) if r.action == 'unscrew')
    assert any('found by the search' in n.message for n in world.of(Notice))


def test_a_hole_beyond_the_search_ends_in_safe_hold_with_the_base_attached():
    world = World()
    world.holes['n1_2'] = (0.009, 0.0)
    ended = world.goal('step', 'n1_2')
    assert ended.status == 'aborted' and 'search tried all' in ended.message
    assert world.runner.sequencer.phase == Phase.SAFE_HOLD
    assert world.grippers['a'][0] == 'attached'
    assert not world.runner.mapped.map.surveyed('n1_2')
