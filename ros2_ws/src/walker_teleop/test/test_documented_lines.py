"""The documented commands: each teleoperation both ways, every ``ros2`` line a valid request."""

import re
import shlex
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from ros_test_support import REPO_ROOT
from walker_teleop.walkerctl import build_parser

from ros2_lines import build, lines_in


def _teleoperation_page() -> str:
    return (REPO_ROOT / 'docs' / 'teleoperation.md').read_text()


def test_every_ros2_line_of_the_teleoperation_page_builds_a_valid_request():
    lines = lines_in(_teleoperation_page())
    assert len(lines) == 9  # every operation but status, which reads topics
    for line in lines:
        build(line)  # raises on an unknown field or a value of the wrong type


def test_each_ros2_command_has_its_walkerctl_line_next_to_it():
    block = _teleoperation_page().split('```\n# ', 1)[1].split('```', 1)[0]
    operations = [o for o in block.split('\n\n') if o.strip()]
    assert len(operations) == 10
    for operation in operations:
        lines = [line for line in operation.splitlines() if not line.startswith('#')]
        assert any(line.startswith('ros2 ') for line in lines), operation
        tools = [line for line in lines if line.startswith('scripts/walkerctl ')]
        assert len(tools) == 1, operation
        build_parser().parse_args(shlex.split(tools[0])[1:])  # exits on a bad argument


def test_the_teleoperation_page_covers_every_walkerctl_command():
    parser = build_parser()
    commands = next(a for a in parser._actions if a.dest == 'command').choices
    page = _teleoperation_page()
    for name in commands:
        assert f'scripts/walkerctl {name}' in page, name


def test_every_ros2_call_of_the_readme_interface_table_builds_a_valid_request():
    readme = (REPO_ROOT / 'README.md').read_text()
    calls = re.findall(r'`(ros2 (?:service call|action send_goal)[^`]*)`', readme)
    names = {build(call)[1] for call in calls}  # raises on an unknown field or a wrong type
    assert names == {'/walker/walk_to', '/walker/step', '/walker/hold', '/walker/resume',
                     '/walker/operate_gripper'}
