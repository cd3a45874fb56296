"""Teleoperation rules: every refusal, the limits, the base, the tip frame."""

import dataclasses
import math

import numpy as np
import pytest

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES, joint_of_role, roles_to_physical
from walker_core.kinematics import WalkerKinematics
from walker_core.parameter_schema import ParameterError, load_parameter_file, section_from_flat
from walker_core.robot_parameters import default_parameter_file, load_walker_parameters
from walker_supervisor.core.phases import Phase
from walker_supervisor.core.teleop import (
    SettleDetector, Situation, TeleopParameters, TeleopRefusedError, TeleopRules, busy_reason,
    tip_heading)

PARAMS = load_walker_parameters()
KIN = WalkerKinematics.from_parameters(PARAMS)
TELEOP = section_from_flat(TeleopParameters, load_parameter_file(default_parameter_file()),
                           'teleop.')
RULES = TeleopRules.from_parameters(TELEOP, PARAMS)
TOLERANCE = PARAMS.gripper.insertion_position_tolerance
SPACING = PARAMS.truss.spacing
#: Joint angles J1..J5 with the free gripper in the neighbouring node's hole, and lifted.
IN_HOLE = KIN.inverse([0.0, SPACING, 0.0, 0.0, 0.0])
LIFTED = KIN.inverse([0.0, SPACING, 0.05, 0.0, 0.0])


def situation(roles=LIFTED, base='a', a='attached', b='free', activity=''):
    states = {'a': a, 'b': b}
    nodes = {g: ('n1_1' if g == 'a' else 'n2_1') if s in ('attached', 'jammed') else ''
             for g, s in states.items()}
    positions = None if roles is None else roles_to_physical(np.asarray(roles), base)
    return Situation(activity, states, nodes, base, positions)


def refused(match, call, *args):
    with pytest.raises(TeleopRefusedError, match=match):
        call(*args)


# ---------------------------------------------------------------------------- parameters
def test_the_file_gives_valid_teleop_limits():
    assert TELEOP.joint_speed <= TELEOP.max_joint_speed
    assert TELEOP.tip_speed <= TELEOP.max_tip_speed
    assert TELEOP.clearance > TOLERANCE


@pytest.mark.parametrize('field, value, match', [
    ('joint_speed', 0.6, r'teleop\.joint_speed .* must not exceed teleop\.max_joint_speed'),
    ('tip_speed', 0.06, r'teleop\.tip_speed .* must not exceed teleop\.max_tip_speed'),
])
def test_a_default_speed_above_its_limit_is_refused(field, value, match):
    with pytest.raises(ParameterError, match=match):
        dataclasses.replace(TELEOP, **{field: value})


# ---------------------------------------------------------------------------- when
@pytest.mark.parametrize('walk, phase, operation, match', [
    ('n4_3', Phase.IDLE, '', 'a walk or step to n4_3 is under way: cancel it first'),
    (None, Phase.COARSE, '', r'a step is under way \(phase COARSE\)'),
    (None, Phase.EXTRACTION, '', 'phase EXTRACTION'),
    (None, Phase.IDLE, 'jog of vertex_joint', r'another command is under way \(jog of vertex'),
])
def test_nothing_starts_while_something_else_is_under_way(walk, phase, operation, match):
    reason = busy_reason(walk, phase, operation)
    assert reason
    refused(match, RULES.joint_jog, situation(activity=reason), 'b_yaw_joint', 0.1, 0.0)
    refused(match, RULES.tip_jog, situation(activity=reason), [0.0, 0.0, 0.01], 0.0)
    refused(match, RULES.gripper_operation,
            situation(activity=reason, b='attached'), 'b', 'unscrew')


@pytest.mark.parametrize('phase', [Phase.IDLE, Phase.SAFE_HOLD])
def test_commands_are_allowed_when_idle_or_in_safe_hold(phase):
    assert busy_reason(None, phase, '') == ''


def test_a_jog_with_both_grippers_attached_is_refused():
    both = situation(IN_HOLE, b='attached')
    refused('both grippers are screwed in: unscrew one first', RULES.joint_jog, both,
            'b_yaw_joint', 0.1, 0.0)
    refused('both grippers are screwed in: unscrew one first', RULES.tip_jog, both,
            [0.0, 0.0, 0.01], 0.0)


@pytest.mark.parametrize('state, match', [
    ('unscrewing', 'gripper b is unscrewing: wait until it is free'),
    ('screwing', 'gripper b is screwing: wait until it is attached'),
])
def test_no_command_while_a_gripper_screws(state, match):
    s = situation(b=state)
    refused(match, RULES.joint_jog, s, 'b_yaw_joint', 0.1, 0.0)
    refused(match, RULES.gripper_operation, s, 'a', 'unscrew')
    refused(match, RULES.gripper_operation, s, 'b', 'screw_in')


def test_commands_need_the_measurements():
    no_grippers = Situation('', {}, {}, 'a', roles_to_physical(LIFTED, 'a'))
    refused('no gripper states received', RULES.joint_jog, no_grippers, 'b_yaw_joint', 0.1, 0.0)
    refused('no gripper states received', RULES.gripper_operation, no_grippers, 'b', 'unscrew')
    refused('no joint states received', RULES.joint_jog, situation(None), 'b_yaw_joint', 0.1,
            0.0)


# ---------------------------------------------------------------------------- the base
@pytest.mark.parametrize('attached', ['a', 'b'])
def test_the_attached_gripper_is_the_base_of_a_jog(attached):
    free = 'b' if attached == 'a' else 'a'
    # the supervisor's base may lag (e.g. a restarted node): the jog's base is the attached one
    s = situation(LIFTED, base=attached, **{attached: 'attached', free: 'free'})
    s = dataclasses.replace(s, base_gripper=free)
    jog = RULES.joint_jog(s, f'{free}_yaw_joint', 0.1, 0.0)
    assert jog.base_gripper == attached
    assert jog.goal[4] - jog.start[4] == pytest.approx(0.1)  # the free yaw is J5
    assert np.count_nonzero(jog.goal - jog.start) == 1
    tip = RULES.tip_jog(s, [0.0, 0.0, 0.01], 0.0)
    assert (tip.base_gripper, tip.free_gripper) == (attached, free)


# ---------------------------------------------------------------------------- joint jogs
@pytest.mark.parametrize('joint, delta, speed, match', [
    ('elbow_joint', 0.1, 0.0, "unknown joint 'elbow_joint': the joints are a_yaw_joint"),
    ('b_yaw_joint', math.nan, 0.0, 'delta must be a finite number, got nan rad'),
    ('b_yaw_joint', math.inf, 0.0, 'delta must be a finite number'),
    ('b_yaw_joint', 0.0, 0.0, 'delta is 0 rad: there is nothing to move'),
    ('b_yaw_joint', 0.25, 0.0, r'larger than a jog may be \(teleop.max_joint_jog = 0.2 rad\)'),
    ('b_yaw_joint', -0.25, 0.0, 'larger than a jog may be'),
    ('b_yaw_joint', 0.1, -0.1, 'max_velocity must not be negative'),
    ('b_yaw_joint', 0.1, math.nan, 'max_velocity must be a finite number'),
    ('b_yaw_joint', 0.1, 0.6, r'above teleop.max_joint_speed = 0.5 rad/s'),
])
def test_a_bad_joint_jog_is_refused_by_name(joint, delta, speed, match):
    refused(match, RULES.joint_jog, situation(), joint, delta, speed)


def test_a_joint_jog_above_the_joint_velocity_limit_is_refused():
    rules = TeleopRules(dataclasses.replace(TELEOP, max_joint_speed=1.5), KIN,
                        [1.5, 1.5, 1.5, 1.0, 1.0], TOLERANCE)
    refused(r'above the velocity limit of b_yaw_joint \(1 rad/s\)', rules.joint_jog,
            situation(), 'b_yaw_joint', 0.1, 1.2)
    assert rules.joint_jog(situation(), 'b_yaw_joint', 0.1, 1.0).speed == 1.0


def test_a_joint_jog_past_the_joint_limit_is_refused():
    upper = KIN.upper[4]
    near_limit = LIFTED.copy()
    near_limit[4] = upper - 0.05
    refused(rf'b_yaw_joint would reach {upper + 0.05:.4f} rad, outside its limits '
            rf'\[-{upper:g}, {upper:g}\] rad', RULES.joint_jog, situation(near_limit),
            'b_yaw_joint', 0.1, 0.0)
    jog = RULES.joint_jog(situation(near_limit), 'b_yaw_joint', 0.05, 0.0)
    assert jog.target == pytest.approx(upper)


def test_a_joint_jog_takes_the_default_speed_and_names_its_target():
    jog = RULES.joint_jog(situation(), 'vertex_joint', -0.1, 0.0)
    assert jog.speed == TELEOP.joint_speed
    assert jog.target == pytest.approx(LIFTED[2] - 0.1)
    assert jog.describe() == 'jog of vertex_joint by -0.1000 rad'


def test_a_joint_jog_into_the_truss_is_refused():
    # J2 tilting the arm forward lowers the free gripper 50 mm above the surface into it
    refused(r'moving a_pitch_joint by \+0.2000 rad would take gripper b [0-9.]+ mm below the '
            r'truss surface', RULES.joint_jog, situation(), 'a_pitch_joint', 0.2, 0.0)


def test_a_joint_jog_that_drags_a_gripper_in_its_hole_sideways_is_refused():
    refused(r'would move gripper b [0-9.]+ mm sideways while it is [-0-9.]+ mm above the truss '
            r'surface: it must be at least teleop.clearance = 10 mm above it',
            RULES.joint_jog, situation(IN_HOLE), 'a_yaw_joint', 0.1, 0.0)
    # turning the free gripper about its own axis does not move its contact point: allowed
    assert RULES.joint_jog(situation(IN_HOLE), 'b_yaw_joint', 0.1, 0.0).joint_name == \
        'b_yaw_joint'


# ---------------------------------------------------------------------------- tip jogs
@pytest.mark.parametrize('delta, speed, match', [
    ([0.0, 0.01], 0.0, r'delta must have 3 values \(x, y, z in m\)'),
    ([0.0, math.nan, 0.01], 0.0, 'delta must be a finite number, got nan m'),
    ([0.0, 0.0, 0.0], 0.0, r'delta is \(0, 0, 0\) m: there is nothing to move'),
    ([0.0, 0.08, 0.08], 0.0, r'113.1 mm long, longer than a jog may be \(teleop.max_tip_jog '
                             r'= 100 mm\)'),
    ([0.0, 0.0, 0.01], -0.01, 'max_velocity must not be negative'),
    ([0.0, 0.0, 0.01], 0.06, r'above teleop.max_tip_speed = 0.05 m/s'),
])
def test_a_bad_tip_jog_is_refused_by_name(delta, speed, match):
    refused(match, RULES.tip_jog, situation(), delta, speed)


def test_a_tip_jog_below_the_truss_surface_is_refused():
    refused(r'the jog would take gripper b 5.0 mm below the truss surface', RULES.tip_jog,
            situation(IN_HOLE), [0.0, 0.0, -0.005], 0.0)
    # down to the mouth of the hole (within its tolerance) is allowed
    jog = RULES.tip_jog(situation(LIFTED), [0.0, 0.0, -0.05 - 0.5 * TOLERANCE], 0.0)
    assert jog.goal_point[2] == pytest.approx(-0.5 * TOLERANCE)


def test_a_gripper_leaves_its_hole_straight_up_before_it_moves_sideways():
    refused(r'would move gripper b [0-9.]+ mm sideways while it is [0-9.]+ mm above the truss '
            r'surface: .* lift it straight up first', RULES.tip_jog, situation(IN_HOLE),
            [0.01, 0.0, 0.02], 0.0)
    up = RULES.tip_jog(situation(IN_HOLE), [0.0, 0.0, 0.02], 0.0)
    np.testing.assert_allclose(up.goal_point - up.start_point, [0.0, 0.0, 0.02], atol=1e-12)
    # a correction within the hole's tolerance is allowed at any height
    RULES.tip_jog(situation(IN_HOLE), [0.5 * TOLERANCE, 0.0, 0.0], 0.0)


#: Where a fault once left the free gripper (mode commands that moved the arm with its chain
#: open): 13.1 mm off its hole, 4.1 mm below the truss surface, tilted 2.1 deg.
SUNK = KIN.inverse([0.0131, SPACING, -0.0041, 0.0367, 0.0])
SUNK_LEVEL = KIN.inverse([0.0131, SPACING, -0.0041, 0.0, 0.0])


def test_a_gripper_below_the_surface_is_brought_out_by_jogs_that_lift_it():
    lift = RULES.joint_jog(situation(SUNK), 'a_pitch_joint', -0.05, 0.0)
    path = np.linspace(0.0, 1.0, 41)[:, None] * (lift.goal - lift.start) + lift.start
    heights = np.array([KIN.forward(q)[2] for q in path])
    assert heights[0] < -TOLERANCE and heights[-1] > TELEOP.clearance
    assert np.all(np.diff(heights) >= 0.0)
    # turning it about its own axis moves its contact point nowhere: allowed too
    RULES.joint_jog(situation(SUNK), 'b_yaw_joint', 0.1, 0.0)
    # a level gripper rises out of it along its axis
    up = RULES.tip_jog(situation(SUNK_LEVEL), [0.0, 0.0, 0.02], 0.0)
    assert up.goal_point[2] == pytest.approx(0.02 - 0.0041)


@pytest.mark.parametrize('joint, delta, match', [
    ('a_pitch_joint', 0.02, r'would take it down to 22.1 mm below it'),
    ('b_pitch_joint', 0.05, r'would take it down to 4.2 mm below it'),
    ('a_yaw_joint', 0.1, r'would move it 2.3 mm sideways while it rises 0.0 mm'),
])
def test_from_below_the_surface_a_jog_that_sinks_or_drags_sideways_is_refused(joint, delta,
                                                                                match):
    refused(r'gripper b is 4.1 mm below the truss surface and moving ' + joint + '.*' + match
            + r': from below the surface a jog may only move it up, and sideways by no more '
            r'than it rises, until it is teleop.clearance = 10 mm above it',
            RULES.joint_jog, situation(SUNK), joint, delta, 0.0)
    refused(r'4.1 mm below the truss surface and the jog would take it down',
            RULES.tip_jog, situation(SUNK_LEVEL), [0.0, 0.0, -0.001], 0.0)


def test_a_tilted_gripper_must_be_levelled_before_a_tip_jog():
    tilted = LIFTED.copy()
    tilted[3] -= 0.05  # alpha = pi - (th2 + th3 + th4) grows by 0.05
    refused(r'gripper b is tilted \+0.0500 rad from vertical .* level it first with '
            r'jog_joint b_pitch_joint by \+0.0500 rad', RULES.tip_jog, situation(tilted),
            [0.0, 0.0, 0.01], 0.0)
    tilted_b = situation(tilted, base='b', a='free', b='attached')
    refused(rf'jog_joint {joint_of_role(4, "b")} by', RULES.tip_jog, tilted_b,
            [0.0, 0.0, 0.01], 0.0)


def test_a_tip_jog_out_of_reach_is_refused():
    stretched = KIN.inverse([0.0, 1.15, 0.05, 0.0, 0.0])
    refused(r'the line leaves the reachable workspace \d+% of the way, at .* out of reach',
            RULES.tip_jog, situation(stretched), [0.0, -0.1, 0.0], 0.0)


@pytest.mark.parametrize('base', ['a', 'b'])
@pytest.mark.parametrize('yaw1, yaw5', [(0.0, 0.0), (0.7, -0.4), (-2.0, 1.3)])
def test_the_tip_frame_is_the_free_gripper_frame(base, yaw1, yaw5):
    roles = KIN.inverse([0.0, SPACING, 0.05, 0.0, 0.0])
    roles[0], roles[4] = yaw1, yaw5
    free = 'b' if base == 'a' else 'a'
    s = situation(roles, base=base, **{base: 'attached', free: 'free'})
    delta = np.array([0.01, -0.02, 0.03])
    jog = RULES.tip_jog(s, delta, 0.0)
    rotation = KIN.forward_transform(roles)[:3, :3]
    np.testing.assert_allclose(rotation[:, 2], [0.0, 0.0, 1.0], atol=1e-12)  # vertical
    np.testing.assert_allclose(jog.goal_point - jog.start_point, rotation @ delta, atol=1e-12)
    np.testing.assert_allclose(jog.start_point, KIN.forward(roles)[:3], atol=1e-12)
    turn = tip_heading(KIN, roles) - (yaw1 - yaw5 + math.pi)
    assert math.remainder(turn, 2 * math.pi) == pytest.approx(0.0, abs=1e-12)


# ---------------------------------------------------------------------------- grippers
@pytest.mark.parametrize('gripper, action, states, match', [
    ('c', 'unscrew', {}, 'unknown gripper \'c\': expected "a" or "b"'),
    ('a', 'loosen', {}, "unknown gripper action 'loosen'"),
    ('a', 'unscrew', {'b': 'free'}, r'gripper a is the only gripper attached \(gripper b is '
                                    r'free\): unscrewing it would let go of the truss'),
    ('a', 'unscrew', {'b': 'jammed'}, 'gripper a is the only gripper attached'),
    ('b', 'unscrew', {'b': 'free'}, r'gripper b is free: only an attached \(or jammed\)'),
    ('a', 'screw_in', {'b': 'free'}, 'gripper a is already attached at n1_1'),
    ('b', 'screw_in', {'b': 'attached'}, 'gripper b is already attached at n2_1'),
])
def test_a_bad_gripper_command_is_refused_by_name(gripper, action, states, match):
    refused(match, RULES.gripper_operation, situation(**states), gripper, action)


@pytest.mark.parametrize('base, gripper, base_after', [
    ('a', 'b', 'a'), ('a', 'a', 'b'), ('b', 'b', 'a'), ('b', 'a', 'b')])
def test_unscrewing_the_base_makes_the_other_gripper_the_base(base, gripper, base_after):
    operation = RULES.gripper_operation(situation(IN_HOLE, base=base, b='attached'), gripper,
                                        'unscrew')
    assert (operation.base_after, operation.expected) == (base_after, ('free',))


@pytest.mark.parametrize('state', ['free', 'jammed'])
def test_a_free_or_jammed_gripper_may_be_screwed_in_the_attached_one_stays_base(state):
    operation = RULES.gripper_operation(situation(base='b', b=state), 'b', 'screw_in')
    assert (operation.base_after, operation.expected) == ('a', ('attached',))


def test_a_jammed_gripper_can_always_be_backed_out():
    operation = RULES.gripper_operation(situation(b='jammed'), 'b', 'unscrew')
    assert operation.expected == ('free',) and operation.base_after == 'a'


def test_every_physical_joint_can_be_jogged_when_the_path_allows():
    lifted_more = KIN.inverse([0.0, SPACING, 0.1, 0.0, 0.0])
    for joint in PHYSICAL_JOINT_NAMES:
        delta = -0.02 if joint in ('a_pitch_joint', 'b_pitch_joint') else 0.02
        assert RULES.joint_jog(situation(lifted_more), joint, delta, 0.0).joint_name == joint


# ---------------------------------------------------------------------------- settling
def test_the_joints_settle_after_staying_still_long_enough():
    detector = SettleDetector(velocity=0.02, duration=1.0)
    assert not detector.update(0.0, [0.0] * 5)
    assert not detector.update(0.9, [0.0] * 5)
    assert not detector.update(1.0, [0.0, 0.0, 0.03, 0.0, 0.0])  # moving again: start over
    assert not detector.update(1.5, [0.01] * 5)
    assert detector.update(2.5, [-0.01] * 5)


# ---------------------------------------------------------------------------- corrections
def test_a_correction_leads_every_joint_back_to_the_goal_of_the_jog():
    jog = RULES.tip_jog(situation(LIFTED), [0.02, 0.0, 0.0], 0.0)
    np.testing.assert_allclose(KIN.forward(jog.goal)[:3], jog.goal_point, atol=1e-9)
    assert KIN.forward(jog.goal)[3] == pytest.approx(0.0, abs=1e-9)  # vertical
    settled = jog.goal.copy()
    settled[0] += 0.002  # J1 stopped 2 mrad off
    settled[3] -= 0.02  # J4 stopped short: the gripper is tilted
    correction = RULES.correction(roles_to_physical(settled, 'a'), jog)
    np.testing.assert_allclose(correction.start, settled)
    np.testing.assert_allclose(correction.goal, jog.goal)
    assert correction.speed == TELEOP.joint_speed
    joint = RULES.joint_jog(situation(), 'vertex_joint', -0.1, 0.0)
    assert np.array_equal(RULES.correction(roles_to_physical(LIFTED, 'a'), joint).goal,
                          joint.goal)


def test_the_miss_of_a_jog_is_the_farthest_joint_and_the_tip_distance():
    jog = RULES.tip_jog(situation(LIFTED), [0.02, 0.0, 0.0], 0.0)
    assert RULES.joint_miss(roles_to_physical(jog.goal, 'a'), jog) == 0.0
    assert RULES.tip_miss(roles_to_physical(jog.goal, 'a'), jog) == pytest.approx(0.0, abs=1e-12)
    settled = jog.goal.copy()
    settled[1] += 0.003
    settled[4] -= 0.004
    physical = roles_to_physical(settled, 'a')
    assert RULES.joint_miss(physical, jog) == pytest.approx(0.004)
    expected = np.linalg.norm(KIN.forward(settled)[:3] - jog.goal_point)
    assert RULES.tip_miss(physical, jog) == pytest.approx(expected) and expected > 1e-4


def test_a_correction_into_the_truss_is_refused():
    jog = RULES.tip_jog(situation(LIFTED), [0.0, 0.0, -0.05], 0.0)
    beside = KIN.inverse([0.0, SPACING - 0.02, 0.0, 0.0, 0.0], reference=LIFTED)
    refused(r'the correction would move gripper b', RULES.correction,
            roles_to_physical(beside, 'a'), jog)
