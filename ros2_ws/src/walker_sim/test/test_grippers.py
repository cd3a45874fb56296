"""Gripper logic: tolerance, jamming, the release interlock, screw timing, the base gripper."""

import math

import pytest

from walker_core.truss import Truss
from walker_core.gripper_state import GripperState
from walker_sim.core.grippers import (
    GripperCommandError, GripperLogic, HoleAlignment, InterlockError,
    hole_alignment)

TRUSS = Truss(spacing=0.9, columns=5, rows=4)
POSITION_TOLERANCE, AXIS_TOLERANCE, SCREW_TIME = 0.002, 0.035, 0.5


def logic(attached=None, base='a'):
    grippers = GripperLogic(POSITION_TOLERANCE, AXIS_TOLERANCE, SCREW_TIME)
    grippers.reset(attached or {'a': 'n1_1', 'b': 'n2_1'}, base)
    return grippers


def aligned(position_error=0.0, axis_error=0.0):
    return HoleAlignment('n2_1', position_error, axis_error)


@pytest.mark.parametrize('position, axis, node, position_error, axis_error', [
    ((1.8, 0.9, 0.0), (0, 0, 1), 'n2_1', 0.0, 0.0),
    ((1.801, 0.9, 0.0), (0, 0, 1), 'n2_1', 0.001, 0.0),
    ((1.8, 0.9, 0.03), (0, 0, 1), 'n2_1', 0.03, 0.0),    # above the mouth: vertical distance
    ((1.8, 0.9, -0.01), (0, 0, 1), 'n2_1', 0.0, 0.0),    # inside the hole: on its axis
    ((1.8, 0.9, -0.05), (0, 0, 1), 'n2_1', 0.03, 0.0),   # below the bottom of a 20 mm hole
    ((1.8, 0.9, 0.0), (math.sin(0.1), 0, math.cos(0.1)), 'n2_1', 0.0, 0.1),
    ((-5.0, 20.0, 0.0), (0, 0, 1), 'n0_3', math.hypot(5.0, 20.0 - 2.7), 0.0),
])
def test_alignment_is_measured_against_the_nearest_hole(position, axis, node, position_error,
                                                         axis_error):
    alignment = hole_alignment(position, axis, TRUSS, hole_depth=0.02)
    assert alignment.node == node
    assert alignment.position_error == pytest.approx(position_error, abs=1e-12)
    assert alignment.axis_error == pytest.approx(axis_error, abs=1e-12)


def test_screw_in_within_tolerance_screws_then_attaches_after_the_screw_time():
    grippers = logic({'a': 'n1_1'})
    outcome = grippers.request_screw_in('b', aligned(0.9 * POSITION_TOLERANCE,
                                                     0.9 * AXIS_TOLERANCE))
    assert outcome.success and outcome.status.mode == GripperState.SCREWING
    assert grippers.advance(0.5 * SCREW_TIME) == []
    assert grippers.status('b').progress == pytest.approx(0.5)
    changed = grippers.advance(0.5 * SCREW_TIME)
    assert [s.mode for s in changed] == [GripperState.ATTACHED]
    assert grippers.status('b').node == 'n2_1'


@pytest.mark.parametrize('position_error, axis_error, words', [
    (2.5 * POSITION_TOLERANCE, 0.0, 'position error 5.00 mm exceeds the tolerance 2.00 mm'),
    (0.0, 2 * AXIS_TOLERANCE, 'axis error 4.01 deg exceeds the tolerance 2.01 deg'),
])
def test_screw_in_outside_tolerance_jams_and_says_by_how_much(position_error, axis_error,
                                                              words):
    grippers = logic({'a': 'n1_1'})
    outcome = grippers.request_screw_in('b', aligned(position_error, axis_error))
    assert not outcome.success
    assert outcome.status.mode == GripperState.JAMMED
    assert words in outcome.status.message and 'n2_1' in outcome.status.message
    assert not grippers.holds('b')
    # a jammed gripper may retry once aligned
    assert grippers.request_screw_in('b', aligned()).success


def test_releasing_the_only_attached_gripper_is_refused_and_changes_nothing():
    grippers = logic({'a': 'n1_1'})
    with pytest.raises(InterlockError, match='interlock: gripper a holds the walker'):
        grippers.request_unscrew('a')
    assert grippers.status('a').mode == GripperState.ATTACHED
    assert grippers.base == 'a'


def test_release_needs_the_other_gripper_attached_not_merely_screwing():
    grippers = logic({'a': 'n1_1'})
    grippers.request_screw_in('b', aligned())
    with pytest.raises(InterlockError, match='SCREWING'):
        grippers.request_unscrew('a')
    grippers.advance(SCREW_TIME)
    grippers.request_unscrew('a')
    with pytest.raises(InterlockError, match='UNSCREWING'):
        grippers.request_unscrew('b')


def test_the_base_passes_to_the_other_gripper_when_the_base_is_released():
    grippers = logic()
    assert grippers.base == 'a'
    status = grippers.request_unscrew('a')
    assert status.mode == GripperState.UNSCREWING and grippers.base == 'b'
    assert grippers.holds('a')  # still held until the unscrew completes
    changed = grippers.advance(SCREW_TIME)
    assert [(s.name, s.mode) for s in changed] == [('a', GripperState.FREE)]


@pytest.mark.parametrize('base', ['a', 'b'])
def test_the_tip_is_the_gripper_that_moves_or_moves_next_never_the_one_just_screwed_in(base):
    """After a step both are attached: the tip is the gripper the next step releases.

    Not the one that just screwed in, which the supervisor makes its base.
    """
    other = 'b' if base == 'a' else 'a'
    grippers = logic(base=base)
    assert grippers.tip == other  # both attached at the start: the start base's other gripper
    grippers.request_unscrew(base)
    assert grippers.tip == base
    grippers.advance(SCREW_TIME)
    assert grippers.tip == base and grippers.status(base).mode == GripperState.FREE
    grippers.request_screw_in(base, aligned())
    grippers.advance(SCREW_TIME)
    assert grippers.status(base).mode == GripperState.ATTACHED
    assert grippers.tip == other  # idle, both attached: the gripper the next step releases


def test_a_restored_logic_keeps_its_tip():
    grippers = logic()
    timers = {g: (s.mode, s.node, t) for g, (s, t) in grippers.timers().items()}
    grippers.restore(timers, 'a', 'a')
    assert grippers.tip == 'a'
    grippers.restore(timers, 'a')
    assert grippers.tip == 'b'


@pytest.mark.parametrize('mode_setup, command, words', [
    ('attached', 'screw_in', 'needs a free gripper'),
    ('free', 'unscrew', 'only an attached gripper'),
])
def test_commands_in_the_wrong_state_are_refused(mode_setup, command, words):
    grippers = logic({'a': 'n1_1', 'b': 'n2_1'} if mode_setup == 'attached' else {'a': 'n1_1'})
    with pytest.raises(GripperCommandError, match=words):
        if command == 'screw_in':
            grippers.request_screw_in('b', aligned())
        else:
            grippers.request_unscrew('b')


def test_a_fouled_thread_jams_the_next_screw_ins_however_well_aligned_then_clears():
    grippers = logic({'a': 'n1_1'})
    grippers.fouled_screw_ins = 2
    for remaining in (1, 0):
        outcome = grippers.request_screw_in('b', aligned())
        assert not outcome.success and outcome.status.mode == GripperState.JAMMED
        assert 'thread is fouled' in outcome.status.message
        assert f'{remaining} more screw-ins will jam' in outcome.status.message
        assert grippers.fouled_screw_ins == remaining
    outcome = grippers.request_screw_in('b', aligned())  # retried from JAMMED: clear now
    assert outcome.success and outcome.status.mode == GripperState.SCREWING


def test_a_fouled_thread_does_not_count_down_on_a_refused_screw_in():
    grippers = logic()  # both attached: screw-in is refused before the thread is tried
    grippers.fouled_screw_ins = 1
    with pytest.raises(GripperCommandError):
        grippers.request_screw_in('b', aligned())
    assert grippers.fouled_screw_ins == 1


def test_a_jammed_gripper_backs_out_at_once():
    grippers = logic({'a': 'n1_1'})
    grippers.request_screw_in('b', aligned(1.0))
    assert grippers.request_unscrew('b').mode == GripperState.FREE


def test_unknown_grippers_are_named():
    with pytest.raises(ValueError, match="unknown gripper 'c'"):
        logic().status('c')
