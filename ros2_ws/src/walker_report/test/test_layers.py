"""The report needs no ROS graph and no supervisor: it depends on the bag and the model only."""

import ast
import subprocess
import sys

MODULES = ['core.analysis', 'core.animation', 'core.errors', 'core.figures', 'core.markdown',
           'core.report', 'core.steps', 'core.walk_data', 'progress', 'walk_report']


def _loaded_after(code: str, packages: tuple[str, ...]) -> list[str]:
    script = ('import sys\n' + code
              + f'\nprint(sorted(m for m in sys.modules if m.split(".")[0] in {packages!r}))\n')
    result = subprocess.run([sys.executable, '-c', script], capture_output=True, text=True,
                            check=True)
    return ast.literal_eval(result.stdout.strip().splitlines()[-1])


def test_the_report_imports_without_rclpy():
    code = ''.join(f'import walker_report.{m}\n' for m in MODULES)
    assert _loaded_after(code, ('rclpy',)) == []


def test_the_report_takes_its_parameters_without_the_supervisor():
    """The settling window comes from the model (walker_core.settling), as the supervisor's."""
    code = ''.join(f'import walker_report.{m}\n' for m in MODULES) + (
        'from walker_core.parameter_file import ParameterFile\n'
        'from walker_core.settling import SETTLING_PREFIX, SettlingWindow\n'
        'ParameterFile.read().section(SettlingWindow, SETTLING_PREFIX)\n')
    assert _loaded_after(code, ('walker_supervisor', 'walker_planner', 'walker_control')) == []
