"""The main job: bring the graph up, walk to a target node, record, summarise, shut down, report.

Every node runs as a separate process (:mod:`walker_bringup.processes`), or, with
``--composed``, the whole graph runs in one process (:mod:`walker_bringup.composition`) under
the same supervision. ``--grouped-controllers`` runs the five joint controllers as one node
(``joint_controllers_node``) instead of five, either way. With ``--walkers N``, N graphs run
side by side in the namespaces ``/walker``, ``/walker_2``, ..., each from its own start on the
same truss layout and each walking the same route moved with its start (their plants are
separate physics worlds: they do not collide). A graph counts as up when every node is in the
ROS graph, every server answers and the supervisor has heard from every source it watches
(checked, not after a sleep).
A node process that dies is reported at once with the end of its log and started again after
``--respawn-delay`` seconds, as launch's ``respawn`` (:mod:`walker_bringup.respawning`; the
supervisor holds a step it sees interrupted, and ``resume`` completes it); each node's deaths
and restarts go into the walk summary (``processes``). A node that dies more than
``--respawn-limit`` times in a row is given up: the walk is stopped safely (the supervisor is
told to hold, the walk goal cancelled), and everything is shut down (exit code 5). Ctrl-C does
the same (exit code 130). Nothing is left running: each child is interrupted, then terminated,
then killed. See docs/reliability.md.

Once the graph is down (and with it the recorder, which closes the bag), the walk report is
made from the bag (:mod:`walker_report`) into ``<out>/report``, unless ``--no-report``; it is
made after a failed walk too, not after Ctrl-C. With several walkers, the report is the first
walker's (its bag is ``<out>/bag``; the others' bags are beside it).
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import math
import os
import signal
import sys
import threading
import time
from pathlib import Path

from walker_bringup.composed_process import composed_command
from walker_bringup.composition import LOOP_NODES
from walker_bringup.graph import (
    FOXGLOVE_NODE, NodeSpec, StartStance, several_walkers, walker_graph, walker_targets)
from walker_bringup.graph_client import (
    GoalRejectedError, GraphClient, GraphNotReadyError, WalkInterruptedError, init_context)
from walker_bringup.core.respawn import DEFAULT_DELAY, DEFAULT_LIMIT, RespawnPolicy
from walker_bringup.processes import ProcessGroup
from walker_bringup.respawning import RespawningGroup
from walker_bringup.summary import format_table, rows_from_reports, write_json
from walker_bringup.transport import (
    DEFAULT_TRANSPORT, PROFILES_VARIABLE, STATIC_PEERS_VARIABLE, TRANSPORTS, default_transport,
    graph_environment)
from walker_report.walk_report import report_after_walk
from walker_core.progress import ProgressLine, walk_progress

__all__ = ['main', 'parse_arguments', 'walk_feedback_text', 'write_report']

SERVE_POLL = 0.2  # [s] longest wait of --serve before it sees Ctrl-C or a dead node
_DEATH_REPORT_LEAD = 0.5  # [s] between a death's report on /diagnostics and the hold it asks
#: SCHED_FIFO priority of the control loop with --realtime (ros2_control's thread_priority).
REALTIME_PRIORITY = 50
#: Port of the Foxglove WebSocket server with --foxglove (foxglove_bridge's default).
FOXGLOVE_PORT = 8765
#: --serve's recording: files of at most 256 MiB or 15 min, the newest 8 kept (an idle sim-time
#: graph records about 6 MiB a minute: without a limit a long session fills the disk)
SERVE_SPLIT = (256 * 2**20, 900.0, 8)
#: The plant's state snapshot in the output directory (a plant started again restores it).
PLANT_STATE_FILE = 'plant_state.json'


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
    parser.add_argument('--max-bag-size', type=_non_negative_int, default=None, metavar='BYTES',
                        help='the bag goes on in a new file once its file holds this many '
                             'bytes, as ros2 bag record --max-bag-size; 0: never (default: 0, '
                             f'with --serve {SERVE_SPLIT[0]})')
    parser.add_argument('--max-bag-duration', type=_non_negative_float, default=None,
                        metavar='SECONDS',
                        help='the bag goes on in a new file once its file spans this many '
                             'seconds, as ros2 bag record --max-bag-duration; 0: never '
                             f'(default: 0, with --serve {SERVE_SPLIT[1]:g})')
    parser.add_argument('--max-bag-files', type=_non_negative_int, default=None, metavar='N',
                        help='the bag keeps its newest N files, deleting older ones; 0: every '
                             f'file (default: 0, with --serve {SERVE_SPLIT[2]})')
    parser.add_argument('--respawn-delay', type=_non_negative_float, default=DEFAULT_DELAY,
                        metavar='SECONDS',
                        help='a node process that dies is started again after this many '
                             "seconds, as launch's respawn_delay (default: %(default)s)")
    parser.add_argument('--respawn-limit', type=_non_negative_int, default=DEFAULT_LIMIT,
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
    parser.add_argument('--realtime', nargs='?', type=_priority, const=REALTIME_PRIORITY,
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
    parser.add_argument('--foxglove-port', type=_port, default=FOXGLOVE_PORT, metavar='N',
                        help='port of the Foxglove server (default: %(default)s, as '
                             'foxglove_bridge)')
    parser.add_argument('--headless', action='store_true',
                        help='walk without ROS: the plant, controller, planner and '
                             'supervisor cores in one lock-step loop in this process, no DDS, '
                             'many times faster than real time; the same summary, bag and '
                             'report (walker_headless)')
    parser.add_argument('--walkers', type=_walker_count, default=1, metavar='N',
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


def _priority(text: str) -> int:
    try:
        priority = int(text)
    except ValueError:
        priority = 0
    if not 1 <= priority <= 99:
        raise argparse.ArgumentTypeError(f'expected a SCHED_FIFO priority 1..99, got {text!r}')
    return priority


def _port(text: str) -> int:
    try:
        port = int(text)
    except ValueError:
        port = -1
    if not 0 <= port <= 65535:
        raise argparse.ArgumentTypeError(f'expected a TCP port 0..65535 (0: any free one), got '
                                         f'{text!r}')
    return port
def _non_negative_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < 0:
        raise argparse.ArgumentTypeError(f'expected a whole number >= 0, got {text!r}')
    return value


def _non_negative_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value >= 0.0):
        raise argparse.ArgumentTypeError(f'expected a number of seconds >= 0, got {text!r}')
    return value


def _walker_count(text: str) -> int:
    try:
        count = int(text)
    except ValueError:
        count = 0
    if count < 1:
        raise argparse.ArgumentTypeError(f'expected a positive number of walkers, got {text!r}')
    return count


@dataclasses.dataclass
class _Walker:
    """One walker's graph in a run: its nodes, its processes, its client, its outcome."""

    namespace: str
    start: StartStance | None
    nodes: list[NodeSpec]
    group: ProcessGroup
    target: str = ''
    client: GraphClient | None = None
    code: int = 1
    respawner: RespawningGroup | None = None

    def processes(self) -> dict[str, dict]:
        """Deaths and restarts of each node that died (the walk summary's ``processes``)."""
        return {} if self.respawner is None else self.respawner.summary()

    @property
    def label(self) -> str:
        return self.namespace.strip('/')


def _describe_walkers(args, configuration, out: Path, env: dict) -> list[_Walker]:
    """Each walker's graph and process group (nothing started yet).

    Raises
    ------
    ValueError
        If the truss has no room for that many walkers, or the target is not a node.
    """
    if args.walkers == 1:
        nodes = walker_graph(configuration.path, args.namespace, sim_time=args.sim_time,
                             record=args.record, bag_path=out / 'bag',
                             parameters=_graph_parameters(args),
                             grouped_controllers=args.grouped_controllers,
                             foxglove_port=args.foxglove_port if args.foxglove else None,
                             plant_state_file=out / PLANT_STATE_FILE,
                             plant_params_file=_plant_file(args))
        return [_Walker(args.namespace, None, nodes, ProcessGroup(out / 'logs', env),
                        args.target)]
    graphs = several_walkers(configuration, args.walkers, args.sim_time, args.record, out,
                             _graph_parameters(args),
                             grouped_controllers=args.grouped_controllers, state_dir=out)
    targets = walker_targets(configuration, args.target, [start for _, start, _ in graphs])
    walkers = []
    for index, ((namespace, start, nodes), target) in enumerate(zip(graphs, targets,
                                                                     strict=True)):
        logs = out / 'logs' if index == 0 else out / 'logs' / namespace.strip('/')
        walkers.append(_Walker(namespace, start if index else None, nodes,
                               ProcessGroup(logs, env), target))
    return walkers


def _plant_file(args) -> Path | None:
    """Return the plant's own parameter file, resolved (``None``: the graph's one file)."""
    return Path(args.plant_params_file).resolve() if args.plant_params_file else None


def _bag_paths(walkers: list[_Walker]) -> list[Path]:
    """List the bag directory each walker's recorder will write (none when not recording)."""
    bags = []
    for walker in walkers:
        for spec in walker.nodes:
            if spec.executable == 'recorder_node':
                params = dict(spec.parameters)
                bags.append(Path(params['recorder.directory']) / params['recorder.bag_name'])
    return bags


def _graph_parameters(args) -> tuple[tuple[str, str], ...]:
    """Return the overrides for every node.

    The recorder's splits, the real-time priority asked for, and the gate.

    With the loop composed in sim time: at two to three times real time the supervisor,
    outside the lock-step, decides late in simulated time; the plant then waits for its
    release (``sim.wait_for_decisions``).
    """
    overrides = (('recorder.max_bag_size', str(args.max_bag_size)),
                 ('recorder.max_bag_duration', repr(float(args.max_bag_duration))),
                 ('recorder.max_bag_files', str(args.max_bag_files)))
    if args.realtime and not args.sim_time:
        overrides += (('timing.realtime_priority', str(args.realtime)),)
    if args.composed_loop and args.sim_time:
        overrides += (('sim.wait_for_decisions', 'true'),)
    return overrides


def _launch(walker: _Walker, args, params_file: Path) -> None:
    """Start a walker's graph: one process per node, the loop composed, or one process."""
    if not (args.composed or args.composed_loop):
        for spec in walker.nodes:
            walker.group.start(spec)
        return
    plant = next(n for n in walker.nodes if n.executable == 'plant_node')
    bags = _bag_paths([walker])
    loop = LOOP_NODES if args.composed_loop else None
    command = composed_command(params_file, walker.namespace, args.sim_time,
                               bool(bags) and loop is None,
                               bags[0] if bags and loop is None else None, walker.start,
                               dict(plant.remaps).get('/clock'), _graph_parameters(args),
                               grouped_controllers=args.grouped_controllers, only=loop,
                               plant_params_file=_plant_file(args),
                               plant_state_file=dict(plant.parameters).get('state_file'))
    walker.group.start(NodeSpec('walker_bringup', 'composed_graph',
                                'graph' if loop is None else 'loop', walker.namespace,
                                str(params_file)), command)
    for spec in walker.nodes:  # beside the composed process: the bridge serves any graph
        if (spec.name not in loop) if loop is not None else spec.name == FOXGLOVE_NODE:
            walker.group.start(spec)


def main(argv: list[str] | None = None) -> int:
    """Run the main job; return the exit code (0 when every walk reached its target).

    The process's own participant is made with the graph's transport profile; the caller's
    environment is given back as it was, so a later graph started from the same process (a
    test, a campaign) chooses its own transport again.
    """
    before = os.environ.get(PROFILES_VARIABLE)
    try:
        return _run(argv)
    finally:
        if before is None:
            os.environ.pop(PROFILES_VARIABLE, None)
        else:
            os.environ[PROFILES_VARIABLE] = before


def _run(argv: list[str] | None) -> int:
    args = parse_arguments(argv)
    if args.headless:
        from walker_headless.run import run_headless

        return run_headless(args)
    from walker_config.core.configuration import load_configuration
    from walker_core.parameter_schema import ParameterError
    from walker_core.truss import Truss

    progress = ProgressLine(args.quiet, stream=sys.stdout)
    # Everything the command line names is checked before anything is started or written:
    # every section and every rule between them, the target.
    try:
        configuration = load_configuration(args.params_file)
    except ParameterError as error:
        progress.error(f'[walker] error: {args.params_file or "the installed walker.yaml"}: '
                       f'{error}')
        return 2
    if args.plant_params_file is not None:
        try:
            load_configuration(args.plant_params_file)
        except ParameterError as error:
            progress.error(f'[walker] error: --plant-params-file {args.plant_params_file}: '
                           f'{error}')
            return 2
    if args.walk and not args.serve:
        try:
            Truss.from_parameters(configuration.walker).index(args.target)
        except ValueError as error:
            progress.error(f'[walker] error: --target {args.target!r}: {error}')
            return 2
    params_file = configuration.path
    stamp = datetime.datetime.now().strftime('%Y%m%d-%H%M%S')
    out = Path(args.out or Path('runs') / stamp).resolve()
    base_env = {**os.environ, 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST'}
    transport = args.transport or default_transport(base_env)
    if transport != DEFAULT_TRANSPORT and args.transport is None:
        progress.say(f'[walker] {STATIC_PEERS_VARIABLE} names peers on other hosts: the graph '
                     f'runs on {transport} (--transport), reachable from them')
    try:
        env = graph_environment(base_env, transport)
    except ValueError as error:
        progress.error(f'[walker] error: --transport {transport}: {error} (--transport shm '
                       'leaves the rmw default)')
        return 2
    # this process's own participant (the walk's client) is reached as the nodes are
    if PROFILES_VARIABLE in env:
        os.environ[PROFILES_VARIABLE] = env[PROFILES_VARIABLE]
    if args.walkers > 1 and args.namespace != '/walker':
        progress.error('[walker] error: --walkers names the namespaces itself (/walker, '
                       '/walker_2, ...): leave --namespace out')
        return 2
    if args.walkers > 1 and args.serve:
        progress.error('[walker] error: --serve keeps one walker up for walkerctl: leave '
                       '--walkers out')
        return 2
    if args.walkers > 1 and args.foxglove:
        progress.error('[walker] error: --foxglove serves one walker: leave --walkers out')
        return 2
    try:
        walkers = _describe_walkers(args, configuration, out, env)
        timing = configuration.walker.timing
        args.control_rate = timing.control_rate
        if args.realtime and args.realtime <= timing.decision_priority:
            raise ValueError(f"--realtime {args.realtime} must be above the supervisor's and "
                             f"planner's timing.decision_priority ({timing.decision_priority})"
                             ' in the parameter file, which it runs them at')
    except ValueError as error:
        progress.error(f'[walker] error: {error}')
        return 2
    taken = [bag for bag in _bag_paths(walkers) if bag.exists()]
    if taken:
        progress.error(f'[walker] error: {", ".join(map(str, taken))} already exists and a '
                       'recording never overwrites a bag: choose another --out, or --no-record')
        return 2
    out.mkdir(parents=True, exist_ok=True)
    for stale in out.glob('plant_state*.json'):  # an earlier run's robot is not this one's
        stale.unlink()
    context = init_context()
    busy = _namespaces_in_use(walkers, context)
    if busy:
        context.try_shutdown()
        progress.error(f'[walker] error: {busy}')
        return 2
    count = sum(len(w.nodes) for w in walkers)
    progress.say(f'[walker] output in {out}')
    progress.say(
        f'[walker] starting {count} nodes '
        + (f'in {len(walkers)} composed process{"es" if len(walkers) > 1 else ""}'
           if args.composed else 'with the loop (plant, controllers) in one process'
           if args.composed_loop else 'as separate processes')
        + f' ({"sim time" if args.sim_time else "real time"}'
        + (f', {len(walkers)} walkers' if len(walkers) > 1 else '') + '): '
        + ', '.join(n.name for n in walkers[0].nodes))

    interrupted = {'signal': None}

    def on_signal(signum, _frame):
        interrupted['signal'] = signum

    previous = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    deaths: list = []
    lock = threading.Lock()

    policy = RespawnPolicy(args.respawn_delay, args.respawn_limit)
    for walker in walkers:
        walker.respawner = RespawningGroup(
            walker.group, policy, progress.error, walker.label if len(walkers) > 1 else '',
            report=lambda node, level, message, w=walker: w.client is not None
            and w.client.report_process(node, level, message))

    def should_stop() -> bool:
        with lock:
            if not deaths:  # a graph given up on is not started again
                for walker in walkers:
                    deaths.extend(walker.respawner.poll())
        return bool(deaths) or interrupted['signal'] is not None

    code = 1
    try:
        for walker in walkers:
            _launch(walker, args, params_file)
        started = time.monotonic()
        for walker in walkers:
            walker.client = GraphClient(walker.namespace, context)
            prefix = f'{walker.label}: ' if len(walkers) > 1 else ''
            walker.client.wait_until_ready(
                [n.full_name for n in walker.nodes], args.startup_timeout,
                progress=lambda r, p=prefix: progress.update(
                    f'[walker] {p}bringing the graph up: {len(r.ready)}/'
                    f'{len(r.ready) + len(r.missing)} ready'
                    + (f' (waiting for {", ".join(r.missing[:3])})' if r.missing else ''),
                    key=(p, len(r.ready))),
                should_stop=should_stop)
        progress.say(f'[walker] graph{"s" if len(walkers) > 1 else ""} ready in '
                     f'{time.monotonic() - started:.1f} s')
        if args.foxglove:
            progress.say(f'[walker] live view: open ws://127.0.0.1:{args.foxglove_port} in '
                         f'Foxglove with the layout {_foxglove_layout()}')
        if args.serve:
            return _serve(walkers[0], args, should_stop, deaths, out)
        if not args.walk:
            return 0
        if len(walkers) == 1:
            code = _walk(walkers[0], args.target, args, progress, should_stop, out)
        else:
            code = _walk_several(walkers, args, progress, should_stop, out)
    except GraphNotReadyError as error:
        progress.error(f'[walker] error: {error}')
        code = 3
    except GoalRejectedError as error:  # the supervisor's reason: nothing moved
        progress.error(f'[walker] error: {error}')
        code = 1
    except WalkInterruptedError:
        code = _report_interruption([w.client for w in walkers if w.client is not None],
                                    deaths, interrupted['signal'], progress)
    finally:
        for walker in walkers:
            if walker.client is not None:
                walker.client.close()
        context.try_shutdown()
        progress.say('[walker] shutting the graph down')
        codes: dict[str, int | None] = {}
        left = []
        for walker in walkers:
            prefix = f'{walker.label}/' if len(walkers) > 1 else ''
            codes.update({prefix + n: c for n, c in walker.group.stop_all().items()})
            left += [prefix + p.spec.name for p in walker.group.processes if p.alive]
        if left:
            progress.error(f'[walker] error: still running after shutdown: {", ".join(left)}')
            code = code or 4
        elif not args.quiet:
            progress.say(f'[walker] all {"processes" if args.composed else "node processes"} '
                         'stopped (' + ', '.join(f'{n}: {c}' for n, c in codes.items()) + ')')
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        for line in _recover_bags(_bag_paths(walkers)):
            progress.error(line)
    walked = args.walk and code not in (3, 130)  # the graph came up and nobody hit Ctrl-C
    if args.record and args.report and walked and (out / 'bag').is_dir():
        if not write_report(out / 'bag', out / 'report', params_file, args.quiet):
            code = code or 6
    return code


def _recover_bags(bags: list[Path]) -> list[str]:
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
def _foxglove_layout() -> Path:
    """Return the installed Foxglove layout of walker_viz."""
    from ament_index_python.packages import get_package_share_directory

    return Path(get_package_share_directory('walker_viz')) / 'config' / 'walker.foxglove.json'


def _namespaces_in_use(walkers: list[_Walker], context) -> str:
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


def _serve(walker: _Walker, args, should_stop, deaths: list, out: Path) -> int:
    """Keep the graph running until Ctrl-C (exit code 0) or a node is given up on.

    The client keeps spinning: a participant that stops taking its messages would hold up the
    graph's reliable writers. On the way out, the steps taken and each node's deaths and
    restarts go into ``<out>/summary.json``.
    """
    client = walker.client
    domain = os.environ.get('ROS_DOMAIN_ID', '0')
    print(f'[walker] serving in namespace {args.namespace}, ROS_DOMAIN_ID={domain}: try '
          f'scripts/walkerctl status; Ctrl-C shuts the graph down', flush=True)
    try:
        while not should_stop():
            client.spin_for(SERVE_POLL)
    finally:
        write_json(rows_from_reports(client.reports), out / 'summary.json',
                   {'serve': True, 'processes': walker.processes()})
    if deaths:
        raise WalkInterruptedError('a node died')
    return 0


def write_report(bag: Path, report_dir: Path, params_file: Path, quiet: bool) -> bool:
    """Make the walk report of ``bag`` into ``report_dir`` and say where it is.

    Returns False (having said why) when the report could not be made; the walk's own
    outcome stands (:func:`walker_report.walk_report.report_after_walk`).
    """
    return report_after_walk(bag, report_dir, params_file, quiet)


def walk_feedback_text(feedback, elapsed: float) -> str:
    """One progress line from a ``WalkTo`` feedback, ``elapsed`` [s] after the goal was sent.

    The line ``walkerctl walk-to`` shows (:func:`walker_core.progress.walk_progress`).
    """
    return walk_progress(feedback.step_index, feedback.step_count, feedback.phase,
                         feedback.from_node, feedback.to_node, feedback.tip_position_error,
                         elapsed)


def _walk(walker: _Walker, target: str, args, progress: ProgressLine, should_stop, out: Path,
          label: str = '', summary_name: str = 'summary.json') -> int:
    client = walker.client
    started = time.monotonic()
    prefix = f'{label}: ' if label else ''

    def on_feedback(feedback) -> None:
        progress.update(f'[walker] {prefix}'
                        f'{walk_feedback_text(feedback, time.monotonic() - started)}',
                        key=(label, feedback.step_index, feedback.phase))

    progress.say(f'[walker] {prefix}walking to {target}')
    status, result = client.walk_to(target, args.walk_timeout, on_feedback, should_stop)
    client.spin_for(0.5)  # the last step report
    rows = rows_from_reports(client.reports)
    with _OUTPUT:
        progress.say('')
        if label:
            print(f'[walker] {label}:')
        print(format_table(rows) if rows else '[walker] no step was taken')
        if client.loop is not None:
            print(f'[walker] {prefix}{client.loop.summary(args.control_rate)}')
        write_json(rows, out / summary_name,
                   {'target': target, 'reached': bool(result.success),
                    'message': result.message, 'path': list(result.path),
                    'wall_time': time.monotonic() - started,
                    'loop': None if client.loop is None else client.loop.as_dict(),
                    'processes': walker.processes(),
                    **({'namespace': client.namespace} if label else {})})
        if result.success:
            print(f'[walker] {prefix}reached {target} in {result.steps_taken} steps, '
                  f'{result.duration:.1f} s of walking; summary in {out / summary_name}')
            return 0
        print(f'[walker] {prefix}the walk to {target} did not reach it: {result.message}')
    return 1


_OUTPUT = threading.Lock()


def _walk_several(walkers: list[_Walker], args, progress: ProgressLine, should_stop,
                  out: Path) -> int:
    """Walk every walker to its target at once, one thread each; the first error stops all."""
    errors: list[BaseException] = []

    def walk(walker: _Walker) -> None:
        name = 'summary.json' if walker.namespace == '/walker' else \
            f'summary_{walker.label}.json'
        try:
            walker.code = _walk(walker, walker.target, args, progress,
                                lambda: bool(errors) or should_stop(), out, walker.label, name)
        except BaseException as error:  # re-raised in the main thread
            errors.append(error)

    threads = [threading.Thread(target=walk, args=(w,), name=w.label) for w in walkers]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    if errors:
        raise next((e for e in errors if not isinstance(e, WalkInterruptedError)), errors[0])
    return max(w.code for w in walkers)


def _report_interruption(clients, deaths, signum, progress: ProgressLine) -> int:
    for process in deaths:
        progress.error(f'[walker] error: node {process.spec.full_name} died '
                       f'(exit code {process.popen.returncode}); the end of its log:\n'
                       f'{process.log_tail()}')
    if signum is not None:
        progress.say(f'[walker] interrupted ({signal.Signals(signum).name}): stopping safely')
    elif deaths:  # the death was reported on /diagnostics: let it reach the supervisor first,
        time.sleep(_DEATH_REPORT_LEAD)  # which names the dead node in the hold's reason
    for client in clients:
        try:
            response = client.call_trigger('hold', timeout=2.0)
            progress.say(f'[walker] supervisor {client.namespace}: {response.message}')
        except Exception as error:  # reporting only: shutting down anyway
            progress.error(f'[walker] could not ask the supervisor {client.namespace} to '
                           f'hold: {error}')
    return 130 if signum is not None and not deaths else 5
