"""The README's Teleoperation section: each operation both ways, every line a valid command."""

import shlex
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from ros_test_support import REPO_ROOT
from walker_teleop.walkerctl import build_parser

from ros2_lines import build, lines_in


def _section() -> str:
    text = (REPO_ROOT / 'README.md').read_text()
    return text.split('## Teleoperation', 1)[1].split('\n## ', 1)[0]


def test_every_ros2_line_of_the_section_builds_a_valid_request():
    lines = lines_in(_section())
    assert len(lines) == 9  # every operation but status, which reads topics
    for line in lines:
        build(line)  # raises on an unknown field or a value of the wrong type


def test_each_ros2_command_has_its_walkerctl_line_next_to_it():
    block = _section().split('```\n# ', 1)[1].split('```', 1)[0]
    operations = [o for o in block.split('\n\n') if o.strip()]
    assert len(operations) == 10
    for operation in operations:
        lines = [line for line in operation.splitlines() if not line.startswith('#')]
        assert any(line.startswith('ros2 ') for line in lines), operation
        tools = [line for line in lines if line.startswith('scripts/walkerctl ')]
        assert len(tools) == 1, operation
        build_parser().parse_args(shlex.split(tools[0])[1:])  # exits on a bad argument


def test_the_section_covers_every_walkerctl_command():
    parser = build_parser()
    commands = next(a for a in parser._actions if a.dest == 'command').choices
    section = _section()
    for name in commands:
        assert f'scripts/walkerctl {name}' in section, name
