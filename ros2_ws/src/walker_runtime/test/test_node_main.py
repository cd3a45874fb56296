"""run_node: every node process starts, stops and refuses the same way, with the same codes."""

import ast
import dataclasses
import re
import signal
import sys
import textwrap
from pathlib import Path

import pytest
from ros_test_support import REPO_ROOT, NodeProcess

from walker_runtime.node_main import EXIT_FAILED, EXIT_OK, EXIT_REFUSED, refusal_line

WAIT = 30.0  # [s] wall clock, for a process to start or end on a loaded machine

# A node with one parameter section and a switch to fail while spinning; run through run_node.
_NODE = textwrap.dedent("""
    import dataclasses, sys
    from rclpy.node import Node
    from walker_core.parameter_schema import parameter
    from walker_runtime.node_main import run_node
    from walker_runtime.node_parameters import declare_section

    @dataclasses.dataclass(frozen=True)
    class Band:
        low: float = parameter('lower edge', 'm', 0.0, 10.0)
        high: float = parameter('upper edge', 'm', 0.0, 10.0)

        def __post_init__(self):
            if self.low >= self.high:
                raise ValueError(f'band.low ({self.low}) must be below band.high')

    class Demo(Node):
        def __init__(self):
            super().__init__('demo')
            self.band = declare_section(self, Band, 'band.', {'band.low': 1.0, 'band.high': 2.0})
            self.create_timer(0.05, self._tick)
            print('demo spinning', flush=True)

        def _tick(self):
            if self.band.high > 9.0:
                raise RuntimeError('failed while running')

    sys.exit(run_node(Demo, 'demo', sys.argv,
                      before_destroy=lambda node: print('demo destroyed', flush=True)))
""")


def _demo(ros_env, *ros_args):
    arguments = ['--ros-args', *ros_args] if ros_args else []
    return NodeProcess([sys.executable, '-c', _NODE, *arguments], ros_env, 'demo')


def _ended(process: NodeProcess) -> int:
    process.process.wait(timeout=WAIT)
    return process.process.returncode


def test_a_node_stopped_by_a_signal_exits_0_after_destroying_itself(ros_env):
    with _demo(ros_env) as demo:
        assert demo.wait_for_output('demo spinning', WAIT), demo.output
        demo.process.send_signal(signal.SIGINT)
        assert _ended(demo) == EXIT_OK, demo.output
        assert 'demo destroyed' in demo.output and 'Traceback' not in demo.output


@pytest.mark.parametrize('ros_args, words', [
    (('-p', 'band.low:=5.0'), 'band.low (5.0) must be below band.high'),
    (('-p', 'band.high:=11.0'), 'band.high out of range'),
    (('-p', 'band.low:=abc'), 'band.low'),
    (('--params-file', '{bad_file}'), "Couldn't parse params file"),
    (('--params-file', '{missing_file}'), 'missing.yaml'),
])
def test_a_refused_parameter_or_file_is_one_line_and_exit_2(ros_env, tmp_path, ros_args,
                                                              words):
    bad_file = tmp_path / 'bad.yaml'
    bad_file.write_text('/**:\n  ros__parameters:\n    band: [unclosed\n')
    ros_args = [a.format(bad_file=bad_file, missing_file=tmp_path / 'missing.yaml')
                for a in ros_args]
    with _demo(ros_env, *ros_args) as demo:
        assert _ended(demo) == EXIT_REFUSED, demo.output
        lines = [line for line in demo.output.splitlines() if 'refusing to start' in line]
        assert len(lines) == 1 and lines[0].startswith('[demo] refusing to start: '), \
            demo.output
        assert words in lines[0], demo.output
        assert 'Traceback' not in demo.output and 'demo spinning' not in demo.output
        assert '.c:' not in lines[0], 'no C source locations in the line'


def test_an_error_while_running_is_a_failure_with_its_traceback(ros_env):
    with _demo(ros_env, '-p', 'band.high:=9.5') as demo:
        assert _ended(demo) == EXIT_FAILED, demo.output
        assert 'Traceback' in demo.output and 'failed while running' in demo.output
        assert 'demo destroyed' in demo.output


def test_the_refusal_line_is_one_line_without_source_locations():
    error = RuntimeError("failed to initialize rcl: Couldn't parse params file: 'x.yaml'. "
                         'Error: near line 3, at /project/src/parse.c:782, at '
                         '/project/src/rcl/arguments.c:415')
    assert refusal_line('plant', error) == (
        "[plant] refusing to start: failed to initialize rcl: Couldn't parse params file: "
        "'x.yaml'. Error: near line 3")
    assert refusal_line('p', ValueError('two\nlines')) == '[p] refusing to start: two lines'


@dataclasses.dataclass(frozen=True)
class _Executable:
    package: str
    name: str
    module: str
    function: str


def _node_executables() -> list[_Executable]:
    """Every ``*_node`` console script of every package, read from its setup.py."""
    found = []
    for setup in sorted((REPO_ROOT / 'ros2_ws' / 'src').glob('*/setup.py')):
        for line in re.findall(r"'(\w+_node\s*=\s*[\w.]+:\w+)'", setup.read_text()):
            name, target = (part.strip() for part in line.split('='))
            module, function = target.split(':')
            found.append(_Executable(setup.parent.name, name, module, function))
    return found


def _calls(path: Path, function: str) -> set[str]:
    tree = ast.parse(path.read_text())
    body = next(n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == function)
    return {n.func.id if isinstance(n.func, ast.Name) else n.func.attr
            for n in ast.walk(body) if isinstance(n, ast.Call)
            and isinstance(n.func, (ast.Name, ast.Attribute))}


def test_every_node_executable_runs_through_run_node():
    executables = _node_executables()
    assert {'plant_node', 'planner_node', 'supervisor_node', 'recorder_node',
            'joint_controller_node'} <= {e.name for e in executables}
    source = REPO_ROOT / 'ros2_ws' / 'src'
    for executable in executables:
        path = source / executable.package / Path(*executable.module.split('.')).with_suffix(
            '.py')
        calls = _calls(path, executable.function)
        # one level of indirection: the controllers' run_controller_node
        helpers = {name for name in calls if name.startswith('run_') and name != 'run_node'}
        for helper in helpers:
            for candidate in path.parent.glob('*.py'):
                if f'def {helper}(' in candidate.read_text():
                    calls |= _calls(candidate, helper)
        assert 'run_node' in calls, f'{executable.name} ({path}) does not call run_node'
