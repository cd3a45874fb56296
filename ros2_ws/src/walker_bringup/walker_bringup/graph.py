"""The walker's node graph as data: which executables run, with which names and arguments.

ROS 2 ``launch`` is not available here, so the graph is described by plain dataclasses and
started as separate processes by :mod:`walker_bringup.processes`; the command lines are exactly
what ``ros2 run <package> <executable> --ros-args ...`` would run on a full Jazzy install.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES

__all__ = ['NodeSpec', 'walker_graph', 'executable_path', 'controller_node_name',
           'RECORDED_TOPICS']

#: What a walk's bag holds (relative to the robot's namespace): everything the walk report
#: uses. The high-rate inner-loop topics (effort_commands, joint_accelerations, the setpoint
#: streams) are left out: the controller states carry the setpoints and efforts at
#: ``control.state_rate``, and recording every message of the 500 Hz loop would take about a
#: core of CPU on its own.
RECORDED_TOPICS = ('joint_states', 'tip_pose', 'gripper_a_pose', 'gripper_b_pose',
                   'gripper_states', 'phase', 'step_reports', 'control_mode',
                   'controllers/*/state', 'planned_trajectory', 'robot_description',
                   '/diagnostics', '/clock')


@dataclasses.dataclass(frozen=True)
class NodeSpec:
    """One node process.

    Attributes
    ----------
    package, executable : str
        As for ``ros2 run``.
    name : str
        Node name (``__node`` remap).
    namespace : str
        Node namespace, e.g. ``/walker``.
    params_file : str
        The parameter file, passed with ``--params-file``.
    parameters : tuple of (str, str)
        Extra ``-p name:=value`` overrides, values already in ROS YAML syntax.
    """

    package: str
    executable: str
    name: str
    namespace: str
    params_file: str
    parameters: tuple[tuple[str, str], ...] = ()

    @property
    def full_name(self) -> str:
        """Fully qualified node name, e.g. ``/walker/plant``."""
        return f'{self.namespace.rstrip("/")}/{self.name}'

    def command(self, executable: str | None = None) -> list[str]:
        """Command line of the process; ``executable`` overrides the installed path."""
        args = [executable or str(executable_path(self.package, self.executable)),
                '--ros-args', '-r', f'__node:={self.name}', '-r', f'__ns:={self.namespace}',
                '--params-file', self.params_file]
        for name, value in self.parameters:
            args += ['-p', f'{name}:={value}']
        return args


def executable_path(package: str, executable: str) -> Path:
    """Installed path of a package's executable (what ``ros2 run`` runs)."""
    from ament_index_python.packages import get_package_prefix

    path = Path(get_package_prefix(package)) / 'lib' / package / executable
    if not path.exists():
        raise FileNotFoundError(f'package {package!r} has no executable {executable!r} '
                                f'(looked for {path})')
    return path


def controller_node_name(joint_name: str) -> str:
    """Name of the controller node of a physical joint: ``controller_<joint>``."""
    return 'controller_' + joint_name.removesuffix('_joint')


def walker_graph(params_file: str | Path, namespace: str = '/walker', sim_time: bool = False,
                 record: bool = False, bag_path: str | Path | None = None) -> list[NodeSpec]:
    """List the walker's nodes in start order: plant, five controllers, planner, supervisor.

    Parameters
    ----------
    params_file : str or Path
        The one parameter file every node takes.
    namespace : str
        The robot's namespace.
    sim_time : bool
        Run on the plant's ``/clock`` (``use_sim_time``) with the plant lock-stepped, or in
        real time like hardware.
    record : bool
        Also start the rosbag2 recorder, first, so it sees every topic from its start.
    bag_path : str or Path, optional
        Output directory of the bag (the recorder's default when omitted).
    """
    params_file = str(params_file)
    common = (('use_sim_time', 'true' if sim_time else 'false'),)
    nodes = []
    if record:
        bag = Path(bag_path) if bag_path else None
        extra = ((('recorder.directory', str(bag.parent)), ('recorder.bag_name', bag.name))
                 if bag else ())
        topics = '[' + ', '.join(f"'{t}'" for t in RECORDED_TOPICS) + ']'
        extra += (('recorder.topics', topics),)
        nodes.append(NodeSpec('walker_bag', 'recorder_node', 'recorder', namespace,
                              params_file, common + extra))
    nodes.append(NodeSpec('walker_sim', 'plant_node', 'plant', namespace, params_file,
                          common + (('sim.clock_mode', 'sim_time' if sim_time else 'real_time'),)))
    for joint in PHYSICAL_JOINT_NAMES:
        # The controllers run on the plant's state stream and its stamps (watchdogs on the
        # steady clock): use_sim_time would only add a /clock subscription every period.
        nodes.append(NodeSpec('walker_control', 'joint_controller_node',
                              controller_node_name(joint), namespace, params_file,
                              (('joint_name', joint),)))
    nodes.append(NodeSpec('walker_planner', 'planner_node', 'planner', namespace, params_file,
                          common))
    nodes.append(NodeSpec('walker_supervisor', 'supervisor_node', 'supervisor', namespace,
                          params_file, common))
    return nodes
