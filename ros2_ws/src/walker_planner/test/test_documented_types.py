"""The planner page's table of trajectory types is the registry's list, in order."""

import re

from ros_test_support import REPO_ROOT
from walker_planner.core.registry import TRAJECTORY_TYPES


def test_the_planner_page_lists_exactly_the_nine_types():
    text = (REPO_ROOT / 'docs' / 'planner.md').read_text()
    section = text.split('\n## The nine types', 1)[1].split('\n## ', 1)[0]
    rows = re.findall(r'^\| `([a-z_]+)` \|', section, flags=re.MULTILINE)
    assert rows == list(TRAJECTORY_TYPES)
    assert len(rows) == 9
    for name, kind in TRAJECTORY_TYPES.items():
        row = next(line for line in section.splitlines() if line.startswith(f'| `{name}` |'))
        assert kind.space.lower() in row.lower()
