"""COARSE and FINE: the hand-over inside the region, fine lines, when the descent may start.

Each test drives the sequencer through a step in ``sequencer_world``'s ideal world.
"""

import dataclasses

import numpy as np

from sequencer_world import (
    DT, KIN, SUPERVISOR, TRUSS, World, joint1_short_by, settling_above_the_hole, stage_times)
from walker_supervisor.core.commands import (
    CancelTrajectory, PrepareTrajectory, SetControlMode, TrajectoryRequest)
from walker_supervisor.core.phases import Phase
from walker_supervisor.core.route import possible_steps
from walker_supervisor.core.sequencer import StepSequencer


def test_coarse_hands_over_to_fine_mode_inside_the_region_and_runs_to_its_end():
    world = World()
    world.run_step(possible_steps(TRUSS, world.stance)[0])
    coarse = next(i for i, c in enumerate(world.log)
                  if isinstance(c, TrajectoryRequest) and c.purpose == 'coarse')
    fine = next(i for i, c in enumerate(world.log[coarse:], coarse)
                if isinstance(c, SetControlMode) and c.mode == 'fine')
    assert not any(isinstance(c, CancelTrajectory) for c in world.log), 'nothing is cancelled'
    assert world.phases.count(Phase.FINE) > 0
    assert fine > coarse


def test_a_coarse_motion_that_stops_outside_the_region_goes_on_in_fine_motion():
    world = World(coarse_miss=0.06)  # 54 mm short at 0.9 m, outside the 30 mm region
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert outcome.success, outcome.message
    lines = [c for c in world.log if isinstance(c, TrajectoryRequest) and c.purpose == 'fine']
    assert lines and lines[0].mode == 'fine'
    assert np.linalg.norm(KIN.forward(lines[0].start)[:3] - lines[0].goal_point) > \
        SUPERVISOR.coarse_to_fine_region


def test_a_tip_that_settles_off_the_hole_gets_a_fine_line_from_where_it_settled():
    world = World(coarse_miss=0.004)  # 3.6 mm short at 0.9 m
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert outcome.success, outcome.message
    lines = [c for c in world.log if isinstance(c, TrajectoryRequest) and c.purpose == 'fine']
    assert len(lines) == 1
    settled_tip = KIN.forward(lines[0].start)[:3]
    assert np.linalg.norm(settled_tip - lines[0].goal_point) > SUPERVISOR.insertion_alignment
    np.testing.assert_allclose(lines[0].goal_point, world.targets.point_above_to)


def test_a_correction_line_waits_settle_time_not_mouth_settle_time():
    """A tip that stopped short waits ``settle_time`` before its line: joint 1 may yet come in."""
    parameters = dataclasses.replace(SUPERVISOR, settle_time=0.4, mouth_settle_time=0.05)
    world = World(coarse_miss=0.004)  # 3.6 mm short at 0.9 m
    world.sequencer = StepSequencer(parameters, KIN, 'a')
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert outcome.success, outcome.message
    settling = stage_times(world, 'settling')
    line = stage_times(world, 'moving')
    fine_line_start = min(t for t in line if t > settling[0])
    assert fine_line_start - settling[0] >= parameters.settle_time - 1e-9


def test_the_descent_is_planned_on_entering_fine_and_streams_unchanged():
    """The descent asked for when FINE ends is the one prepared as FINE began (no replanning)."""
    world = World(coarse_miss=0.004)  # a correction line too: the descent stays the same
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert outcome.success, outcome.message
    prepared = [c.request for c in world.log
                if isinstance(c, PrepareTrajectory) and c.request.purpose == 'insertion']
    descents = [c for c in world.log
                if isinstance(c, TrajectoryRequest) and c.purpose == 'insertion']
    assert len(prepared) == 1 and len(descents) == 1
    assert prepared[0].same_motion(descents[0])
    # straight down the axis, from the point above the hole to its mouth
    np.testing.assert_allclose(descents[0].start_point[:2], descents[0].goal_point[:2])
    np.testing.assert_allclose(KIN.forward(descents[0].start)[:3], descents[0].start_point,
                               atol=1e-9)


def test_a_tip_over_the_hole_and_slow_descends_without_waiting_to_settle():
    """The descent starts at the first tick the tip is aligned and the joints slow.

    The insertion settles at the mouth before the screw-in, so the fine phase need not wait
    ``settle_time`` too: here (ideal tracking) the coarse motion ends on the point above the
    hole, and the descent is requested at once; the mouth settles for ``mouth_settle_time``,
    not for the longer ``settle_time``.
    """
    parameters = dataclasses.replace(SUPERVISOR, settle_time=0.5, mouth_settle_time=0.2)
    world = World()
    world.sequencer = StepSequencer(parameters, KIN, 'a')
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert outcome.success, outcome.message
    arriving = stage_times(world, 'arriving')  # FINE while the coarse motion runs on
    descent = stage_times(world, 'descending')
    mouth = stage_times(world, 'settling')
    screw = stage_times(world, 'screwing')
    assert arriving and descent and mouth and screw
    # the motion ends, its last step still moving; the next ticks are still: down at once
    assert descent[0] - arriving[-1] <= 3 * DT + 1e-9 < 0.1 * parameters.settle_time
    at_mouth = min(t for t in mouth if t > descent[0])
    waited = screw[0] - at_mouth  # still from the first tick at the mouth (ideal tracking)
    assert parameters.mouth_settle_time - 1e-9 <= waited < parameters.settle_time


def test_an_aligned_tip_still_moving_is_not_lowered():
    """Over the hole but a joint faster than ``settle_velocity``: no descent until it slows."""
    world = World()
    step = possible_steps(TRUSS, world.stance)[0]
    world.run_step(step, max_time=0.0)  # unscrewing
    while world.sequencer.phase != Phase.FINE:
        world.advance()
    while world.motion is not None:  # the coarse motion runs on to its end
        world.advance()
    assert world.sequencer.stage == 'settling'
    sequencer = world.sequencer
    theta = world.targets.above_to
    fast = np.array([0.0, 1.5 * SUPERVISOR.settle_velocity, 0.0, 0.0, 0.0])
    for k in range(20):
        assert sequencer.tick(world.now + k * DT, theta, fast, dict(world.grippers)) == []
    commands = sequencer.tick(world.now + 20 * DT, theta, np.zeros(5), dict(world.grippers))
    assert [c.purpose for c in commands if isinstance(c, TrajectoryRequest)] == ['insertion']
    assert sequencer.phase == Phase.INSERTION


def test_a_tip_still_closing_inside_the_descent_region_descends_at_once():
    """Joint 1 coming in behind its filter: the descent starts inside ``descent_region``.

    The joints are faster than ``settle_velocity`` and the tip farther than
    ``insertion_alignment``, as when the sweep's setpoints have ended and joint 1's filtered
    reference is still arriving; closing on the point, the tip starts down at the first tick
    inside the region, and not before.
    """
    world = World(coarse_miss=0.004)  # 3.6 mm short at 0.9 m
    sequencer = settling_above_the_hole(world)
    parameters = sequencer.parameters
    errors = [4.0e-3, 3.0e-3, 2.4e-3, 1.6e-3, 1.0e-3]  # [m], 20 ms apart
    moving = np.array([0.04, 0.0, 0.0, 0.0, 0.0])  # [rad/s] twice settle_velocity
    assert moving[0] > parameters.settle_velocity
    started = None
    for k, theta in enumerate(joint1_short_by(world, errors)):
        commands = sequencer.tick(world.now + k * DT, theta, moving, dict(world.grippers))
        if any(isinstance(c, TrajectoryRequest) for c in commands):
            started = k
            break
    assert started is not None
    assert errors[started] <= parameters.descent_region < errors[started - 1]
    assert errors[started] > parameters.insertion_alignment
    assert sequencer.phase == Phase.INSERTION


def test_a_tip_swinging_through_or_at_rest_off_the_point_is_not_lowered():
    """Through the point faster than it closes, or away, or still: not lowered.

    Outside ``insertion_alignment`` at rest it settles and gets a correction line, as a tip
    that stopped short always has.
    """
    world = World(coarse_miss=0.004)  # 3.6 mm short at 0.9 m
    sequencer = settling_above_the_hole(world)
    parameters = sequencer.parameters
    inside = 0.5 * (parameters.descent_region + parameters.insertion_alignment)
    # [m] 20 ms apart: in by more than what remains each tick, through, out again, then still
    errors = [1.5 * parameters.descent_region, 0.3 * parameters.descent_region, 0.0,
              0.6 * inside, inside, inside]
    moving = np.array([0.2, 0.0, 0.0, 0.0, 0.0])
    for k, theta in enumerate(joint1_short_by(world, errors)):
        velocities = moving if k < 5 else np.zeros(5)
        commands = sequencer.tick(world.now + k * DT, theta, velocities, dict(world.grippers))
        assert not any(isinstance(c, TrajectoryRequest) for c in commands), k
    assert sequencer.phase == Phase.FINE
    at_rest = joint1_short_by(world, [inside])[0]
    requests = []
    for k in range(int(round(parameters.settle_time / DT)) + 2):
        requests += [c for c in sequencer.tick(world.now + (len(errors) + k) * DT, at_rest,
                                               np.zeros(5), dict(world.grippers))
                     if isinstance(c, TrajectoryRequest)]
    assert [c.purpose for c in requests] == ['fine']  # a correction line, not the descent


def test_a_tip_swinging_through_between_two_ticks_close_together_is_not_lowered():
    """Ticks late and then bunched up (a real-time supervisor): the speed, not the tick, counts.

    2 ms apart the tip comes 1 mm closer with 1.5 mm to go, which the change of its error
    between the ticks took for closing slowly; its joints say it moves at 0.45 m/s, through
    the point. It is not lowered; coming in at the same place slowly, it is.
    """
    world = World(coarse_miss=0.004)
    sequencer = settling_above_the_hole(world)
    far, near = joint1_short_by(world, [2.5e-3, 1.5e-3])
    swinging = np.array([0.5, 0.0, 0.0, 0.0, 0.0])  # [rad/s] joint 1, towards the point
    for k, theta in enumerate((far, near)):
        commands = sequencer.tick(world.now + k * 0.002, theta, swinging, dict(world.grippers))
        assert not any(isinstance(c, TrajectoryRequest) for c in commands), k
    assert sequencer.phase == Phase.FINE
    coming_in = np.array([0.02, 0.0, 0.0, 0.0, 0.0])  # [rad/s] about 18 mm/s of tip
    commands = sequencer.tick(world.now + 0.004, near, coming_in, dict(world.grippers))
    assert [c.purpose for c in commands if isinstance(c, TrajectoryRequest)] == ['insertion']


def test_a_tip_moving_away_inside_the_descent_region_is_not_lowered():
    world = World(coarse_miss=0.004)
    sequencer = settling_above_the_hole(world)
    (near,) = joint1_short_by(world, [1.5e-3])
    leaving = np.array([-0.02, 0.0, 0.0, 0.0, 0.0])  # [rad/s] joint 1, away from the point
    for k in range(3):
        commands = sequencer.tick(world.now + k * DT, near, leaving, dict(world.grippers))
        assert not any(isinstance(c, TrajectoryRequest) for c in commands), k
    assert sequencer.phase == Phase.FINE
