"""The composed graph's process: its command line and its ``main`` (``composed_graph``).

``ros2 run walker_bringup composed_graph`` takes :func:`walker_graph`'s options, builds the
graph's nodes in this one process (:class:`walker_bringup.composition.ComposedGraph`) and spins
them until SIGINT or SIGTERM; :func:`composed_command` is the command line ``run_all.py
--composed`` and the benchmarks start it with.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import sys
from collections.abc import Sequence
from pathlib import Path

from walker_bringup.composition import APPEND_BAG, ComposedGraph, CompositionError
from walker_bringup.graph import NodeSpec, StartStance, executable_path, walker_graph

__all__ = ['parse_arguments', 'graph_from_arguments', 'composed_command', 'main']


def parse_arguments(argv: Sequence[str] | None = None) -> argparse.Namespace:
    """Command-line options of ``composed_graph`` (those of :func:`walker_graph`)."""
    parser = argparse.ArgumentParser(
        prog='composed_graph',
        description="Run the walker's whole node graph in one process (composition).")
    parser.add_argument('--params-file', default=None,
                        help='parameter file (default: the installed walker.yaml)')
    parser.add_argument('--plant-params-file', default=None,
                        help="the plant's own parameter file (default: --params-file): the "
                             'robot as it really is, the other nodes keeping the model')
    parser.add_argument('--namespace', default='/walker', help='robot namespace')
    parser.add_argument('--sim-time', action='store_true',
                        help='lock-stepped on the plant clock (default: real time)')
    parser.add_argument('--record', action='store_true', help='also run the recorder')
    parser.add_argument('--bag-path', default=None, help="the recorder's bag directory")
    parser.add_argument('--append-bag', action='store_true',
                        help='the recorder continues the bag at --bag-path in a new file (the '
                             'one a killed process left cut completed first) instead of '
                             'refusing a bag that exists: the composed process started again')
    parser.add_argument('--plant-state-file', default=None, metavar='PATH',
                        help="the plant's state snapshot: a plant started again restores the "
                             'physical state it had from it (walker_sim.core.snapshot)')
    parser.add_argument('--truss-survey-file', default=None, metavar='PATH',
                        help="the supervisor's truss survey file (supervisor.truss_survey_file): "
                             'its map starts from it where it exists and is kept in it')
    parser.add_argument('--start', default=None, metavar='GRIPPER,BASE_NODE,OTHER_NODE',
                        help="start stance of the plant (default: the parameter file's)")
    parser.add_argument('--clock-topic', default=None,
                        help='remap /clock to this topic in every node')
    parser.add_argument('-p', '--param', action='append', default=[], metavar='NAME:=VALUE',
                        help='parameter override for every node (repeatable)')
    parser.add_argument('--grouped-controllers', action='store_true',
                        help='the five joint controllers as one node (joint_controllers_node)')
    parser.add_argument('--only', default=None, metavar='NAME[,NAME...]',
                        help='compose only these nodes of the graph (e.g. plant,controllers: '
                             'the control loop); the others are left to run elsewhere')
    args = parser.parse_args(argv)
    parameters = []
    for text in args.param:
        name, separator, value = text.partition(':=')
        if not separator or not name or not value:
            parser.error(f'--param {text!r}: expected NAME:=VALUE, e.g. '
                         'timing.control_rate:=1000.0')
        parameters.append((name, value))
    args.param = tuple(parameters)
    if args.start is not None:
        parts = args.start.split(',')
        if len(parts) != 3 or not all(parts):
            parser.error(f'--start {args.start!r}: expected GRIPPER,BASE_NODE,OTHER_NODE, '
                         'e.g. a,n1_2,n2_2')
        args.start = StartStance(*parts)
    if args.bag_path is not None and not args.record:
        parser.error('--bag-path needs --record')
    if args.append_bag and not args.record:
        parser.error('--append-bag needs --record')
    if args.only is not None:
        args.only = tuple(name for name in args.only.split(',') if name)
        if not args.only:
            parser.error('--only: expected node names, e.g. plant,controllers')
    return args


def graph_from_arguments(args: argparse.Namespace) -> list[NodeSpec]:
    """Return the graph the options describe (what the separate processes would run)."""
    from walker_core.robot_parameters import default_parameter_file

    params_file = Path(args.params_file or default_parameter_file()).resolve()
    plant_file = args.plant_params_file and Path(args.plant_params_file).resolve()
    state_file = getattr(args, 'plant_state_file', None)
    survey_file = getattr(args, 'truss_survey_file', None)
    specs = walker_graph(params_file, args.namespace, sim_time=args.sim_time,
                         record=args.record, bag_path=args.bag_path, start=args.start,
                         clock_topic=args.clock_topic, parameters=args.param,
                         grouped_controllers=args.grouped_controllers,
                         plant_params_file=plant_file,
                         plant_state_file=state_file and Path(state_file).resolve(),
                         survey_file=survey_file and Path(survey_file).resolve())
    if getattr(args, 'append_bag', False):
        specs = [dataclasses.replace(spec, parameters=(*spec.parameters, APPEND_BAG))
                 if spec.executable == 'recorder_node' else spec for spec in specs]
    only = getattr(args, 'only', None)
    if only is None:
        return specs
    unknown = sorted(set(only) - {spec.name for spec in specs})
    if unknown:
        raise CompositionError(f'--only {",".join(only)}: the graph has no node '
                               f'{", ".join(unknown)} (it has '
                               f'{", ".join(spec.name for spec in specs)})')
    return [spec for spec in specs if spec.name in only]


def composed_command(params_file: str | Path, namespace: str = '/walker',
                     sim_time: bool = False, record: bool = False,
                     bag_path: str | Path | None = None, start: StartStance | None = None,
                     clock_topic: str | None = None,
                     parameters: tuple[tuple[str, str], ...] = (),
                     executable: str | None = None,
                     grouped_controllers: bool = False,
                     only: Sequence[str] | None = None,
                     plant_params_file: str | Path | None = None,
                     plant_state_file: str | Path | None = None,
                     survey_file: str | Path | None = None) -> list[str]:
    """Return the command line of the composed graph with :func:`walker_graph`'s arguments."""
    command = [executable or str(executable_path('walker_bringup', 'composed_graph')),
               '--params-file', str(params_file), '--namespace', namespace]
    if plant_params_file is not None:
        command += ['--plant-params-file', str(plant_params_file)]
    if sim_time:
        command.append('--sim-time')
    if record:
        command.append('--record')
        if bag_path is not None:
            command += ['--bag-path', str(bag_path)]
    if start is not None:
        command += ['--start', f'{start.base_gripper},{start.base_node},{start.other_node}']
    if clock_topic:
        command += ['--clock-topic', clock_topic]
    for name, value in parameters:
        command += ['--param', f'{name}:={value}']
    if grouped_controllers:
        command.append('--grouped-controllers')
    if only:
        command += ['--only', ','.join(only)]
    if plant_state_file is not None:
        command += ['--plant-state-file', str(plant_state_file)]
    if survey_file is not None:
        command += ['--truss-survey-file', str(survey_file)]
    return command


def main(argv: Sequence[str] | None = None) -> int:
    """Run the composed graph until SIGINT or SIGTERM; return the exit code.

    The exit codes of every node process (:mod:`walker_runtime.node_main`): 2 when a node
    refuses to start.
    """
    import rclpy

    from walker_runtime.node_main import EXIT_OK, EXIT_REFUSED
    from walker_runtime.spinning import init_node_process

    args = parse_arguments(sys.argv[1:] if argv is None else argv)
    try:
        specs = graph_from_arguments(args)
    except CompositionError as error:
        print(f'[composed_graph] {error}', file=sys.stderr, flush=True)
        return EXIT_REFUSED
    context = rclpy.context.Context()
    stop = init_node_process(context=context)
    graph = None
    code = EXIT_OK
    try:
        graph = ComposedGraph(specs, context)
        print(f'[composed_graph] {len(graph.nodes)} nodes in one process: '
              + ', '.join(spec.full_name for spec, _, _ in graph.nodes)
              + ({'': '', 'loop': '; the plant and the controllers exchange by call',
                  'graph': '; the plant, the planner and the controllers exchange by call'}
                 [graph.loop_by_call]), flush=True)
        # the process is the loop's: on the wall clock it asks for the plant's real-time
        # priority, as the plant's own process does (its other nodes share the interpreter)
        with contextlib.suppress(KeyError):  # a graph without its plant asks nothing
            graph.node('plant').request_realtime_scheduling()
        graph.spin(stop)
    except CompositionError as error:
        print(f'[composed_graph] {error}', file=sys.stderr, flush=True)
        code = EXIT_REFUSED
    finally:
        if graph is not None:
            graph.destroy()
        rclpy.try_shutdown(context=context)
    return code


if __name__ == '__main__':
    sys.exit(main())
