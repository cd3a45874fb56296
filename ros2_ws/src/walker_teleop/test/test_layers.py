"""walkerctl's ROS-free part loads no rclpy, and its command line builds without a graph."""

import subprocess
import sys


def test_the_core_and_the_command_line_import_without_rclpy():
    code = ('import sys\n'
            'import walker_core.progress, walker_teleop.core.status\n'
            'import walker_teleop.walkerctl\n'
            'walker_teleop.walkerctl.build_parser()\n'
            "print(sorted(m for m in sys.modules if m.split('.')[0] == 'rclpy'))\n")
    result = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                            check=True)
    assert result.stdout.strip().splitlines()[-1] == '[]'
