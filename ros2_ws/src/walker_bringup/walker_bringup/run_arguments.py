"""run_all.py's command line: its options, each checked, and how they combine.

:func:`parse_arguments` refuses what contradicts itself (``--composed`` with
``--composed-loop``, a graph's own option with ``--headless``) with argparse's usage error;
:func:`walker_bringup.run.session_options` turns the rest into the walk session's options.
"""

from __future__ import annotations

import argparse

from walker_bringup import argument_types as types
from walker_bringup.core.respawn import DEFAULT_DELAY, DEFAULT_LIMIT
from walker_bringup.transport import DEFAULT_TRANSPORT, TRANSPORTS

__all__ = ['parse_arguments', 'REALTIME_PRIORITY', 'FOXGLOVE_PORT', 'SERVE_SPLIT']

#: SCHED_FIFO priority of the control loop with --realtime (ros2_control's thread_priority).
REALTIME_PRIORITY = 50
#: Port of the Foxglove WebSocket server with --foxglove (foxglove_bridge's default).
FOXGLOVE_PORT = 8765
#: --serve's recording: files of at most 256 MiB or 15 min, the newest 8 kept (an idle sim-time
#: graph records about 6 MiB a minute: without a limit a long session fills the disk)
SERVE_SPLIT = (256 * 2**20, 900.0, 8)


def parse_arguments(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line options of ``run_all.py``."""
    parser = argparse.ArgumentParser(
        prog='run_all.py',
        description='Bring the walker graph up on the pybullet plant, walk to a target node, '
                    'record the walk and print a per-step summary.')
    parser.add_argument('--target', default='n4_3',
                        help='truss node to walk to (default: %(default)s)')
    parser.add_argument('--params-file', default=None,
                        help='parameter file (default: the installed walker.yaml)')
    parser.add_argument('--plant-params-file', default=None,
                        help="the plant's own parameter file (default: --params-file): the "
                             'robot as it really is, while the controllers, the planner and '
                             'the supervisor keep the model (a campaign run)')
    parser.add_argument('--param', '-p', dest='params', action='append', default=[],
                        type=types.parameter_assignment, metavar='NAME:=VALUE',
                        help="a parameter's value over the files' for every node, as ros2 "
                             "run's -p (repeatable; e.g. -p gripper.camera.enabled:=true)")
    parser.add_argument('--sim-time', action='store_true',
                        help='run on the plant clock, lock-stepped, as fast as the graph allows '
                             '(default: real time, like hardware)')
    parser.add_argument('--no-record', dest='record', action='store_false',
                        help='do not record a rosbag2 bag of the walk (and so no report)')
    parser.add_argument('--no-report', dest='report', action='store_false',
                        help='do not write the walk report (figures, animation) from the bag')
    parser.add_argument('--out', default=None,
                        help='output directory (default: runs/<date-time>)')
    parser.add_argument('--namespace', default='/walker', help='robot namespace')
    parser.add_argument('--startup-timeout', type=float, default=120.0,
                        help='seconds to wait for the graph to come up')
    parser.add_argument('--walk-timeout', type=float, default=600.0,
                        help='seconds the walk may take (wall clock)')
    parser.add_argument('--no-walk', dest='walk', action='store_false',
                        help='bring the graph up, report it ready, and shut it down')
    parser.add_argument('--serve', action='store_true',
                        help='bring the graph up and keep it running, without walking, until '
                             'Ctrl-C: for an operator with walkerctl or the ros2 tools. It '
                             'records all along, split as --max-bag-size, --max-bag-duration '
                             'and --max-bag-files say (by default files of at most '
                             f'{SERVE_SPLIT[0] // 2**20} MiB or {SERVE_SPLIT[1]:g} s, the newest '
                             f'{SERVE_SPLIT[2]} kept: at most about '
                             f'{SERVE_SPLIT[0] * SERVE_SPLIT[2] // 2**30} GiB and '
                             f'{SERVE_SPLIT[1] * SERVE_SPLIT[2] / 3600:g} h of recording)')
    parser.add_argument('--max-bag-size', type=types.non_negative_int, default=None,
                        metavar='BYTES',
                        help='the bag goes on in a new file once its file holds this many '
                             'bytes, as ros2 bag record --max-bag-size; 0: never (default: 0, '
                             f'with --serve {SERVE_SPLIT[0]})')
    parser.add_argument('--max-bag-duration', type=types.non_negative_float, default=None,
                        metavar='SECONDS',
                        help='the bag goes on in a new file once its file spans this many '
                             'seconds, as ros2 bag record --max-bag-duration; 0: never '
                             f'(default: 0, with --serve {SERVE_SPLIT[1]:g})')
    parser.add_argument('--max-bag-files', type=types.non_negative_int, default=None, metavar='N',
                        help='the bag keeps its newest N files, deleting older ones; 0: every '
                             f'file (default: 0, with --serve {SERVE_SPLIT[2]})')
    parser.add_argument('--respawn-delay', type=types.non_negative_float, default=DEFAULT_DELAY,
                        metavar='SECONDS',
                        help='a node process that dies is started again after this many '
                             "seconds, as launch's respawn_delay (default: %(default)s)")
    parser.add_argument('--respawn-limit', type=types.non_negative_int, default=DEFAULT_LIMIT,
                        metavar='N',
                        help='restarts in a row of one node (each dying within a minute of its '
                             'start) before the graph is given up as dead: the walker is held '
                             'and everything shut down (exit code 5); 0: never start a node '
                             'again (default: %(default)s)')
    parser.add_argument('--transport', choices=TRANSPORTS, default=None,
                        help="how the graph's node processes reach each other: udp (UDP on "
                             'loopback, walker_bringup/config/fastdds_udp_loopback.xml; a node '
                             'started again after a crash is heard as before) or shm (the rmw '
                             "default, Fast DDS's shared memory, with any profile "
                             'FASTRTPS_DEFAULT_PROFILES_FILE names; reached from other hosts) '
                             f'(default: {DEFAULT_TRANSPORT}, or shm when ROS_STATIC_PEERS names '
                             'peers on other hosts)')
    parser.add_argument('--quiet', action='store_true', help='print only the summary')
    parser.add_argument('--composed', action='store_true',
                        help='run each graph in one process (composition) instead of one '
                             'process per node; in sim time with the five joint controllers '
                             'as one node, the plant, the planner and the controllers '
                             'exchanging states and setpoints by call')
    parser.add_argument('--composed-loop', action='store_true',
                        help='run the control loop (the plant and the five joint controllers '
                             'as one node) in one process, where in sim time they exchange '
                             'states and efforts by call; the planner, the supervisor and the '
                             'recorder as processes of their own (implies '
                             '--grouped-controllers)')
    parser.add_argument('--grouped-controllers', action='store_true',
                        help='run the five joint controllers as one node and process '
                             '(joint_controllers_node: one state in, one effort message out '
                             'per period) instead of one each')
    parser.add_argument('--realtime', nargs='?', type=types.priority, const=REALTIME_PRIORITY,
                        default=0, metavar='PRIORITY',
                        help='on the wall clock, run the control loop (plant, controllers) '
                             'under SCHED_FIFO at PRIORITY (default %(const)s, as ros2_control) '
                             'and the supervisor and planner below it, when permitted (root, '
                             'CAP_SYS_NICE or an rtprio limit). Off by default: a real-time '
                             'graph outranks every ordinary process and on a small machine '
                             'starves its own tools (the ros2 CLI, an editor); ignored in sim '
                             'time')
    parser.add_argument('--foxglove', action='store_true',
                        help="serve the graph's topics to Foxglove over its WebSocket protocol "
                             'on 127.0.0.1 (open ws://127.0.0.1:PORT in the Foxglove app, with '
                             'the layout walker_viz/config/walker.foxglove.json)')
    parser.add_argument('--foxglove-port', type=types.port, default=FOXGLOVE_PORT, metavar='N',
                        help='port of the Foxglove server (default: %(default)s, as '
                             'foxglove_bridge)')
    parser.add_argument('--headless', action='store_true',
                        help='walk without ROS: the plant, controller, planner and '
                             'supervisor cores in one lock-step loop in this process, no DDS, '
                             'many times faster than real time; the same summary, bag and '
                             'report (walker_headless)')
    parser.add_argument('--truss-survey', default=None, metavar='FILE',
                        help="start from a truss survey (a walk's truss_survey.yaml, "
                             "docs/walking.md); the walk's own survey is written to "
                             '<out>/truss_survey.yaml')
    parser.add_argument('--walkers', type=types.positive_count, default=1, metavar='N',
                        help='run N walkers side by side (namespaces /walker, /walker_2, ...), '
                             'each from its own start, walking the same route moved with it '
                             '(default: 1)')
    args = parser.parse_args(argv)
    if args.composed_loop and args.composed:
        parser.error('--composed-loop composes the loop only; --composed the whole graph: '
                     'choose one')
    if args.headless:
        graph_only = [option for option, given in (
            ('--composed', args.composed), ('--composed-loop', args.composed_loop),
            ('--grouped-controllers', args.grouped_controllers), ('--serve', args.serve),
            ('--no-walk', not args.walk), ('--walkers', args.walkers > 1)) if given]
        if graph_only:
            parser.error(f'--headless runs no graph: leave {", ".join(graph_only)} out')
    args.grouped_controllers = args.grouped_controllers or args.composed_loop \
        or (args.composed and args.sim_time)  # composed in sim time: the loop by call
    serving = (SERVE_SPLIT if args.serve else (0, 0.0, 0))
    for name, default in zip(('max_bag_size', 'max_bag_duration', 'max_bag_files'), serving,
                             strict=True):
        if getattr(args, name) is None:
            setattr(args, name, default)
    if args.plant_params_file is not None and args.walkers > 1:
        parser.error('--plant-params-file is for one walker: leave --walkers out')
    return args
