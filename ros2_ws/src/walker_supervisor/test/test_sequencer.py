"""The step-phase state machine as a whole: phases in order, modes, faults, refusals.

Each test drives the sequencer through a step in ``sequencer_world``'s ideal world.
"""

import math

import numpy as np
import pytest

from sequencer_world import DT, KIN, SUPERVISOR, TRUSS, World
from walker_supervisor.core.commands import (
    CancelTrajectory, GripperRequest, SetControlMode, TrajectoryRequest)
from walker_supervisor.core.phases import Phase, SequencerError
from walker_supervisor.core.route import PlannedStep, plan_route, possible_steps
from walker_supervisor.core.sequencer import StepSequencer
from walker_supervisor.core.step_geometry import BaseFrame, plan_step_targets


@pytest.mark.parametrize('to_node', ['n1_2', 'n1_0', 'n0_1'])
def test_a_step_runs_the_four_phases_in_order_and_swaps_the_base(to_node):
    world = World()
    step = next(s for s in possible_steps(TRUSS, world.stance) if s.to_node == to_node)
    outcome = world.run_step(step)
    assert outcome.success, outcome.message
    order = [p for i, p in enumerate(world.phases) if i == 0 or world.phases[i - 1] != p]
    assert order[:4] == [Phase.EXTRACTION, Phase.COARSE, Phase.FINE, Phase.INSERTION]
    assert world.sequencer.phase == Phase.IDLE
    assert world.sequencer.base_gripper == 'b'
    assert world.log[-1] == SetControlMode('hold', 'b')
    assert world.grippers == {'a': 'attached', 'b': 'attached'}
    assert set(outcome.phase_durations) == {'extraction', 'coarse', 'fine', 'insertion'}
    assert outcome.insertion_error <= SUPERVISOR.insertion_alignment
    tip = KIN.forward(world.theta)[:3]
    np.testing.assert_allclose(world.frame.to_truss(tip), TRUSS.position(to_node), atol=1e-9)


def test_controller_modes_follow_the_phases():
    world = World()
    world.run_step(possible_steps(TRUSS, world.stance)[0])
    modes = [c.mode for c in world.log if isinstance(c, SetControlMode)]
    # the controllers hold while the gripper unscrews (a relaxation under way runs on); each
    # motion then commands its own mode just before it streams (TrajectoryRequest.mode)
    assert modes[0] == 'hold' and 'coarse' in modes
    assert modes.index('coarse') < len(modes) - 1 - modes[::-1].index('fine')
    purposes = [c.purpose for c in world.log if isinstance(c, TrajectoryRequest)]
    # tracking is ideal here: the coarse motion ends on the point above the hole, no fine line
    assert purposes == ['extraction', 'coarse', 'insertion']
    assert [c.mode for c in world.log if isinstance(c, TrajectoryRequest)] == \
        ['fine', 'coarse', 'fine']


def test_walking_a_route_there_and_back_keeps_every_joint_inside_its_limits():
    world = World()
    stance = world.stance
    limits = (KIN.lower[0], KIN.upper[0])
    yaws = (world.theta[0], world.theta[4])  # base a: J1 is a_yaw_joint, J5 b_yaw_joint
    route = plan_route(TRUSS, stance, 'n4_3', yaws=yaws, yaw_limits=limits)
    turned = sum(step.sweep for step in route)
    route += plan_route(TRUSS, route[-1].stance_after(), 'n0_0',
                        yaws=(yaws[0] + turned, yaws[1] + turned), yaw_limits=limits)
    assert any(step.is_half_turn for step in route) and len(route) >= 6
    for step in route:
        world.frame = BaseFrame.from_stance(KIN, world.theta, TRUSS.position(stance.base_node),
                                            TRUSS.position(stance.other_node))
        outcome = world.run_step(step)
        assert outcome.success, outcome.message
        assert KIN.within_limits(world.theta)
        tip = world.frame.to_truss(KIN.forward(world.theta)[:3])
        np.testing.assert_allclose(tip, TRUSS.position(step.to_node), atol=1e-9)
        stance = step.stance_after()
        world.stance = stance
        world.theta = world.theta[::-1].copy()  # the roles mirror with the new base


def test_the_step_ends_at_the_screw_in_holding_under_the_new_base():
    """Screwed in: the step ends, HOLD under the new base (the controllers relax after it)."""
    world = World()
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert outcome.success, outcome.message
    holds = [i for i, c in enumerate(world.log) if c == SetControlMode('hold', 'b')]
    screw_in = max(i for i, c in enumerate(world.log)
                   if isinstance(c, GripperRequest) and c.action == 'screw_in')
    assert holds == [len(world.log) - 1] and holds[0] > screw_in
    attached = next(t for t, stage in reversed(world.stages) if stage == 'screwing')
    assert world.now == pytest.approx(attached)  # no wait: the relaxation overlaps what follows
    assert world.sequencer.relaxed_at == pytest.approx(world.now + SUPERVISOR.relaxation_wait)
    assert world.sequencer.phase == Phase.IDLE


def test_nothing_moves_until_the_gripper_reports_free_and_the_step_ends_when_attached():
    world = World(gripper_delay=0.5)
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert outcome.success, outcome.message
    lift = next(i for i, c in enumerate(world.log) if isinstance(c, TrajectoryRequest))
    assert world.log[lift].purpose == 'extraction'
    # the extraction line starts only once the plant reported gripper b free (0.5 s later)
    assert outcome.phase_durations['extraction'] >= 0.5 + 1.0
    assert outcome.phase_durations['insertion'] >= 0.5 + SUPERVISOR.settle_time


def test_a_gripper_that_never_completes_aborts_the_step_with_the_base_attached():
    world = World(gripper_never=True)
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert not outcome.success and 'did not unscrew in time' in outcome.message
    assert not any(isinstance(c, TrajectoryRequest) for c in world.log)
    assert world.grippers['a'] == 'attached'


def test_a_stalled_trajectory_times_out_to_safe_hold():
    world = World(stall_trajectories=True)
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0], max_time=30.0)
    assert not outcome.success and 'overran' in outcome.message
    assert world.now == pytest.approx(1.0 + SUPERVISOR.phase_timeout, abs=3 * DT)
    assert isinstance(world.log[-2], CancelTrajectory)


def test_a_trajectory_the_planner_never_answers_times_out_to_safe_hold():
    world = World()
    step = possible_steps(TRUSS, world.stance)[0]
    targets = plan_step_targets(KIN, world.frame, step, TRUSS.position(step.from_node),
                                TRUSS.position(step.to_node), world.theta, 0.03)
    sequencer = world.sequencer
    sequencer.start(step, targets, 0.0, dict(world.grippers))
    sequencer.gripper_done(True, '', 0.0)
    request = sequencer.tick(0.5, world.theta, np.zeros(5), {'a': 'attached', 'b': 'free'})
    assert [c.purpose for c in request if isinstance(c, TrajectoryRequest)] == ['extraction']
    now = 0.5
    while sequencer.phase != Phase.SAFE_HOLD:  # no trajectory_started, no trajectory_done
        now += DT
        assert now < 0.5 + SUPERVISOR.phase_timeout + 1.0, 'the request waits forever'
        commands = sequencer.tick(now, world.theta, np.zeros(5),
                                  {'a': 'attached', 'b': 'free'})
    assert now == pytest.approx(0.5 + SUPERVISOR.phase_timeout, abs=3 * DT)
    assert 'extraction trajectory did not start' in sequencer.reason
    assert 'planner' in sequencer.reason
    assert commands == [CancelTrajectory(), SetControlMode('hold', 'a')]


def test_a_hold_while_a_trajectory_is_being_planned_cancels_it():
    """The plan's answer, arriving after the hold, must not start a motion."""
    world = World()
    step = possible_steps(TRUSS, world.stance)[0]
    targets = plan_step_targets(KIN, world.frame, step, TRUSS.position(step.from_node),
                                TRUSS.position(step.to_node), world.theta, 0.03)
    sequencer = world.sequencer
    sequencer.start(step, targets, 0.0, dict(world.grippers))
    sequencer.gripper_done(True, '', 0.0)
    sequencer.tick(0.5, world.theta, np.zeros(5), {'a': 'attached', 'b': 'free'})
    assert sequencer.hold('hold requested by an operator', 0.6) == [
        CancelTrajectory(), SetControlMode('hold', 'a')]


def test_losing_the_base_during_a_step_aborts():
    world = World()
    step = possible_steps(TRUSS, world.stance)[0]
    targets = plan_step_targets(KIN, world.frame, step, TRUSS.position(step.from_node),
                                TRUSS.position(step.to_node), world.theta, 0.03)
    world.execute(world.sequencer.start(step, targets, 0.0, dict(world.grippers)))
    commands = world.sequencer.tick(0.1, world.theta, np.zeros(5), {'a': 'free', 'b': 'free'})
    assert world.sequencer.phase == Phase.SAFE_HOLD
    assert 'base gripper a' in world.sequencer.reason
    assert commands[-1] == SetControlMode('hold', 'a')


def test_steps_are_refused_unless_both_grippers_are_attached_and_idle():
    world = World()
    step = possible_steps(TRUSS, world.stance)[0]
    targets = plan_step_targets(KIN, world.frame, step, TRUSS.position(step.from_node),
                                TRUSS.position(step.to_node), world.theta, 0.03)
    with pytest.raises(SequencerError, match='both grippers attached'):
        world.sequencer.start(step, targets, 0.0, {'a': 'attached', 'b': 'free'})
    world.sequencer.start(step, targets, 0.0, dict(world.grippers))
    with pytest.raises(SequencerError, match='already under way'):
        world.sequencer.start(step, targets, 0.0, dict(world.grippers))
    world.sequencer.hold('operator hold', 0.5)
    with pytest.raises(SequencerError, match='SAFE_HOLD'):
        world.sequencer.start(step, targets, 0.0, dict(world.grippers))
    wrong_base = PlannedStep('b', 'n2_1', 'n1_1', 'n3_1', math.pi)
    fresh = StepSequencer(SUPERVISOR, KIN, 'a')
    with pytest.raises(SequencerError, match='base is gripper a'):
        fresh.start(wrong_base, targets, 0.0, dict(world.grippers))


def test_an_answer_that_nobody_waits_for_is_refused():
    world = World()
    with pytest.raises(SequencerError, match='unexpected gripper result'):
        world.sequencer.gripper_done(True, '', 0.0)


@pytest.mark.parametrize('accepted', [True, False])
def test_a_gripper_answer_after_a_hold_is_ignored(accepted):
    world = World()
    step = possible_steps(TRUSS, world.stance)[0]
    targets = plan_step_targets(KIN, world.frame, step, TRUSS.position(step.from_node),
                                TRUSS.position(step.to_node), world.theta, 0.03)
    start = world.sequencer.start(step, targets, world.now, dict(world.grippers))
    assert GripperRequest(step.moving_gripper, 'unscrew') in start
    world.execute(world.sequencer.hold('hold requested by an operator', world.now))
    # the plant's answer to the unscrew sent before the hold comes in now
    assert world.sequencer.gripper_done(accepted, '', world.now) == []
    assert world.sequencer.phase == Phase.SAFE_HOLD
    assert world.sequencer.reason == 'hold requested by an operator'
