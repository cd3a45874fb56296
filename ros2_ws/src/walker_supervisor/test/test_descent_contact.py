"""Feeling the node's face from the joints: contact at the end of a descent to past the mouth."""

import dataclasses
import math

import numpy as np
import pytest

from walker_supervisor.core import insertion, transitions
from walker_supervisor.core.descent_contact import (
    CONTACT_DWELL, CONTACT_SPEED, SHORT_OF_THE_END, DescentContact)
from walker_supervisor.core.commands import CancelTrajectory, Notice, TrajectoryRequest
from walker_supervisor.core.phases import Stage
from walker_supervisor.core.step_run import StepRun

from sequencer_world import KIN, SUPERVISOR, TRUSS, START
from walker_supervisor.core.route import possible_steps
from walker_supervisor.core.step_geometry import BaseFrame, plan_step_targets

MOUTH = 0.0
OVERTRAVEL = 0.002
TICK = 0.02


def descend(contact, heights):
    """Feed tip heights one decision tick apart; return the tick at which contact was felt."""
    for tick, height in enumerate(heights):
        if contact.update(tick * TICK, height):
            return tick
    return None


def stopped_at(face, speed=0.02, ticks=120, start=0.03):
    """Return the heights of a tip going down at ``speed`` [m/s] until a face stops it."""
    return [max(face, start - speed * TICK * k) for k in range(ticks)]


@pytest.mark.parametrize('face', [-0.0015, 0.0, 0.0015])
def test_a_tip_stopped_by_the_face_is_felt_where_the_face_is(face):
    contact = DescentContact(MOUTH, MOUTH - OVERTRAVEL)
    tick = descend(contact, stopped_at(face))
    assert tick is not None and contact.felt
    assert contact.face_offset == pytest.approx(face - MOUTH)
    # felt once it has been still for the dwell, not before
    arrived = next(k for k, h in enumerate(stopped_at(face)) if h == face)
    assert (tick - arrived) * TICK >= CONTACT_DWELL


def test_a_tip_still_above_the_highest_face_is_no_contact():
    contact = DescentContact(MOUTH, MOUTH - OVERTRAVEL)
    assert descend(contact, [0.01] * 20) is None and not contact.felt


def test_a_tip_still_going_down_is_no_contact():
    contact = DescentContact(MOUTH, MOUTH - OVERTRAVEL)
    slow = 2.0 * CONTACT_SPEED
    assert descend(contact, [0.002 - slow * TICK * k for k in range(20)]) is None


def test_a_descent_judged_at_rest_short_of_its_end_met_the_face():
    stopped = DescentContact(MOUTH, MOUTH - OVERTRAVEL)
    assert stopped.at_rest(MOUTH - 0.001) and stopped.face_offset == pytest.approx(-0.001)
    free = DescentContact(MOUTH, MOUTH - OVERTRAVEL)
    assert not free.at_rest(MOUTH - OVERTRAVEL + 0.5 * SHORT_OF_THE_END)
    assert math.isnan(free.face_offset)


def run_at_insertion(overtravel):
    settings = dataclasses.replace(SUPERVISOR, insertion_overtravel=overtravel)
    run = StepRun(settings, KIN, 'a', 0.5)
    step = possible_steps(TRUSS, START)[0]
    theta = np.array(KIN.inverse([0.0, TRUSS.spacing, 0.0, 0.0, 0.0]))
    frame = BaseFrame.from_stance(KIN, theta, TRUSS.position(step.base_node),
                                  TRUSS.position(step.from_node))
    run.step = step
    run.targets = plan_step_targets(KIN, frame, step, TRUSS.position(step.from_node),
                                    TRUSS.position(step.to_node), theta, 0.03)
    return run


def test_the_descent_is_commanded_the_overtravel_past_the_mouth_on_the_hole_axis():
    run = run_at_insertion(OVERTRAVEL)
    request = transitions.descent_request(run)
    mouth = run.targets.point_to
    np.testing.assert_allclose(request.goal_point, mouth - [0.0, 0.0, OVERTRAVEL], atol=1e-12)
    np.testing.assert_allclose(KIN.forward(request.goal)[:3], request.goal_point, atol=1e-9)
    assert request.goal[4] == pytest.approx(run.targets.at_to[4])  # the same tip yaw


def test_no_overtravel_descends_to_the_nominal_mouth_as_before():
    run = run_at_insertion(0.0)
    request = transitions.descent_request(run)
    np.testing.assert_array_equal(request.goal, run.targets.at_to)
    np.testing.assert_array_equal(request.goal_point, run.targets.point_to)


def stream_down_to_the_face(run, face):
    """Stream a descent down the axis to a face ``face`` [m] off the mouth; return the commands."""
    mouth = run.targets.point_to
    said = []
    for tick, height in enumerate(stopped_at(face, start=0.01, ticks=60)):
        point = np.array([mouth[0], mouth[1], mouth[2] + height])
        run.theta = np.array(KIN.inverse([*point, 0.0, run.targets.at_to[4]],
                                         reference=run.targets.at_to))
        said += insertion.feel_the_face(run, tick * TICK)
    return said


def test_a_descent_stopped_by_the_face_says_where_once_and_stops_pressing_on_the_axis():
    run = run_at_insertion(OVERTRAVEL)
    transitions.enter_insertion(run, 0.0)
    run.motions.running = True
    mouth = run.targets.point_to
    notice, cancel, line = stream_down_to_the_face(run, -0.001)
    assert notice.message == "the descent met the node's face 1.00 mm below the nominal mouth"
    assert isinstance(cancel, CancelTrajectory)
    # the rest of the descent (2 mm deeper) would push the tip sideways: a line to a light
    # press below the contact, on the hole's axis, replaces it
    assert line.purpose == 'insertion'
    np.testing.assert_allclose(line.goal_point[:2], mouth[:2], atol=1e-12)
    assert line.goal_point[2] == pytest.approx(mouth[2] - 0.001 - insertion.MOUTH_PRESS,
                                               abs=1e-6)
    np.testing.assert_allclose(KIN.forward(line.goal)[:3], line.goal_point, atol=1e-9)


def test_a_face_felt_once_the_descent_has_ended_is_pressed_lightly_before_the_tip_is_judged():
    run = run_at_insertion(OVERTRAVEL)
    transitions.enter_insertion(run, 0.0)
    run.stage = Stage.SETTLING  # the descent's stream ended above the face
    mouth = run.targets.point_to
    said = []
    heights = stopped_at(0.0, start=0.004, ticks=60)
    for tick, height in enumerate(heights):
        moving = tick == 0 or height != heights[tick - 1]
        velocities = np.full(5, 1.0 if moving else 0.0)
        point = np.array([mouth[0], mouth[1], mouth[2] + height])
        run.theta = np.array(KIN.inverse([*point, 0.0, run.targets.at_to[4]],
                                         reference=run.targets.at_to))
        said += insertion.at_mouth(run, tick * TICK, velocities,
                                   {'a': 'attached', 'b': 'free'})
        if said:
            break
    assert [type(command) for command in said] == [Notice, TrajectoryRequest]
    # judged once the joints were still for the mouth's settling time, where the face held it
    assert said[0].message == "the descent met the node's face at the nominal mouth"
    assert tick * TICK >= 10 * TICK + SUPERVISOR.mouth_settle_time - 1e-9
    assert run.stage == Stage.DESCENDING  # its end is waited for, then the tip is judged
    assert said[1].goal_point[2] == pytest.approx(mouth[2] - insertion.MOUTH_PRESS, abs=1e-6)


def test_without_overtravel_the_face_is_only_said():
    run = run_at_insertion(0.0)
    transitions.enter_insertion(run, 0.0)
    run.motions.running = True
    said = stream_down_to_the_face(run, -0.0002)
    assert [type(command) for command in said] == [Notice]


def test_a_tip_resting_on_the_face_beside_the_hole_is_aligned_onto_the_axis():
    """A tip resting 3 mm off the axis is pressed where it is, then lined up onto the axis.

    3 mm off the axis (past ``descent_region``, within ``descent_axis_tolerance``), the
    press goes straight down where the tip is, and the line at the mouth onto the axis.
    """
    run = run_at_insertion(OVERTRAVEL)
    transitions.enter_insertion(run, 0.0)
    mouth = run.targets.point_to
    beside = 0.003
    assert SUPERVISOR.descent_region < beside < SUPERVISOR.descent_axis_tolerance
    rest = mouth + np.array([beside, 0.0, 0.003])  # on the face: the screw's length up
    run.theta = np.array(KIN.inverse([*rest, 0.0, run.targets.at_to[4]],
                                     reference=run.targets.at_to))
    assert run.tries.contact.at_rest(float(rest[2]))
    _, press = insertion._on_the_face(run, run.tries.contact)
    np.testing.assert_allclose(press[:2], rest[:2], atol=1e-9)
    line = insertion._align(run)[0]
    assert line.purpose == 'fine' and run.stage == Stage.ALIGNING
    np.testing.assert_allclose(line.goal_point[:2], mouth[:2], atol=1e-12)
    assert line.goal_point[2] == pytest.approx(rest[2] - insertion.MOUTH_PRESS, abs=1e-9)
    np.testing.assert_allclose(KIN.forward(line.goal)[:3], line.goal_point, atol=1e-9)


def test_a_descent_the_joints_did_not_follow_holds_and_teaches_the_map_nothing():
    """A trajectory lost after a restart: the tip at rest 30 mm above the mouth, not a face."""
    run = run_at_insertion(OVERTRAVEL)
    transitions.enter_insertion(run, 0.0)
    run.stage = Stage.SETTLING  # the descent's stream ended; the joints never moved
    above = run.targets.point_above_to  # where the descent began
    run.theta = np.array(KIN.inverse([*above, 0.0, run.targets.at_to[4]],
                                     reference=run.targets.at_to))
    said = []
    for tick in range(200):
        said += insertion.at_mouth(run, tick * TICK, np.zeros(5), {'a': 'attached', 'b': 'free'})
        if said:
            break
    assert run.phase.name == 'SAFE_HOLD'
    height = (run.targets.point_above_to[2] - run.targets.point_to[2]) * 1e3
    assert 'did not follow' in run.reason \
        and f'{height:.1f} mm above the nominal mouth' in run.reason
    assert not run.tries.contact.felt and run.felt_faces == []
    assert not any(isinstance(command, TrajectoryRequest) for command in said)


def searching_run():
    from walker_supervisor.core.hole_search import HoleSearch, SearchPattern

    run = run_at_insertion(OVERTRAVEL)
    run.search = HoleSearch(SearchPattern.around(0.0015, 0.002, 3.0, 0.0075))
    transitions.enter_insertion(run, 0.0)
    run.theta = run.targets.at_to.copy()  # at the end of the descent
    return run


def test_a_jam_after_a_descent_that_met_no_face_sends_the_next_probes_deeper():
    """The estimate 5 mm high: the descent ends on nothing, and so would every probe's."""
    run = searching_run()
    mouth = float(run.targets.point_to[2])
    run.tries.contact.judged = True  # judged at rest at its end: no face
    said = insertion.jammed(run, 'the screw-in jammed', 1.0)
    assert run.height_shift == pytest.approx(-OVERTRAVEL)
    assert any('met no face' in n.message for n in said if isinstance(n, Notice))
    # the next probe's descent ends the overtravel deeper than the first
    assert float(run.targets.point_to[2]) == pytest.approx(mouth - OVERTRAVEL, abs=1e-9)
    for _ in range(2 * insertion.MAX_DEEPER_DESCENTS):  # bounded
        transitions.enter_insertion(run, 2.0)
        run.theta = run.targets.at_to.copy()
        run.tries.contact.judged = True
        insertion.jammed(run, 'the screw-in jammed', 2.0)
    assert run.height_shift == pytest.approx(-insertion.MAX_DEEPER_DESCENTS * OVERTRAVEL)


def test_a_jam_on_the_face_felt_changes_no_depth():
    run = searching_run()
    run.tries.contact.judged = True
    run.tries.contact.height = float(run.targets.point_to[2]) + 0.003  # on the face
    said = insertion.jammed(run, 'the screw-in jammed', 1.0)
    assert run.height_shift == 0.0
    assert not any('met no face' in getattr(n, 'message', '') for n in said)
    assert len(run.felt_faces) == 1  # the map takes that height instead
