"""The command line that starts the walk recorder, for the scripts that bring the graph up.

``launch`` is not available here, so ``scripts/run_all.py`` starts every node as a process;
this module gives it (and the tests) the recorder's command line in one place::

    command = recorder_command('runs/bags', params_file=walker_yaml, use_sim_time=True)
    subprocess.Popen(command, env=env)   # stop it with SIGINT or SIGTERM: the bag is closed

It is the equivalent of ``ros2 run walker_bag recorder_node --ros-args -r __ns:=/walker
--params-file walker.yaml -p recorder.directory:=runs/bags``.
"""

from __future__ import annotations

from pathlib import Path

from ament_index_python.packages import get_package_prefix

__all__ = ['recorder_executable', 'recorder_command']


def recorder_executable() -> Path:
    """Return the installed ``recorder_node`` executable (found through the ament index)."""
    return Path(get_package_prefix('walker_bag')) / 'lib' / 'walker_bag' / 'recorder_node'


def recorder_command(directory: str | Path, *, bag_name: str | None = None,
                     params_file: str | Path | None = None, use_sim_time: bool = False,
                     namespace: str = '/walker',
                     parameters: dict[str, str] | None = None) -> list[str]:
    """Return the argument list that starts the recorder.

    Parameters
    ----------
    directory : str or Path
        ``recorder.directory``: where the bag directory is created.
    bag_name : str, optional
        ``recorder.bag_name``; default a time-stamped name.
    params_file : str or Path, optional
        The parameter file (``--params-file``); default the installed ``walker.yaml``.
    use_sim_time : bool
        Stamp messages with the simulation clock.
    namespace : str
        The robot's namespace.
    parameters : dict of str to str, optional
        Further ``name: value`` overrides, e.g. ``{'recorder.topics': "['joint_states']"}``.
    """
    args = [str(recorder_executable()), '--ros-args', '-r', f'__ns:={namespace}']
    if params_file is not None:
        args += ['--params-file', str(params_file)]
    overrides = {'recorder.directory': str(directory)}
    if bag_name is not None:
        overrides['recorder.bag_name'] = bag_name
    if use_sim_time:
        overrides['use_sim_time'] = 'true'
    overrides.update(parameters or {})
    for name, value in overrides.items():
        args += ['-p', f'{name}:={value}']
    return args
