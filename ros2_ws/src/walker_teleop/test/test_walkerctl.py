"""walkerctl's command line: bad input is refused before anything is sent, help reads well."""

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_teleop.walkerctl import EXIT_USAGE, build_parser, main

from ros2_lines import build, lines_in

#: The supervisor's operator interfaces (walker_supervisor.supervisor_node, teleop_server).
SERVICES = {'hold': 'Trigger', 'resume': 'Trigger', 'jog_joint': 'JogJoint',
            'jog_tip': 'JogTip', 'operate_gripper': 'GripperCommand'}
ACTIONS = {'step': 'Step', 'walk_to': 'WalkTo'}


def _subparsers():
    parser = build_parser()
    action = next(a for a in parser._actions if a.dest == 'command')
    return action.choices


@pytest.mark.parametrize('argv, words', [
    (['jog-joint', 'elbow', '0.1'], "invalid choice: 'elbow'"),
    (['jog-joint', 'vertex_joint', 'nan'], "must be a finite number, got 'nan'"),
    (['jog-joint', 'vertex_joint', 'inf'], "must be a finite number, got 'inf'"),
    (['jog-joint', 'vertex_joint', 'a lot'], "not a number: 'a lot'"),
    (['jog-joint', 'vertex_joint', '0.1', '--speed', '-1'], 'must not be negative'),
    (['jog-tip', '0.01', '0'], 'the following arguments are required: DZ'),
    (['jog-tip', '0.01', '0', '1e999'], 'must be a finite number'),
    (['screw-in', 'c'], "invalid choice: 'c'"),
    (['step'], 'the following arguments are required: NODE'),
    (['--domain-id', '300', 'status'], 'must be between 0 and 232, got 300'),
    (['--timeout', '0', 'status'], 'must be a positive number of seconds'),
    (['fly'], "invalid choice: 'fly'"),
    ([], 'the following arguments are required: COMMAND'),
])
def test_bad_input_is_refused_with_the_reason_and_exit_code_2(capsys, argv, words):
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == EXIT_USAGE
    assert words in capsys.readouterr().err


def test_good_input_parses_to_si_values():
    args = build_parser().parse_args(['--namespace', '/walker2', '--domain-id', '7', 'jog-joint',
                                      'b_pitch_joint', '-0.05', '--speed', '0.05'])
    assert (args.namespace, args.domain_id, args.command) == ('/walker2', 7, 'jog-joint')
    assert (args.joint, args.delta, args.speed) == ('b_pitch_joint', -0.05, 0.05)
    args = build_parser().parse_args(['jog-tip', '0', '-0.02', '0.03'])
    assert (args.dx, args.dy, args.dz, args.speed) == (0.0, -0.02, 0.03, 0.0)
    assert build_parser().parse_args(['walk-to', '-q', 'n4_3']).quiet


def test_every_command_is_listed_with_a_summary_and_the_exit_codes():
    text = build_parser().format_help()
    for name in _subparsers():
        assert f'    {name} ' in text
    assert 'exit codes: 0 done, 1 refused or failed' in text
    assert 'ROS_DOMAIN_ID' in text


@pytest.mark.parametrize('name', ['hold', 'resume', 'step', 'walk-to', 'jog-joint', 'jog-tip',
                                  'unscrew', 'screw-in'])
def test_each_command_help_shows_a_ros2_line_that_builds_a_valid_request(name):
    text = _subparsers()[name].format_help()
    lines = lines_in(text)
    assert len(lines) == 1, text
    kind, topic, message = build(lines[0])
    short = topic.rsplit('/', 1)[1]
    expected = SERVICES if kind == 'service' else ACTIONS
    assert type(message).__name__.split('_')[0] == expected[short]
    if 'example:' in text:  # the example and the ros2 line do the same thing
        example = text.split('example:', 1)[1].split('\n')[1].split()
        args = vars(build_parser().parse_args(example[1:]))
        if name == 'jog-tip':
            args['delta'] = [args['dx'], args['dy'], args['dz']]
        same = {'joint_name': 'joint', 'delta': 'delta', 'max_velocity': 'speed',
                'target_node': 'node', 'gripper': 'gripper'}
        for field, arg in same.items():
            if hasattr(message, field):
                assert list(getattr(message, field)) == list(args[arg]) if field == 'delta' \
                    and name == 'jog-tip' else getattr(message, field) == args[arg], field


def test_the_joint_choices_are_the_physical_joints():
    action = next(a for a in _subparsers()['jog-joint']._actions if a.dest == 'joint')
    assert list(action.choices) == list(PHYSICAL_JOINT_NAMES)
