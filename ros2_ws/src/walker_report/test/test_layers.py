"""The report needs no ROS graph: importing all of it loads no rclpy."""

import subprocess
import sys

MODULES = ['core.analysis', 'core.animation', 'core.errors', 'core.figures', 'core.markdown',
           'core.report', 'core.steps', 'core.walk_data', 'progress', 'walk_report']


def test_the_report_imports_without_rclpy():
    code = ('import sys\n'
            + ''.join(f'import walker_report.{m}\n' for m in MODULES)
            + "print(sorted(m for m in sys.modules if m.split('.')[0] == 'rclpy'))\n")
    result = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                            check=True)
    assert result.stdout.strip().splitlines()[-1] == '[]'
