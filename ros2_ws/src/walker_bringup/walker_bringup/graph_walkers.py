"""The walkers of a graph session: each one's nodes, processes and client, and how it starts.

A session runs one walker's graph, or several side by side (namespaces ``/walker``,
``/walker_2``, ...); this module describes each (:func:`describe_walkers`: nothing started),
starts it in the session's arrangement (:func:`launch`), and after the graph is down completes
the bags a killed recorder left cut (:func:`recover_bags`).
"""

from __future__ import annotations

import dataclasses
import fnmatch
import os
from collections.abc import Callable
from pathlib import Path

from walker_bag.core.bag_metadata import read_metadata
from walker_bag.core.errors import MetadataError
from walker_bag.core.losses import recorded_losses
from walker_supervisor.core.survey_file import SURVEY_FILE_NAME
from walker_bringup.composed_process import composed_command
from walker_bringup.composition import LOOP_NODES
from walker_bringup.graph import (
    FOXGLOVE_NODE, SURVEY_FILE_PARAMETER, NodeSpec, StartStance, several_walkers, start_stances,
    walker_graph)
from walker_bringup.graph_client import GraphClient
from walker_bringup.processes import ProcessGroup
from walker_bringup.respawning import RespawningGroup
from walker_bringup.session_options import SessionOptions

__all__ = ['GraphWalker', 'describe_walkers', 'with_node_settings', 'plant_file', 'bag_paths',
           'graph_parameters', 'launch', 'recover_bags', 'survey_files', 'namespaces_in_use',
           'PLANT_STATE_FILE', 'Wrap']

#: What a process's command is replaced with: ``wrap(spec, command or None) -> command or None``.
Wrap = Callable[[NodeSpec, list[str] | None], list[str] | None]
#: The plant's state snapshot in the output directory (a plant started again restores it).
PLANT_STATE_FILE = 'plant_state.json'


@dataclasses.dataclass
class GraphWalker:
    """One walker's graph in a run: its nodes, its processes, its client, its outcome.

    ``start`` is the stance its plant is started in (``None``: the parameter file's).
    """

    namespace: str
    start: StartStance | None
    nodes: list[NodeSpec]
    group: ProcessGroup
    target: str = ''
    client: GraphClient | None = None
    code: int = 1
    respawner: RespawningGroup | None = None
    stance: StartStance | None = None  # where it starts on the truss

    def processes(self) -> dict[str, dict]:
        """Deaths and restarts of each node that died (the walk summary's ``processes``)."""
        return {} if self.respawner is None else self.respawner.summary()

    def recording(self) -> dict | None:
        """Return what the walker's bag says it lacks so far (None without a bag).

        The messages lost on the way to the recorder and the spans a recorder started again
        did not record, from the bag's ``metadata.yaml`` as the recorder last flushed it
        (:func:`walker_bag.core.losses.recorded_losses`).
        """
        bags = bag_paths([self])
        if not bags:
            return None
        try:
            return recorded_losses(dict(read_metadata(bags[0]).custom_data))
        except (MetadataError, OSError):
            return None

    @property
    def label(self) -> str:
        """The namespace without slashes (``walker_2``): how the walker is named in output."""
        return self.namespace.strip('/')


def describe_walkers(options: SessionOptions, configuration, out: Path,
                     env: dict) -> list[GraphWalker]:
    """Each walker's graph and process group (nothing started yet).

    Each graph has the options' extra nodes, remaps and per-node parameters
    (:func:`with_node_settings`).

    Raises
    ------
    ValueError
        If the truss has no room for that many walkers, or a node setting names no node.
    """
    if options.walkers == 1:
        nodes = walker_graph(configuration.path, options.namespace, sim_time=options.sim_time,
                             record=options.record, bag_path=out / 'bag',
                             parameters=graph_parameters(options),
                             grouped_controllers=options.grouped_controllers,
                             foxglove_port=options.foxglove_port,
                             plant_state_file=out / PLANT_STATE_FILE,
                             plant_params_file=plant_file(options),
                             survey_file=out / SURVEY_FILE_NAME)
        nodes = with_node_settings(nodes, options)
        stance = start_stances(configuration, 1)[0]  # the parameter file's own start
        return [GraphWalker(options.namespace, None, nodes, ProcessGroup(out / 'logs', env),
                            stance=stance)]
    graphs = several_walkers(configuration, options.walkers, options.sim_time, options.record, out,
                             graph_parameters(options),
                             grouped_controllers=options.grouped_controllers, state_dir=out)
    walkers = []
    for index, (namespace, start, nodes) in enumerate(graphs):
        logs = out / 'logs' if index == 0 else out / 'logs' / namespace.strip('/')
        walkers.append(GraphWalker(namespace, start if index else None,
                                   with_node_settings(nodes, options),
                                   ProcessGroup(logs, env), stance=start))
    return walkers


def with_node_settings(nodes: list[NodeSpec], options: SessionOptions) -> list[NodeSpec]:
    """Return a walker's nodes with the options' extra nodes, remaps and node parameters.

    The extra nodes come last; each remap and parameter goes to every node whose name matches
    its pattern, after the node's own (a later ``-p`` wins).

    Raises
    ------
    ValueError
        If a pattern matches no node of the graph, or an extra node takes a name in use.
    """
    names = [spec.name for spec in nodes]
    for spec in options.extra_nodes:
        if spec.name in names:
            raise ValueError(f'extra node {spec.name!r}: the graph has a node of that name')
        names.append(spec.name)
    for field in ('node_parameters', 'remaps'):
        for pattern, *_ in getattr(options, field):
            if not any(fnmatch.fnmatchcase(name, pattern) for name in names):
                raise ValueError(f'{field}: {pattern!r} names no node of the graph (its nodes: '
                                 f'{", ".join(names)})')
    customised = []
    for spec in [*nodes, *options.extra_nodes]:
        parameters = tuple((name, value) for pattern, name, value in options.node_parameters
                           if fnmatch.fnmatchcase(spec.name, pattern))
        remaps = tuple((source, target) for pattern, source, target in options.remaps
                       if fnmatch.fnmatchcase(spec.name, pattern))
        if parameters or remaps:
            spec = dataclasses.replace(spec, parameters=(*spec.parameters, *parameters),
                                       remaps=(*spec.remaps, *remaps))
        customised.append(spec)
    return customised


def plant_file(options: SessionOptions) -> Path | None:
    """Return the plant's own parameter file, resolved (``None``: the graph's one file)."""
    return Path(options.plant_params_file).resolve() if options.plant_params_file else None


def bag_paths(walkers: list[GraphWalker]) -> list[Path]:
    """List the bag directory each walker's recorder will write (none when not recording)."""
    bags = []
    for walker in walkers:
        for spec in walker.nodes:
            if spec.executable == 'recorder_node':
                params = dict(spec.parameters)
                bags.append(Path(params['recorder.directory']) / params['recorder.bag_name'])
    return bags


def survey_files(walkers: list[GraphWalker]) -> list[Path]:
    """List the truss survey file each walker's supervisor keeps its map in."""
    files = []
    for walker in walkers:
        for spec in walker.nodes:
            path = dict(spec.parameters).get(SURVEY_FILE_PARAMETER)
            if spec.executable == 'supervisor_node' and path:
                files.append(Path(path))
    return files


def graph_parameters(options: SessionOptions) -> tuple[tuple[str, str], ...]:
    """Return the overrides for every node.

    The recorder's splits, the real-time priority asked for, and the gate.

    With the loop composed in sim time: at two to three times real time the supervisor,
    outside the lock-step, decides late in simulated time; the plant then waits for its
    release (``sim.wait_for_decisions``).
    """
    size, duration, files = options.bag_split
    overrides = (('recorder.max_bag_size', str(size)),
                 ('recorder.max_bag_duration', repr(float(duration))),
                 ('recorder.max_bag_files', str(files)))
    if options.realtime and not options.sim_time:
        overrides += (('timing.realtime_priority', str(options.realtime)),)
    if options.composed_loop and options.sim_time:
        overrides += (('sim.wait_for_decisions', 'true'),)
    return overrides + tuple(options.overrides)


def launch(walker: GraphWalker, options: SessionOptions, params_file: Path,
           wrap: Wrap | None = None) -> None:
    """Start a walker's graph: one process per node, the loop composed, or one process.

    ``wrap(spec, command)``, if given, returns the command each process is started with
    instead (``command`` ``None``: the node's installed executable), e.g. through a probe
    that times the loop from the inside.
    """
    wrap = wrap or (lambda _spec, command: command)
    if not (options.composed or options.composed_loop):
        for spec in walker.nodes:
            walker.group.start(spec, wrap(spec, None))
        return
    plant = next(n for n in walker.nodes if n.executable == 'plant_node')
    supervisor = next(n for n in walker.nodes if n.executable == 'supervisor_node')
    bags = bag_paths([walker])
    loop = LOOP_NODES if options.composed_loop else None
    command = composed_command(params_file, walker.namespace, options.sim_time,
                               bool(bags) and loop is None,
                               bags[0] if bags and loop is None else None, walker.start,
                               dict(plant.remaps).get('/clock'), graph_parameters(options),
                               grouped_controllers=options.grouped_controllers, only=loop,
                               plant_params_file=plant_file(options),
                               plant_state_file=dict(plant.parameters).get('state_file'),
                               survey_file=dict(supervisor.parameters).get(
                                   SURVEY_FILE_PARAMETER))
    composed = NodeSpec('walker_bringup', 'composed_graph', 'graph' if loop is None else 'loop',
                        walker.namespace, str(params_file))
    walker.group.start(composed, wrap(composed, command))
    # beside the composed process: the bridge serves any graph; the extra nodes are the caller's
    beside = {FOXGLOVE_NODE, *(spec.name for spec in options.extra_nodes)}
    for spec in walker.nodes:
        if (spec.name not in loop) if loop is not None else spec.name in beside:
            walker.group.start(spec, wrap(spec, None))


def recover_bags(bags: list[Path]) -> list[str]:
    """Complete, in place, the bags a killed recorder left cut; say what was done.

    The graph is down: no recorder holds a bag's lock any more
    (:func:`walker_bag.core.bag_recovery.recover_in_place`).
    """
    from walker_bag.core.bag_recovery import recover_in_place
    from walker_bag.core.errors import BagError

    said = []
    for bag in bags:
        if not bag.is_dir():
            continue
        try:
            report = recover_in_place(bag)
        except (BagError, OSError) as error:
            said.append(f'[walker] error: the bag {bag} cannot be recovered: {error}')
            continue
        if report is not None and report.files:
            said.append(f'[walker] the recorder of {bag} did not close it: its cut file '
                        f'completed in place, {report.message_count} messages (the cut file '
                        f'kept as {report.files[0].path.name}.incomplete)')
    return said


def namespaces_in_use(walkers: list[GraphWalker], context) -> str:
    """Why the walkers' namespaces are taken by a live graph on this domain ('' when free).

    Two graphs in one namespace would answer each other's goals and services: a walk would
    run on the other robot.
    """
    for walker in walkers:
        client = GraphClient(walker.namespace, context)
        try:
            names = client.live_nodes()
        finally:
            client.close()
        if names:
            domain = os.environ.get('ROS_DOMAIN_ID', '0')
            shown = ', '.join(names[:5]) + (', ...' if len(names) > 5 else '')
            return (f'a walker graph is already running in {walker.namespace} on ROS domain '
                    f'{domain} (nodes {shown}): stop it, or give this one another '
                    f'--namespace or ROS_DOMAIN_ID')
    return ''
