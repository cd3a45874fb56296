"""The campaign's core needs neither ROS nor Ray: importing all of it loads no rclpy, no ray."""

import subprocess
import sys

CORE = ['analysis', 'distributions', 'errors', 'figures', 'parameter_sets', 'plan', 'progress',
        'report', 'results', 'rows', 'spec', 'statistics', 'survey', 'targets']


def test_the_core_and_the_execution_import_without_rclpy_or_ray():
    code = ('import sys\n'
            + ''.join(f'import walker_campaign.core.{m}\n' for m in CORE)
            + 'import walker_campaign.execution, walker_campaign.walks\n'
            + 'from walker_campaign.core.spec import load_spec, shipped_spec\n'
            + "load_spec(shipped_spec('default_walk'))\n"
            + "print(sorted({m.split('.')[0] for m in sys.modules} & {'rclpy', 'ray'}))\n")
    result = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                            check=True)
    assert result.stdout.strip().splitlines()[-1] == '[]'
