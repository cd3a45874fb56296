"""Resume from SAFE_HOLD: back to IDLE, or the interrupted step completed; the way back.

Each test drives the sequencer through a step in ``sequencer_world``'s ideal world.
"""

import math

import numpy as np
import pytest

from sequencer_world import (
    KIN, SUPERVISOR, TRUSS, World, following_step, hold_during, remeasuring, resume_step,
    run_to_the_end, start_next_step)
from walker_supervisor.core.commands import SetControlMode, TrajectoryRequest
from walker_supervisor.core.phases import Phase, SequencerError
from walker_supervisor.core.route import possible_steps
from walker_supervisor.core.step_geometry import plan_step_targets


def test_resume_with_both_grippers_attached_returns_to_idle():
    world = World()
    world.sequencer.hold('operator', 0.0)
    assert world.sequencer.phase == Phase.SAFE_HOLD
    world.sequencer.require_safe_hold()  # a hold: resumable
    commands = world.sequencer.resume(0.1, world.theta, dict(world.grippers),
                                      {'a': 'n1_1', 'b': 'n2_1'})
    assert world.sequencer.phase == Phase.IDLE and commands == [SetControlMode('hold', 'a')]
    with pytest.raises(SequencerError, match='not in SAFE_HOLD'):
        world.sequencer.resume(0.2, world.theta, dict(world.grippers), {})
    with pytest.raises(SequencerError, match=r'not in SAFE_HOLD \(phase IDLE\)'):
        world.sequencer.require_safe_hold()  # what the node answers first, whatever the health


@pytest.mark.parametrize('phase', [Phase.COARSE, Phase.FINE])
def test_resume_mid_step_recovers_to_the_target_and_completes_the_step(phase):
    world = World()
    step = hold_during(world, phase)
    assert world.grippers[step.moving_gripper] == 'free'
    recover = resume_step(world)
    assert recover.purpose == 'recover' and recover.mode == 'fine'
    np.testing.assert_allclose(recover.goal_point, world.targets.point_above_to)
    run_to_the_end(world)
    assert world.grippers == {'a': 'attached', 'b': 'attached'}
    assert world.sequencer.base_gripper == 'b'


def test_a_step_completed_after_resume_has_its_outcome_taken_once():
    world = World()
    step = possible_steps(TRUSS, world.stance)[0]
    assert world.sequencer.take_outcome() is None
    hold_during(world, Phase.COARSE)
    aborted = world.sequencer.take_outcome()
    assert aborted is not None and not aborted.success and aborted.message == 'a fault'
    assert world.sequencer.take_outcome() is None
    world.execute(world.sequencer.resume(world.now, world.theta, dict(world.grippers),
                                         {'a': 'n1_1', 'b': ''}))
    assert world.sequencer.take_outcome() is None, 'the step is under way again'
    while world.sequencer.busy:
        world.advance()
    completed = world.sequencer.take_outcome()
    assert completed is not None and completed.success
    assert world.sequencer.take_outcome() is None, 'taken once: no walk counts it again'
    assert world.sequencer.step == step


def test_resume_in_the_hole_lifts_out_first():
    world = World()
    hold_during(world, Phase.EXTRACTION)
    assert resume_step(world).purpose == 'extraction'
    run_to_the_end(world)


@pytest.mark.parametrize('grippers, words', [
    ({'a': 'free', 'b': 'attached'}, 'base gripper a is not attached'),
    ({'a': 'attached', 'b': 'unscrewing'}, 'still unscrewing'),
])
def test_resume_refuses_what_is_not_safe(grippers, words):
    world = World()
    hold_during(world, Phase.COARSE)
    with pytest.raises(SequencerError, match=words):
        world.sequencer.resume(world.now, world.theta, grippers, {})
    assert world.sequencer.phase == Phase.SAFE_HOLD


def test_resume_without_a_step_to_complete_is_refused():
    world = World()
    world.sequencer.hold('operator', 0.0)
    with pytest.raises(SequencerError, match='no step to complete'):
        world.sequencer.resume(0.1, world.theta, {'a': 'attached', 'b': 'free'}, {})


def test_a_step_forgotten_after_an_operator_changed_the_stance_is_not_completed():
    world = World()
    hold_during(world, Phase.COARSE)
    world.sequencer.forget_step()
    with pytest.raises(SequencerError, match='no step to complete'):
        world.sequencer.resume(world.now, world.theta, dict(world.grippers), {'a': 'n1_1'})
    world.sequencer.resume(world.now, world.theta, {'a': 'attached', 'b': 'attached'},
                           {'a': 'n1_1', 'b': 'n2_1'})
    assert world.sequencer.phase == Phase.IDLE


def test_a_step_under_way_cannot_be_forgotten():
    world = World()
    step = possible_steps(TRUSS, world.stance)[0]
    targets = plan_step_targets(KIN, world.frame, step, TRUSS.position(step.from_node),
                                TRUSS.position(step.to_node), world.theta, 0.03)
    world.execute(world.sequencer.start(step, targets, world.now, dict(world.grippers)))
    with pytest.raises(SequencerError, match='a step is under way'):
        world.sequencer.forget_step()
    assert world.sequencer.step is step


def _folded_mid_sweep(world, radius, height=0.03, turned=0.9):
    """Joints with the tip ``radius`` from the base yaw axis, ``turned`` rad into the sweep."""
    sweep = world.sequencer.step.sweep
    start = world.targets.point_above_from
    angle = math.atan2(start[1], start[0]) + turned * math.copysign(1.0, sweep)
    point = [radius * math.cos(angle), radius * math.sin(angle), height, 0.0,
             world.targets.above_from[4]]
    return KIN.inverse(point, reference=world.targets.above_from)


def _hold_a_half_turn_in_coarse_motion(world):
    step = next(s for s in possible_steps(TRUSS, world.stance)
                if abs(abs(s.sweep) - math.pi) < 1e-9)
    return hold_during(world, Phase.COARSE, step, ticks=0, reason='controllers held mid-sweep')


def test_resume_where_the_arm_folded_mid_sweep_goes_back_in_joint_space_and_completes():
    world = World()
    _hold_a_half_turn_in_coarse_motion(world)
    world.theta = _folded_mid_sweep(world, 0.205)  # no straight tip line from here
    back = resume_step(world)
    assert back.purpose == 'recover_joint' and back.mode == 'fine'
    np.testing.assert_allclose(back.goal, world.targets.above_to)
    run_to_the_end(world)


def test_resume_with_no_safe_way_back_is_refused_and_changes_nothing():
    world = World()
    _hold_a_half_turn_in_coarse_motion(world)
    world.theta = _folded_mid_sweep(world, 0.205, height=0.005)  # low, folded
    with pytest.raises(SequencerError, match='no safe way back above n0_1'):
        world.sequencer.resume(world.now, world.theta, dict(world.grippers),
                               {'a': 'n1_1', 'b': ''})
    assert world.sequencer.phase == Phase.SAFE_HOLD
    assert world.sequencer.reason == 'controllers held mid-sweep'


def test_resume_in_the_hole_lifts_straight_up_from_where_the_gripper_drifted():
    world = World()
    hold_during(world, Phase.EXTRACTION)
    world.theta = world.theta + np.array([0.003, 0.0, 0.0, 0.0, 0.0])  # ~2.7 mm sideways
    tip = KIN.forward(world.theta)[:3]
    assert np.linalg.norm(tip[:2] - world.targets.point_above_from[:2]) > 0.002
    lift = resume_step(world)
    assert lift.purpose == 'extraction'
    np.testing.assert_allclose(lift.goal_point[:2], tip[:2], atol=1e-9)  # vertical
    assert lift.goal_point[2] == pytest.approx(world.targets.point_above_from[2])
    np.testing.assert_allclose(KIN.forward(lift.goal)[:3], lift.goal_point, atol=1e-9)
    run_to_the_end(world)


def test_resume_with_the_gripper_tilted_at_the_mouth_turns_it_upright_before_the_line():
    """A fault in the descent left the gripper tilted: turned upright first, then the line.

    A line (gripper vertical) from there would start away from the joints, and the planner
    refuses such a stream every time.
    """
    world = World()
    hold_during(world, Phase.INSERTION)
    world.theta = world.theta + np.array([0.0, 0.0, 0.0, 0.06, 0.0])  # the wrist, J4
    held = world.theta.copy()
    tip = KIN.forward(held)
    assert abs(tip[3]) > 0.05  # the gripper tilted
    upright = resume_step(world)
    assert upright.purpose == 'upright' and upright.mode == 'fine'
    np.testing.assert_allclose(upright.start, held)
    goal = KIN.forward(upright.goal)
    np.testing.assert_allclose(goal[:3], tip[:3], atol=1e-9)  # the tip stays where it is
    assert goal[3] == pytest.approx(0.0, abs=1e-9)  # the gripper vertical
    np.testing.assert_allclose(upright.goal_point, tip[:3], atol=1e-12)
    run_to_the_end(world)
    purposes = [c.purpose for c in world.log if isinstance(c, TrajectoryRequest)]
    after = purposes[purposes.index('upright') + 1]
    assert after == 'fine', purposes  # then the line, from where the gripper stood upright


def test_resume_with_the_gripper_upright_takes_the_line_at_once():
    world = World()
    hold_during(world, Phase.INSERTION)
    world.theta = world.theta + np.array([0.0, 0.0, 0.0, 0.01, 0.0])  # within the tolerance
    assert resume_step(world).purpose == 'recover'


def test_a_way_back_the_planner_refuses_is_taken_again_in_joint_space_once():
    world = World()
    hold_during(world, Phase.COARSE)
    assert resume_step(world).purpose == 'recover' == world.motion[0].purpose
    world.motion = None
    world.execute(world.sequencer.trajectory_done(False, 'the path leaves the workspace',
                                                  world.now))
    again = world.motion[0]
    assert again.purpose == 'recover_joint' and world.sequencer.phase == Phase.FINE
    np.testing.assert_allclose(again.goal, world.targets.above_to)
    world.motion = None  # refused as well: then the step holds
    world.execute(world.sequencer.trajectory_done(False, 'refused again', world.now))
    assert world.sequencer.phase == Phase.SAFE_HOLD
    assert 'refused again' in world.sequencer.reason


def test_a_resume_that_changes_the_base_lets_the_next_step_measure_after_the_relaxation():
    """Held while screwing in: the resume swaps the base, which starts the relaxation."""
    world = World(gripper_delay=0.5)
    step = possible_steps(TRUSS, world.stance)[0]
    world.targets = plan_step_targets(KIN, world.frame, step, TRUSS.position(step.from_node),
                                      TRUSS.position(step.to_node), world.theta, 0.03)
    world.execute(world.sequencer.start(step, world.targets, world.now, dict(world.grippers)))
    while world.sequencer.stage != 'screwing':
        world.advance()
    world.execute(world.sequencer.hold('a fault', world.now))
    assert world.sequencer.base_gripper == step.base_gripper
    for _ in range(60):  # the screw-in completes during the hold
        world.advance()
    assert world.grippers[step.moving_gripper] == 'attached'
    commands = world.sequencer.resume(world.now, world.theta, dict(world.grippers),
                                      {step.base_gripper: step.base_node,
                                       step.moving_gripper: step.to_node})
    assert commands == [SetControlMode('hold', step.moving_gripper)]
    assert world.sequencer.relaxed_at == pytest.approx(world.now + SUPERVISOR.relaxation_wait)
    next_step, calls = following_step(world), []
    start_next_step(world, next_step, remeasuring(world, next_step, calls))
    while world.sequencer.stage == 'unscrewing':
        world.advance()
    assert len(calls) == 1 and calls[0][0] >= world.sequencer.relaxed_at - 1e-9


def test_a_resume_that_keeps_the_base_does_not_wait():
    world = World()
    hold_during(world, Phase.COARSE)
    before = world.sequencer.relaxed_at
    world.sequencer.resume(world.now, world.theta, {'a': 'attached', 'b': 'attached'},
                           {'a': 'n1_1', 'b': 'n2_1'})
    assert world.sequencer.relaxed_at == before < world.now
