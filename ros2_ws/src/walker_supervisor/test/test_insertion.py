"""INSERTION: the descent and its axis, alignment at the mouth, screw-in, jams.

Each test drives the sequencer through a step in ``sequencer_world``'s ideal world.
"""

import dataclasses

import numpy as np
import pytest

from sequencer_world import DT, KIN, SUPERVISOR, TRUSS, World, motion_purposes, stage_times
from walker_supervisor.core.insertion import MAX_MOUTH_LINES, MOUTH_LINE_PROGRESS
from walker_supervisor.core.transitions import MAX_FINE_LINES
from walker_supervisor.core.commands import (
    GripperRequest, Notice, SetControlMode, TrajectoryRequest)
from walker_supervisor.core.phases import Phase
from walker_supervisor.core.route import possible_steps
from walker_supervisor.core.sequencer import StepSequencer


def test_joints_away_from_the_prepared_start_descend_from_where_they_are():
    """A wrist turned another way (a resumed step's way back) is not sent the prepared descent."""
    world = World(coarse_miss=0.004)  # at rest 3.6 mm short: no descent before the tick below
    world.run_step(possible_steps(TRUSS, world.stance)[0], max_time=0.0)  # unscrewing
    while world.sequencer.phase != Phase.FINE:
        world.advance()
    while world.motion is not None:  # the coarse motion runs on to its end
        world.advance()
    turned = world.targets.above_to + np.array([0.0, 0.0, 0.0, 0.0, 1.0])  # J5 a radian off
    commands = world.sequencer.tick(world.now + DT, turned, np.zeros(5), dict(world.grippers))
    descents = [c for c in commands if isinstance(c, TrajectoryRequest)]
    assert [c.purpose for c in descents] == ['insertion']
    np.testing.assert_allclose(descents[0].start, turned)
    np.testing.assert_allclose(descents[0].goal_point, world.targets.point_to)


def test_a_descent_that_leaves_the_axis_is_stopped_lifted_back_and_inserted_again():
    """Joint 1 running 18 mm off as the gripper goes down: stopped before the mouth."""
    world = World(descent_runaway=(0.02, 1))
    offsets = []
    original_tick = world.sequencer.tick

    def tick(*args):
        commands = original_tick(*args)
        if world.sequencer.stage == 'descending':
            offsets.append(world.sequencer.mouth_offset())
        return commands
    world.sequencer.tick = tick
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert outcome.success, outcome.message
    purposes = motion_purposes(world)
    assert purposes[purposes.index('insertion'):] == [
        'insertion', 'cancel', 'retry_lift', 'fine', 'insertion', 'screw_in']
    assert outcome.insertion_attempts == 2  # lifted straight up 5 mm off: a line over the hole
    # stopped within a tick of crossing the tolerance, far from the 18 mm it was heading for
    assert max(offsets) < SUPERVISOR.descent_axis_tolerance + 0.002
    lift = next(c for c in world.log
                if isinstance(c, TrajectoryRequest) and c.purpose == 'retry_lift')
    np.testing.assert_allclose(lift.goal_point[2], world.targets.point_above_to[2])
    assert any(isinstance(c, Notice) and "left the hole's axis" in c.message
               for c in world.log)


def test_a_descent_off_the_axis_before_it_went_down_is_brought_over_the_hole_not_lifted():
    """Fine lines that all stopped 0.025 rad short: the descent is stopped where it began.

    The joints lag the stream's start, so the tip is still at the approach height: there is no
    lift to make (the planner refuses a lift that does not rise), a fine line brings it over
    the hole and the step completes.
    """
    world = World(coarse_miss=0.025, fine_miss=(0.025, MAX_FINE_LINES), start_lag=0.05)
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert outcome.success, outcome.message
    purposes = motion_purposes(world)
    assert purposes[purposes.index('insertion'):] == [
        'insertion', 'cancel', 'fine', 'insertion', 'screw_in']
    assert outcome.insertion_attempts == 2
    assert any(isinstance(c, Notice) and 'before it went down' in c.message for c in world.log)


def test_descents_that_keep_leaving_the_axis_end_in_safe_hold_attached():
    world = World(descent_runaway=(0.02, 99))
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert not outcome.success
    assert "left the hole's axis" in outcome.message
    assert outcome.insertion_attempts == SUPERVISOR.max_insertion_attempts
    assert world.sequencer.phase == Phase.SAFE_HOLD
    assert 'screw_in' not in motion_purposes(world)
    assert world.grippers[world.sequencer.base_gripper] == 'attached'


def test_a_tip_that_settles_off_the_hole_axis_after_the_descent_is_aligned_at_the_mouth():
    world = World(descent_miss=0.0015)  # 1.35 mm off the axis at 0.9 m
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert outcome.success, outcome.message
    purposes = [c.purpose if isinstance(c, TrajectoryRequest) else c.action
                for c in world.log if isinstance(c, (TrajectoryRequest, GripperRequest))]
    assert purposes == ['unscrew', 'extraction', 'coarse', 'insertion', 'fine', 'screw_in']
    line = next(c for c in world.log if isinstance(c, TrajectoryRequest) and c.purpose == 'fine')
    settled_tip = KIN.forward(line.start)[:3]
    assert np.linalg.norm(settled_tip[:2] - line.goal_point[:2]) > SUPERVISOR.insertion_alignment
    np.testing.assert_allclose(line.goal_point, world.targets.point_to)
    np.testing.assert_allclose(line.goal, world.targets.at_to)
    assert world.sequencer.mouth_offset() < 1e-9  # screwed in on the axis


def test_after_a_line_at_the_mouth_the_screw_in_waits_settle_time():
    """A line at the mouth moves joint 1, which may yet come in: the long wait, not the mouth's."""
    parameters = dataclasses.replace(SUPERVISOR, settle_time=0.4, mouth_settle_time=0.05)
    world = World(descent_miss=0.0015)  # 1.35 mm off the axis: one line at the mouth
    world.sequencer = StepSequencer(parameters, KIN, 'a')
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert outcome.success, outcome.message
    descent, aligning = stage_times(world, 'descending'), stage_times(world, 'aligning')
    settling, screw = stage_times(world, 'settling'), stage_times(world, 'screwing')
    after_descent = min(t for t in settling if t > descent[-1])
    after_line = min(t for t in settling if t > aligning[-1])
    # after the descent the short wait, then the line; after the line the long one
    assert parameters.mouth_settle_time - 1e-9 <= aligning[0] - after_descent \
        < parameters.settle_time
    assert screw[0] - after_line >= parameters.settle_time - 1e-9


def _mouth_lines_and_screw_in(world):
    lines = [i for i, c in enumerate(world.log)
             if isinstance(c, TrajectoryRequest) and c.purpose == 'fine']
    screw = next(i for i, c in enumerate(world.log)
                 if isinstance(c, GripperRequest) and c.action == 'screw_in')
    return lines, screw


def test_a_mouth_line_that_does_not_bring_the_tip_nearer_is_the_last():
    """Each line stops as short as the descent: the tip is held where it rests."""
    world = World(descent_miss=0.0015, mouth_lines_miss=True)
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert outcome.success, outcome.message  # the screw-in itself is the final check
    # the error reported is the joints' estimate where it screwed in, off the axis at the mouth
    assert outcome.insertion_error > SUPERVISOR.insertion_alignment
    lines, screw = _mouth_lines_and_screw_in(world)
    assert len(lines) == 1 and screw > lines[-1]


@pytest.mark.parametrize('kept, expected', [(0.7, MAX_MOUTH_LINES), (0.5, 2)])
def test_mouth_lines_that_bring_the_tip_nearer_go_on_a_bounded_number_of_times(kept, expected):
    """Each line stops short by ``kept`` of the last one's miss.

    The descent leaves the tip 2.7 mm off the axis: 0.7 of it is still beyond
    ``insertion_alignment`` after three lines, 0.5 is within it after two.
    """
    world = World(descent_miss=0.003, mouth_lines_miss=kept)
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert outcome.success, outcome.message
    assert kept < MOUTH_LINE_PROGRESS
    lines, screw = _mouth_lines_and_screw_in(world)
    assert len(lines) == expected and screw > lines[-1]


def test_a_jammed_insertion_is_retried():
    world = World(jams=2)
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert outcome.success and outcome.insertion_attempts == 3
    lifts = [c for c in world.log
             if isinstance(c, TrajectoryRequest) and c.purpose == 'retry_lift']
    assert len(lifts) == 2


@pytest.mark.parametrize('jams, attempts', [(2, 3), (5, 3)])
def test_a_jam_seen_in_the_gripper_states_before_its_answer_counts_once(jams, attempts):
    world = World(jams=jams, jam_seen_first=True)
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    lifts = [c for c in world.log
             if isinstance(c, TrajectoryRequest) and c.purpose == 'retry_lift']
    screw_ins = [c for c in world.log if c == GripperRequest('b', 'screw_in')]
    assert len(screw_ins) == attempts and len(lifts) == attempts - 1
    if jams < attempts:
        assert outcome.success and outcome.insertion_attempts == attempts
    else:
        assert not outcome.success and f'jammed {attempts} times' in outcome.message
        assert world.sequencer.phase == Phase.SAFE_HOLD
    assert world.late_answers == []


def test_a_retry_is_not_judged_by_the_last_attempts_jammed_state():
    """A retried screw-in that succeeds is not a second jam while the old state lingers.

    For a while the sequencer still sees the gripper reported jammed (the plant's new state is
    late): that is the last attempt's state, not a second jam.
    """
    world = World(jams=1, jam_seen_first=True, stale_states=0.1, gripper_delay=0.3)
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    screw_ins = [c for c in world.log if c == GripperRequest('b', 'screw_in')]
    assert outcome.success, outcome.message
    assert outcome.insertion_attempts == 2 and len(screw_ins) == 2


def test_too_many_jams_abort_to_safe_hold_with_the_base_attached():
    world = World(jams=5)
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert not outcome.success and 'jammed 3 times' in outcome.message
    assert world.sequencer.phase == Phase.SAFE_HOLD
    assert world.grippers['a'] == 'attached'
    assert world.log[-1] == SetControlMode('hold', 'a')


@pytest.mark.parametrize('off_axis', [0.001, 0.0028])
def test_the_light_press_on_the_face_is_a_line_the_planner_accepts(off_axis):
    """A descent that met the face off the axis presses along a vertical the planner takes.

    The press is planned as a line along the hole's axis (refused beyond the insertion
    tolerance horizontally): near the axis it goes onto it, farther it goes straight down
    where the tip is, and the lines at the mouth bring it over the hole.
    """
    from walker_supervisor.core.descent_contact import DescentContact
    from walker_supervisor.core.insertion import MOUTH_PRESS, _on_the_face
    from walker_supervisor.core.step_run import StepRun

    world = World()
    step = possible_steps(TRUSS, world.stance)[0]
    world.run_step(step)  # the ideal step, for its targets
    run = StepRun(SUPERVISOR, KIN, step.base_gripper, 0.5)
    run.targets = world.targets
    mouth = world.targets.point_to
    resting = mouth + np.array([off_axis, 0.0, 0.0005])
    run.theta = KIN.inverse([*resting, 0.0, world.targets.at_to[4]],
                            reference=world.targets.at_to)
    contact = DescentContact(float(mouth[2]), float(mouth[2]) - 0.002)
    contact.height = float(resting[2])
    joints, point = _on_the_face(run, contact)
    horizontal = np.linalg.norm(point[:2] - resting[:2])
    assert horizontal <= SUPERVISOR.descent_region  # within what the planner accepts
    assert point[2] == pytest.approx(resting[2] - MOUTH_PRESS)
    np.testing.assert_allclose(KIN.forward(joints)[:3], point, atol=1e-9)
    if off_axis <= SUPERVISOR.descent_region:
        np.testing.assert_allclose(point[:2], mouth[:2], atol=1e-12)  # onto the axis
