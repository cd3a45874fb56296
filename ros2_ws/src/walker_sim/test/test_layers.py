"""The plant core is ROS-free: importing all of it loads no rclpy."""

import subprocess
import sys

CORE_MODULES = ['bullet', 'commands', 'config', 'driven_modes', 'flexibility', 'grippers',
                'identification', 'motor', 'plant', 'render']


def test_the_core_imports_without_rclpy():
    code = ('import sys\n'
            + ''.join(f'import walker_sim.core.{m}\n' for m in CORE_MODULES)
            + 'import walker_sim.identify_modes, walker_sim.render_walker\n'
            + "print(sorted(m for m in sys.modules if m.split('.')[0] == 'rclpy'))\n")
    result = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                            check=True)
    assert result.stdout.strip().splitlines()[-1] == '[]'
