"""A seeded chaos run of a served graph, and what the checks of it need.

Shared by the chaos tests (``tests/integration/test_chaos.py``) and the chaos benchmark
(``benchmarks/chaos_benchmark.py``). :func:`run_chaos` brings the graph up as an operator
would, ``run_all.py --serve --sim-time`` (each node a process of its own, recorded, supervised:
a node that dies is started again) in a ROS domain of its own; plans the faults from a seed
(:func:`walker_bringup.core.chaos.plan_faults`); walks the walker between two truss nodes while
:class:`walker_bringup.chaos_driver.ChaosDriver` applies them, with a live grip monitor beside
it; then shuts the graph down with Ctrl-C and checks what is left: no process of the run alive,
no shared-memory file of its processes in /dev/shm, and every file of the bag readable whole
(:func:`check_bag`), with no recorded instant without a gripper attached.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from pathlib import Path

from ros_test_support import (
    NodeProcess, SharedMemoryGuard, isolated_domain, ros_environment, serve_command)

__all__ = ['run_chaos', 'check_bag', 'DEFAULT_TARGETS', 'STARTUP_TIMEOUT']

#: Two nodes the walker walks between: the default walk's target and the start
DEFAULT_TARGETS = ('n4_3', 'n1_1')
STARTUP_TIMEOUT = 240.0  # [s] wall clock for the graph to come up on a loaded machine
NAMESPACE = '/walker'


def check_bag(bag_dir: Path) -> dict:
    """Read every file of a bag with the MCAP reader and the whole bag with rosbags.

    Returns the files and their message counts, the bag's count as rosbags reads it and as
    its metadata says, and the recorded gripper states: ``instants`` and ``grip_losses``
    (instants with no gripper attached). A file that a reader cannot read to its end raises.
    """
    from mcap.reader import make_reader
    from rosbags.highlevel import AnyReader

    from walker_bag.core.bag_metadata import read_metadata
    from walker_bag.core.bag_reader import walker_typestore

    files = {}
    for path in sorted(bag_dir.glob('*.mcap')):
        with open(path, 'rb') as stream:
            files[path.name] = sum(1 for _ in make_reader(stream).iter_messages())
    instants = losses = read = 0
    with AnyReader([bag_dir], default_typestore=walker_typestore()) as reader:
        for connection, _, raw in reader.messages():
            read += 1
            if connection.topic.endswith('/gripper_states'):
                message = reader.deserialize(raw, connection.msgtype)
                instants += 1
                losses += not any(g.state == 2 for g in message.grippers)  # 2: ATTACHED
    return {'files': files, 'messages': read,
            'metadata_messages': read_metadata(bag_dir).message_count,
            'incomplete_files_kept': sorted(p.name for p in bag_dir.glob('*.incomplete')),
            'instants': instants, 'grip_losses': losses}


def run_chaos(out: Path, seed: int, count: int, say: Callable[[str], None] = print,
              targets: Sequence[str] = DEFAULT_TARGETS, timeout: float = 300.0,
              faults: Sequence | None = None, options: Sequence[str] = (), **plan) -> dict:
    """Run ``count`` faults planned from ``seed`` on a served graph; return what it came to.

    ``plan`` goes to :func:`~walker_bringup.core.chaos.plan_faults` (``nodes``, ``phases``,
    ``freeze_share``, ...); ``faults`` (a sequence of
    :class:`~walker_bringup.core.chaos.Fault`) replaces the planned ones with a given sequence
    (``count`` must be its length); ``options`` are more of ``run_all.py``'s (a plant
    parameter file, ...). Returns ``figures`` (:func:`summarise_outcomes`), ``outcomes``
    (one dict per fault), ``reached`` (the walk's last target reached), ``left_running``
    (process ids of the run still alive), ``error`` (what the run waited for in vain, or
    ''), ``stale_shared_memory`` (files of its processes still in /dev/shm), ``bag``
    (:func:`check_bag`), ``exit_code`` of ``run_all.py``, ``processes`` (its summary's
    deaths and restarts), ``wall_time`` [s] and its ``output``.
    """
    import json

    from walker_bringup.chaos_driver import ChaosDriver, ChaosError, GripMonitor
    from walker_bringup.core.chaos import plan_faults, summarise_outcomes
    from walker_bringup.graph_client import GraphClient, init_context
    from walker_bringup.processes import fastdds_shm_files, stale_shared_memory_files
    from walker_msgs.msg import StepPhase

    if faults is None:
        faults = plan_faults(seed, count, **plan)
    elif len(faults) != count:
        raise ValueError(f'{len(faults)} faults given for a run of {count}')
    started = time.monotonic()
    result: dict = {'seed': seed, 'reached': False, 'error': ''}
    with isolated_domain() as domain:
        with NodeProcess(serve_command(NAMESPACE, out, *options), ros_environment(domain),
                         'run_all') as run:
            driver = None
            # the graph's files in /dev/shm kept from other runs' clean-ups while it runs (not
            # while it shuts down: a node deletes its own files as it stops)
            guard = SharedMemoryGuard(lambda: [run.process.pid] + (
                [] if driver is None else list(driver.pids().values())), period=0.2)
            shm_before = fastdds_shm_files()  # files of others, or left by an earlier run
            guard.__enter__()
            context = client = monitor = None
            try:
                if not run.wait_for_output('[walker] serving in namespace', STARTUP_TIMEOUT):
                    raise RuntimeError(f'the graph did not come up:\n{run.output[-3000:]}')
                context = init_context(domain)
                client = GraphClient(NAMESPACE, context)
                monitor = GripMonitor(client)
                driver = ChaosDriver(client, out / 'logs', targets, timeout, say)
                driver.wait(lambda: driver.phase is not None
                            and driver.phase.phase == StepPhase.IDLE, 'the walker idle')
                for fault in faults:
                    driver.apply(fault)
                driver.finish()
                result['reached'] = True
            except ChaosError as error:  # the run's figures and checks so far still count
                result['error'] = str(error)
                say(f'[chaos] {error}')
            finally:
                result['outcomes'] = [o.as_dict() for o in driver.outcomes] if driver else []
                if client is not None:
                    grips = monitor.count
                    client.close()
                if context is not None:
                    context.try_shutdown()
                guard.__exit__(None, None, None)
                result['exit_code'] = run.stop(timeout=120.0)
                result['output'] = run.output
            result['left_running'] = driver.alive_pids()
            # files its processes held, made since it started, that no live process uses (a
            # port's files shared with another graph on the machine are in use by it)
            result['stale_shared_memory'] = [
                path.name for path in stale_shared_memory_files(shm_before, min_age=0.0)
                if path.name in guard.owned]
    bag = check_bag(out / 'bag')
    result['bag'] = bag
    result['grip_instants'] = {'live': grips.instants, 'bag': bag['instants']}
    result['figures'] = summarise_outcomes(driver.outcomes, grips.losses, bag['grip_losses'])
    summary = json.loads((out / 'summary.json').read_text())
    result['processes'] = summary.get('processes', {})
    result['wall_time'] = round(time.monotonic() - started, 1)
    return result
