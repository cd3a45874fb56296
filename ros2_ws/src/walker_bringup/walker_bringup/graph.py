"""The walker's node graph as data: which executables run, with which names and arguments.

ROS 2 ``launch`` is not available here, so the graph is described by plain dataclasses and
started as separate processes by :mod:`walker_bringup.processes`; the command lines are exactly
what ``ros2 run <package> <executable> --ros-args ...`` would run on a full Jazzy install.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from walker_core.camera import RECORDED_CAMERA_TOPICS, camera_topic
from walker_core.joint_roles import GRIPPERS, PHYSICAL_JOINT_NAMES
from walker_supervisor.core.survey_file import SURVEY_FILE_NAME

__all__ = ['NodeSpec', 'StartStance', 'walker_graph', 'walker_namespace', 'start_stances',
           'several_walkers', 'walker_targets', 'executable_path', 'controller_node_name',
           'GROUPED_CONTROLLERS_NODE', 'VIZ_NODE', 'FOXGLOVE_NODE', 'RECORDED_TOPICS', 'tf_remaps',
           'SURVEY_FILE_PARAMETER', 'walker_survey_file']

#: Name of the one node of the five joint controllers in a graph with ``grouped_controllers``.
GROUPED_CONTROLLERS_NODE = 'controllers'
#: Name of the node that publishes TF and markers (walker_viz).
VIZ_NODE = 'viz'
#: Name of the node that serves the graph to Foxglove (``run_all.py --foxglove``).
FOXGLOVE_NODE = 'foxglove_bridge'
#: The supervisor's parameter naming its truss survey file.
SURVEY_FILE_PARAMETER = 'supervisor.truss_survey_file'

#: What a walk's bag holds (relative to the robot's namespace): everything the walk report
#: uses. The high-rate inner-loop topics (effort_commands, joint_accelerations, the setpoint
#: streams) are left out: the controller states carry the setpoints and efforts at
#: ``control.state_rate``, and recording every message of the 500 Hz loop would take about a
#: core of CPU on its own. The wrist cameras' topics exist only with cameras, and their frames
#: only when a look asks for one (``sim.camera.frame_rate`` 0: docs/perception.md).
RECORDED_TOPICS = ('joint_states', 'tip_pose', 'gripper_a_pose', 'gripper_b_pose',
                   'gripper_states', 'phase', 'phase_history', 'goal_rejections',
                   'step_reports', 'control_mode',
                   'controllers/*/state', 'planned_trajectory', 'robot_description',
                   'markers', 'truss_map_markers', '/tf', '/tf_static', '/diagnostics',
                   '/clock',
                   *(camera_topic(g, name) for g in GRIPPERS for name in RECORDED_CAMERA_TOPICS))


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
    remaps : tuple of (str, str)
        Extra ``-r from:=to`` remappings (e.g. ``/clock`` for one walker among several).
    """

    package: str
    executable: str
    name: str
    namespace: str
    params_file: str
    parameters: tuple[tuple[str, str], ...] = ()
    remaps: tuple[tuple[str, str], ...] = ()

    @property
    def full_name(self) -> str:
        """Fully qualified node name, e.g. ``/walker/plant``."""
        return f'{self.namespace.rstrip("/")}/{self.name}'

    def ros_arguments(self) -> list[str]:
        """Return the node's ``--ros-args ...`` arguments.

        What its process gets after the executable, and what the composed graph gives the
        node (``Node(cli_args=...)``).
        """
        args = ['--ros-args', '-r', f'__node:={self.name}', '-r', f'__ns:={self.namespace}']
        for source, target in self.remaps:
            args += ['-r', f'{source}:={target}']
        args += ['--params-file', self.params_file]
        for name, value in self.parameters:
            args += ['-p', f'{name}:={value}']
        return args

    def command(self, executable: str | None = None) -> list[str]:
        """Command line of the process; ``executable`` overrides the installed path."""
        return [executable or str(executable_path(self.package, self.executable)),
                *self.ros_arguments()]


@dataclasses.dataclass(frozen=True)
class StartStance:
    """Where a walker's plant starts: both grippers screwed into neighbouring nodes.

    The plant's ``sim.start.base_gripper``, ``sim.start.base_node`` and
    ``sim.start.other_node``; the other gripper starts attached.
    """

    base_gripper: str
    base_node: str
    other_node: str

    def parameters(self) -> tuple[tuple[str, str], ...]:
        """Return the plant's parameter overrides for this start."""
        return (('sim.start.base_gripper', self.base_gripper),
                ('sim.start.base_node', self.base_node),
                ('sim.start.other_node', self.other_node),
                ('sim.start.other_attached', 'true'), ('sim.start.other_height', '0.0'))


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


def walker_namespace(index: int) -> str:
    """Namespace of the walker number ``index`` (1-based): ``/walker``, ``/walker_2``, ..."""
    if isinstance(index, bool) or not isinstance(index, int) or index < 1:
        raise ValueError(f'walker index must be an integer from 1, got {index!r}')
    return '/walker' if index == 1 else f'/walker_{index}'


def walker_graph(params_file: str | Path, namespace: str = '/walker', sim_time: bool = False,
                 record: bool = False, bag_path: str | Path | None = None,
                 start: StartStance | None = None, clock_topic: str | None = None,
                 parameters: tuple[tuple[str, str], ...] = (),
                 grouped_controllers: bool = False,
                 foxglove_port: int | None = None,
                 plant_state_file: str | Path | None = None,
                 plant_params_file: str | Path | None = None,
                 survey_file: str | Path | None = None) -> list[NodeSpec]:
    """List the walker's nodes in start order: plant, controllers, planner, supervisor, viz.

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
    start : StartStance, optional
        Where the plant starts (the parameter file's ``sim.start.*`` when omitted).
    clock_topic : str, optional
        Remap ``/clock`` to this topic in every node of the graph: each walker of several has
        a plant, and so a simulated clock, of its own. ``/tf`` and ``/tf_static`` are then
        remapped into the walker's namespace too (``<namespace>/tf``), as multi-robot ROS
        graphs do: each walker's links have the same names, and its stamps its own clock.
    parameters : tuple of (str, str)
        Overrides given to every node, after its own (e.g. ``('timing.control_rate',
        '1000.0')``); values in ROS YAML syntax.
    grouped_controllers : bool
        Run the five joint controllers in one node (``joint_controllers_node``, named
        ``controllers``: one state in, one effort message out per period) instead of one
        ``joint_controller_node`` each.
    foxglove_port : int, optional
        Also serve the graph's topics to Foxglove (``walker_viz foxglove_bridge``) on this
        port of 127.0.0.1.
    plant_state_file : str or Path, optional
        The plant's state snapshot (its ``state_file``): a plant started again after a crash
        restores the physical state it had from it (``walker_sim.core.snapshot``).
    plant_params_file : str or Path, optional
        A parameter file of the plant's own (default: ``params_file``): the robot as it
        really is, where the other nodes work on the model (a campaign's dispersed runs).
    survey_file : str or Path, optional
        The supervisor's truss survey file (``supervisor.truss_survey_file``): its map starts
        from it where it exists and is kept up to date in it.
    """
    params_file = str(params_file)
    parameters = tuple(parameters)
    common = (('use_sim_time', 'true' if sim_time else 'false'),)
    remaps = ()
    recorded = RECORDED_TOPICS
    if clock_topic:
        remaps = (('/clock', clock_topic), *tf_remaps(namespace))
        recorded = tuple(dict(tf_remaps(namespace)).get(t, t) for t in RECORDED_TOPICS)
    nodes = []
    if record:
        bag = Path(bag_path) if bag_path else None
        extra = ((('recorder.directory', str(bag.parent)), ('recorder.bag_name', bag.name))
                 if bag else ())
        topics = '[' + ', '.join(f"'{t}'" for t in recorded) + ']'
        extra += (('recorder.topics', topics),)
        nodes.append(NodeSpec('walker_bag', 'recorder_node', 'recorder', namespace,
                              params_file, common + extra + parameters, remaps))
    plant = common + (('sim.clock_mode', 'sim_time' if sim_time else 'real_time'),)
    if start is not None:
        plant += start.parameters()
    if plant_state_file is not None:
        plant += (('state_file', str(plant_state_file)),)
    nodes.append(NodeSpec('walker_sim', 'plant_node', 'plant', namespace,
                          str(plant_params_file or params_file), plant + parameters, remaps))
    # The controllers run on the plant's state stream and its stamps (watchdogs on the steady
    # clock); use_sim_time tells them they are lock-stepped: a state then waits for the
    # setpoint the planner's stream owes it, and no real-time priority is asked for.
    controller = common
    if grouped_controllers:
        nodes.append(NodeSpec('walker_control', 'joint_controllers_node',
                              GROUPED_CONTROLLERS_NODE, namespace, params_file,
                              controller + parameters, remaps))
    for joint in () if grouped_controllers else PHYSICAL_JOINT_NAMES:
        nodes.append(NodeSpec('walker_control', 'joint_controller_node',
                              controller_node_name(joint), namespace, params_file,
                              (('joint_name', joint),) + controller + parameters, remaps))
    nodes.append(NodeSpec('walker_planner', 'planner_node', 'planner', namespace, params_file,
                          common + parameters, remaps))
    supervisor = common
    if survey_file is not None:
        supervisor += ((SURVEY_FILE_PARAMETER, str(survey_file)),)
    nodes.append(NodeSpec('walker_supervisor', 'supervisor_node', 'supervisor', namespace,
                          params_file, supervisor + parameters, remaps))
    nodes.append(NodeSpec('walker_viz', 'viz_node', VIZ_NODE, namespace, params_file,
                          common + parameters, remaps))
    if foxglove_port is not None:
        nodes.append(NodeSpec('walker_viz', 'foxglove_bridge', FOXGLOVE_NODE, namespace,
                              params_file, common + (('port', str(foxglove_port)),), remaps))
    return nodes


def tf_remaps(namespace: str) -> tuple[tuple[str, str], ...]:
    """Remaps of ``/tf`` and ``/tf_static`` into a walker's namespace (``/walker_2/tf``)."""
    prefix = namespace.rstrip('/')
    return (('/tf', f'{prefix}/tf'), ('/tf_static', f'{prefix}/tf_static'))


def start_stances(configuration, count: int) -> list[StartStance]:
    """Distinct start stances for ``count`` walkers on the truss of a configuration.

    ``configuration`` is a :class:`~walker_config.core.configuration.WalkerConfiguration`.
    The first stance is its own ``sim.start.*``; the others are the same pair of neighbouring
    nodes moved to other rows (and then by two columns at a time), so that no two walkers
    start on a common node. The walkers' plants are separate physics worlds: walkers on one
    truss layout do not collide, however close they come.

    Raises
    ------
    ValueError
        If ``count`` is not a positive integer, the file's start is not two neighbouring
        nodes, or the truss has too few nodes for ``count`` distinct stances.
    """
    from walker_core.truss import Truss

    if isinstance(count, bool) or not isinstance(count, int) or count < 1:
        raise ValueError(f'the number of walkers must be a positive integer, got {count!r}')
    truss = Truss.from_parameters(configuration.walker)
    start = configuration.sim.start
    gripper, base, other = start.base_gripper, start.base_node, start.other_node
    if other not in truss.neighbors(base):
        raise ValueError(f'sim.start.base_node {base!r} and other_node {other!r} are not '
                         'neighbouring truss nodes')
    (bc, br), (oc, orow) = truss.index(base), truss.index(other)
    shifts = [(dc, dr) for dc in sorted(range(-truss.columns + 1, truss.columns),
                                        key=lambda c: (abs(c), c < 0)) if dc % 2 == 0
              for dr in [(r - br) for r in (*range(br, truss.rows), *range(br))]]
    stances: list[StartStance] = []
    used: set[str] = set()
    for dc, dr in shifts:
        nodes = ((bc + dc, br + dr), (oc + dc, orow + dr))
        if not all(0 <= c < truss.columns and 0 <= r < truss.rows for c, r in nodes):
            continue
        names = [f'n{c}_{r}' for c, r in nodes]
        if used.intersection(names):
            continue
        used.update(names)
        stances.append(StartStance(gripper, *names))
        if len(stances) == count:
            return stances
    raise ValueError(f'the {truss.columns} x {truss.rows} truss has room for '
                     f'{len(stances)} walkers starting on distinct nodes, not {count}')


def several_walkers(configuration, count: int, sim_time: bool = False,
                    record: bool = False, bag_dir: str | Path | None = None,
                    parameters: tuple[tuple[str, str], ...] = (),
                    grouped_controllers: bool = False, state_dir: str | Path | None = None
                    ) -> list[tuple[str, StartStance, list[NodeSpec]]]:
    """List the graphs of ``count`` walkers on one truss: ``(namespace, start, nodes)`` each.

    Walker ``i`` runs in the namespace :func:`walker_namespace` ``(i)`` from its own start
    (:func:`start_stances` of ``configuration``, whose file every node takes). Each has its
    own plant, so in sim time each has its own clock: ``/clock`` is remapped into the walker's
    namespace (``/walker_2/clock``), except for the first walker, whose graph is exactly the
    single walker's. With ``record``, each walker's recorder writes ``<bag_dir>/bag`` (the
    first) or ``<bag_dir>/bag_walker_<i>``; ``parameters`` go to every node and
    ``grouped_controllers`` is each graph's (see :func:`walker_graph`); with ``state_dir``,
    each plant keeps its state snapshot in ``<state_dir>/plant_state_walker_<i>.json`` and
    each supervisor its truss survey in ``<state_dir>/`` :func:`walker_survey_file`.
    """
    graphs = []
    for index, start in enumerate(start_stances(configuration, count), start=1):
        namespace = walker_namespace(index)
        clock = f'{namespace}/clock' if index > 1 else None
        bag = None
        if record and bag_dir is not None:
            bag = Path(bag_dir) / ('bag' if index == 1 else f'bag_{namespace.strip("/")}')
        graphs.append((namespace, start, walker_graph(
            configuration.path, namespace, sim_time, record=record, bag_path=bag,
            start=start if index > 1 else None, clock_topic=clock, parameters=parameters,
            grouped_controllers=grouped_controllers,
            plant_state_file=None if state_dir is None else
            Path(state_dir) / f'plant_state_{namespace.strip("/")}.json',
            survey_file=None if state_dir is None else
            Path(state_dir) / walker_survey_file(namespace))))
    return graphs


def walker_survey_file(namespace: str) -> str:
    """Return the name of a walker's truss survey file in the run's output directory.

    ``truss_survey.yaml`` for ``/walker``, ``truss_survey_walker_<i>.yaml`` for the others
    (as the walk summaries are named).
    """
    label = namespace.strip('/')
    if label == 'walker':
        return SURVEY_FILE_NAME
    stem, dot, suffix = SURVEY_FILE_NAME.rpartition('.')
    return f'{stem}_{label}{dot}{suffix}'


def walker_targets(configuration, target: str, stances: list[StartStance]) -> list[str]:
    """Return the node each walker walks to: ``target`` moved as its start is moved.

    The first walker walks to ``target``; walker ``i`` to the node as far from its start as
    ``target`` is from the first walker's start, so that every walker walks the same route on
    its own part of the truss; where that node is off the truss, to ``target`` itself.

    Raises
    ------
    walker_core.truss.UnknownNodeError
        If ``target`` is not a node of the truss.
    """
    from walker_core.truss import Truss

    truss = Truss.from_parameters(configuration.walker)
    column, row = truss.index(target)
    first_column, first_row = truss.index(stances[0].base_node)
    targets = []
    for stance in stances:
        base_column, base_row = truss.index(stance.base_node)
        moved = (column + base_column - first_column, row + base_row - first_row)
        inside = 0 <= moved[0] < truss.columns and 0 <= moved[1] < truss.rows
        targets.append(f'n{moved[0]}_{moved[1]}' if inside else target)
    return targets
