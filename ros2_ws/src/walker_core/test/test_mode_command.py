"""Only the namespace's supervisor commands the controllers' mode."""

import pytest

from walker_core.mode_command import mode_command_refusal, mode_commander


@pytest.mark.parametrize('namespace, expected', [
    ('/walker', '/walker/supervisor'), ('/walker_2/', '/walker_2/supervisor'),
    ('/', '/supervisor')])
def test_the_commander_is_the_supervisor_of_the_namespace(namespace, expected):
    assert mode_commander(namespace) == expected


def test_the_supervisors_command_with_a_gripper_as_base_is_taken():
    assert mode_command_refusal('/walker/supervisor', 'b', '/walker') == ''


@pytest.mark.parametrize('commander, shown', [
    ('', 'no commander'), ('/walker/_ros2cli_1234', "'/walker/_ros2cli_1234'"),
    ('/walker_2/supervisor', "'/walker_2/supervisor'"), ('supervisor', "'supervisor'")])
def test_a_command_from_anyone_else_is_refused_naming_the_rule(commander, shown):
    reason = mode_command_refusal(commander, 'a', '/walker')
    assert reason.startswith(f'control_mode command from {shown} refused: only '
                             "/walker/supervisor commands the controllers' mode")
    assert 'hold' in reason


@pytest.mark.parametrize('base', ['', 'c', 'A'])
def test_a_base_that_is_not_a_gripper_is_refused(base):
    assert mode_command_refusal('/walker/supervisor', base, '/walker') == (
        f'control_mode command refused: base gripper {base!r} is not a gripper (expected "a" '
        f'or "b")')
