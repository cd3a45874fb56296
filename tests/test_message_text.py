"""What operators read: no numpy reprs, no doubled texts, no negative zero in any message.

The bad inputs are those a ROS user sent with the plain ``ros2`` CLI: a NaN in a tip jog (the
request's ``float64[3]`` arrives as a numpy array), gripper command 7, and offsets that round
to zero.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from walker_core.joint_roles import roles_to_physical
from walker_core.kinematics import WalkerKinematics
from walker_core.parameter_schema import load_parameter_file, section_from_flat
from walker_core.robot_parameters import default_parameter_file, load_walker_parameters
from walker_core.text import millimetres, number, unknown_choice, value_text
from walker_core.truss import Truss
from walker_supervisor.core.teleop import (
    Situation, TeleopParameters, TeleopRefusedError, TeleopRules)
from walker_teleop.core.status import GripperView, _gripper_line

PARAMS = load_walker_parameters()
KIN = WalkerKinematics.from_parameters(PARAMS)
RULES = TeleopRules.from_parameters(
    section_from_flat(TeleopParameters, load_parameter_file(default_parameter_file()),
                      'teleop.'), PARAMS)
LIFTED = KIN.inverse([0.0, PARAMS.truss.spacing, 0.05, 0.0, 0.0])
#: What no message may contain: a numpy repr, a negative zero.
FORBIDDEN = re.compile(r'np\.|float64\(|(?<![\d.])-0(\.0*)?(?![\d.]*[1-9])')


def free_b() -> Situation:
    return Situation('', {'a': 'attached', 'b': 'free'}, {'a': 'n1_1', 'b': ''}, 'a',
                     roles_to_physical(np.asarray(LIFTED), 'a'))


def clean(text: str) -> str:
    assert not FORBIDDEN.search(text), text
    return text


@pytest.mark.parametrize('delta', [
    np.array([math.nan, 0.0, 0.01]), [np.float64(math.inf), 0.0, 0.0]])
def test_a_non_finite_jog_is_refused_with_the_number_as_a_number(delta):
    with pytest.raises(TeleopRefusedError) as refusal:
        RULES.tip_jog(free_b(), delta, 0.0)
    text = clean(str(refusal.value))
    assert re.search(r'delta must be a finite number, got -?(nan|inf) m$', text), text


def test_an_unknown_gripper_command_is_said_once():
    text = clean(unknown_choice('gripper command', 7, {'SCREW_IN': 1, 'UNSCREW': 2}))
    assert text == 'unknown gripper command 7: expected SCREW_IN (1) or UNSCREW (2)'
    with pytest.raises(TeleopRefusedError) as refusal:
        RULES.gripper_operation(free_b(), 'b', 7)
    text = clean(str(refusal.value))
    assert text.count('expected') == 1 and text.startswith('unknown gripper action 7:'), text


def test_a_jog_that_rounds_to_zero_reads_zero():
    jog = RULES.tip_jog(free_b(), np.array([-0.00001, 0.0, 0.01]), 0.0)
    assert clean(jog.describe()).endswith('by (+0.0, +0.0, +10.0) mm in its frame')


def test_the_status_line_shows_no_negative_zero():
    truss = Truss.from_parameters(PARAMS)
    hole = truss.position('n2_1') + [-0.00002, 0.00001, 0.03]
    view = GripperView('b', 'free', '', hole, (0.0, 0.0, 0.0, 1.0))
    line = clean(_gripper_line(view, truss))
    assert '(+0.0, +0.0, -30.0) mm' in line, line


@pytest.mark.parametrize('value, text', [
    (np.float64(math.nan), 'nan'), (np.float32(1.5), '1.5'), (-0.0, '0'), (np.int64(7), '7'),
    (np.array([0.5, -0.0]), '[0.5, 0]'), ('c', "'c'"), (True, 'True')])
def test_values_read_as_numbers(value, text):
    assert value_text(value) == text


def test_millimetres_round_away_the_sign_of_zero():
    assert millimetres(-0.00004) == '0.0'
    assert millimetres([-0.00004, 0.0012], signed=True) == '+0.0, +1.2'
    assert number(-1e-9, '.3f') == '0.000' and number(-0.5, '.1f') == '-0.5'
