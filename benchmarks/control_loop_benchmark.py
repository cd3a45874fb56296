#!/usr/bin/env python3
"""Control-loop latency of the five joint controllers over DDS, with the real plant or a stand-in.

Usage: ``python3 benchmarks/control_loop_benchmark.py [--plant real|stand-in] [--duration S]
[--rates 500 ...]``

Five real ``joint_controller_node`` processes (COARSE mode, joint 1 with acceleration
feedback) close their loops over DDS with one of two plants:

* ``--plant real`` (default duration 20 s): the real ``plant_node`` in its own process, in
  real-time mode (``sim.clock_mode:=real_time``: physics stepped on a wall-clock timer, states
  stamped with the system clock), started through its own ``main()`` with a measuring hook
  around three of its methods: the start of each timer tick, each state it publishes (stamp,
  time) and each effort command its callback receives (stamp, time). The latency is measured
  where it matters, inside the plant: from the plant starting to publish a state to the
  matching effort reaching its callback. A period is *missed* when the five efforts answering
  a state have not all reached the plant before its next tick (the plant then applies older
  commands, and counts the miss in /diagnostics). No observer process adds load.
* ``--plant stand-in`` (default duration 60 s): a minimal rclpy node in this process publishes
  ``joint_accelerations`` then ``joint_states`` every control period on the wall clock with
  constant positions, and timestamps the efforts that come back. No physics: the controllers'
  share of the loop only.

Reported: latency to each effort and to the last of the five, as median, p99 and max; missed
periods; the plant's publishing jitter; each process's CPU use and the machine's load average.
The machine has 2 cores and other work runs on it: the numbers are noisy and pessimistic; rerun
on a quiet machine to compare. Writes ``benchmarks/results/control_loop_benchmark.json`` (the
runs of the other plant kind already in the file are kept).
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import resource
import struct
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / 'scripts'))
sys.path.insert(0, str(REPO / 'tests'))

import walker_env  # noqa: E402

RESULT = REPO / 'benchmarks' / 'results' / 'control_loop_benchmark.json'
TARGET_P99_PERIODS = 1.0


DEFAULT_DURATION = {'real': 20.0, 'stand-in': 60.0}


def _arguments() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--plant', choices=('real', 'stand-in'), default='real',
                        help='the real plant_node (real time) or the stand-in (default: real)')
    parser.add_argument('--duration', type=float, default=None,
                        help='measured seconds (default: 20 with the real plant, 60 with the '
                             'stand-in)')
    parser.add_argument('--rates', type=float, nargs='+', default=[500.0],
                        help='control rates to run, one after the other [Hz] (default 500)')
    parser.add_argument('--warmup', type=float, default=3.0, help='seconds not measured')
    parser.add_argument('--output', type=Path, default=RESULT, help='JSON result file')
    args = parser.parse_args()
    if args.duration is None:
        args.duration = DEFAULT_DURATION[args.plant]
    if not (args.duration > 0 and args.warmup >= 0 and all(r > 0 for r in args.rates)):
        parser.error('--duration and --rates must be positive, --warmup not negative')
    return args


def _cpu_seconds(pid: int) -> float:
    fields = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')


def _own_cpu_seconds() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def _percentiles(values_ns: list[int]) -> dict[str, float]:
    import numpy as np

    if not values_ns:
        return {'count': 0}
    ms = np.asarray(values_ns, dtype=float) / 1e6
    return {'count': int(ms.size), 'median_ms': float(np.median(ms)),
            'p99_ms': float(np.percentile(ms, 99)), 'max_ms': float(ms.max())}


class StandInPlant:
    """Publishes states on a wall-clock schedule and timestamps the efforts that come back."""

    def __init__(self, context, joints: tuple[str, ...], period_ns: int) -> None:
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node
        from sensor_msgs.msg import JointState
        from walker_msgs.msg import ControlMode, JointAccelerations

        from walker_control.joint_controller_node import COMMAND_QOS, MODE_QOS, STATE_QOS

        self.node = Node('stand_in_plant', namespace='/walker', context=context)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.joints = joints
        self.period_ns = period_ns
        self.state_pub = self.node.create_publisher(JointState, 'joint_states', STATE_QOS)
        self.accel_pub = self.node.create_publisher(JointAccelerations, 'joint_accelerations',
                                                    STATE_QOS)
        self.mode_pub = self.node.create_publisher(ControlMode, 'control_mode', MODE_QOS)
        # Raw CDR: the stamp is read from the bytes, which keeps this stand-in light.
        self.node.create_subscription(JointState, 'effort_commands', self._on_effort,
                                      COMMAND_QOS, raw=True)
        self.state = JointState(name=list(joints), position=[0.0, 0.85, 1.45, 0.85, 0.0],
                                velocity=[0.0] * 5, effort=[0.0] * 5)
        self.accel = JointAccelerations(name=list(joints), acceleration=[0.0] * 5)
        self.sent: dict[int, int] = {}        # stamp [ns] -> publish time [ns, monotonic]
        self.received: dict[int, list[int]] = {}  # stamp -> latencies of the efforts
        self.measuring = False

    def _on_effort(self, data: bytes) -> None:
        now = time.monotonic_ns()
        # CDR: 4-byte encapsulation header, then header.stamp as int32 sec, uint32 nanosec.
        little = data[1] == 1
        sec, nanosec = struct.unpack('<iI' if little else '>iI', data[4:12])
        stamp = sec * 1_000_000_000 + nanosec
        sent = self.sent.get(stamp)
        if sent is not None:
            self.received.setdefault(stamp, []).append(now - sent)

    def publish(self, stamp_ns: int) -> None:
        """Publish the accelerations, then the state, stamped ``stamp_ns``."""
        sec, nanosec = divmod(stamp_ns, 1_000_000_000)
        for msg in (self.accel, self.state):
            msg.header.stamp.sec, msg.header.stamp.nanosec = sec, nanosec
        self.accel_pub.publish(self.accel)
        self.sent[stamp_ns] = time.monotonic_ns()
        self.state_pub.publish(self.state)

    def spin_until(self, deadline_ns: int) -> None:
        """Serve incoming efforts until the monotonic time ``deadline_ns``."""
        while True:
            remaining = (deadline_ns - time.monotonic_ns()) / 1e9
            if remaining <= 0.0:
                return
            self.executor.spin_once(timeout_sec=remaining)

    def close(self) -> None:
        """Destroy the node."""
        self.executor.shutdown()
        self.node.destroy_node()


def _run(args: argparse.Namespace, rate: float) -> dict:
    import rclpy
    from ament_index_python.packages import get_package_prefix
    from rclpy.context import Context
    from walker_msgs.msg import ControlMode

    from ros_test_support import NodeProcess, isolated_domain, ros_environment
    from walker_core.joint_roles import PHYSICAL_JOINT_NAMES

    executable = f'{get_package_prefix("walker_control")}/lib/walker_control/' \
                 'joint_controller_node'
    period_ns = int(round(1e9 / rate))
    with isolated_domain() as domain:
        env = ros_environment(domain)
        context = Context()
        rclpy.init(context=context, domain_id=domain)
        controllers = [NodeProcess([executable, '--ros-args', '-r', '__ns:=/walker', '-p',
                                    f'joint_name:={joint}', '-p',
                                    f'timing.control_rate:={rate}'], env, joint)
                       for joint in PHYSICAL_JOINT_NAMES]
        plant = StandInPlant(context, PHYSICAL_JOINT_NAMES, period_ns)
        try:
            print(f'[benchmark] waiting for the five controllers (ROS domain {domain})')
            stamp = 1_000_000_000
            deadline = time.monotonic() + 60.0
            while time.monotonic() < deadline:
                plant.publish(stamp)
                plant.spin_until(time.monotonic_ns() + 50_000_000)
                if len(plant.received.get(stamp, [])) == 5:
                    break
                stamp += period_ns
            else:
                raise RuntimeError('the controllers did not answer within 60 s:\n'
                                   + '\n'.join(c.output[-500:] for c in controllers))
            plant.mode_pub.publish(ControlMode(mode=ControlMode.COARSE, base_gripper='a',
                                               commander='/walker/supervisor'))
            print(f'[benchmark] running {args.warmup:g} s warm-up + {args.duration:g} s at '
                  f'{rate:g} Hz against the stand-in plant')
            total = int((args.warmup + args.duration) * rate)
            warmup = int(args.warmup * rate)
            cpu_before: list[float] = []
            jitter: list[int] = []
            measured: list[int] = []
            start = time.monotonic_ns() + period_ns
            for k in range(total):
                scheduled = start + k * period_ns
                plant.spin_until(scheduled)
                if k == warmup:
                    cpu_before = [_cpu_seconds(c.process.pid) for c in controllers]
                    own_before = _own_cpu_seconds()
                    wall_before = time.monotonic()
                stamp += period_ns
                if k >= warmup:
                    jitter.append(time.monotonic_ns() - scheduled)
                    measured.append(stamp)
                plant.publish(stamp)
                if k % int(5 * rate) == 0 and k >= warmup:
                    done = (k - warmup) / rate
                    print(f'[benchmark] {done:5.1f} / {args.duration:g} s', flush=True)
            plant.spin_until(time.monotonic_ns() + 10 * period_ns)
            wall = time.monotonic() - wall_before
            cpu = [(_cpu_seconds(c.process.pid) - b) / wall
                   for c, b in zip(controllers, cpu_before, strict=True)]
            own_cpu = (_own_cpu_seconds() - own_before) / wall
        finally:
            plant.close()
            for controller in controllers:
                controller.stop()
            rclpy.try_shutdown(context=context)

    each = [lat for s in measured for lat in plant.received.get(s, [])]
    complete = [max(plant.received[s]) for s in measured if len(plant.received.get(s, [])) == 5]
    missed = sum(1 for s in measured
                 if len([lat for lat in plant.received.get(s, []) if lat < period_ns]) < 5)
    lost = sum(1 for s in measured if len(plant.received.get(s, [])) < 5)
    return {
        'benchmark': 'control_loop_benchmark', 'plant': 'stand-in',
        'note': "STAND-IN plant (no physics): the five controllers' share of the loop only",
        'date': datetime.datetime.now(datetime.UTC).isoformat(timespec='seconds'),
        'commit': subprocess.run(['git', 'rev-parse', '--short', 'HEAD'], cwd=REPO,
                                 capture_output=True, text=True).stdout.strip(),
        'machine': {'cpus': os.cpu_count(), 'python': platform.python_version(),
                    'load_average_1_5_15': list(os.getloadavg())},
        'rate_hz': rate, 'duration_s': args.duration, 'periods': len(measured),
        'effort_latency': _percentiles(each),
        'all_five_latency': _percentiles(complete),
        'missed_periods': missed, 'missed_fraction': missed / max(1, len(measured)),
        'periods_with_an_effort_lost': lost,
        'stand_in_publish_jitter': _percentiles(jitter),
        'controller_cpu_fraction': dict(zip(PHYSICAL_JOINT_NAMES, cpu, strict=True)),
        'stand_in_cpu_fraction': own_cpu,
        'target': 'p99 of all-five latency within one period, no missed periods',
    }


def _report(result: dict) -> None:
    period_ms = 1e3 / result['rate_hz']
    print(f'\nControl loop against a STAND-IN plant (no physics), {result["rate_hz"]:g} Hz, '
          f'{result["periods"]} periods; {result["machine"]["cpus"]} CPUs, load average '
          f'{result["machine"]["load_average_1_5_15"][0]:.2f}: noisy, rerun on a quiet machine')
    print('  latency, state out -> effort back   median [ms]   p99 [ms]   max [ms]')
    for key, label in (('effort_latency', 'each effort'),
                       ('all_five_latency', 'last of the five')):
        row = result[key]
        if row.get('count'):
            print(f'  {label:34s} {row["median_ms"]:10.3f} {row["p99_ms"]:10.3f} '
                  f'{row["max_ms"]:10.3f}')
    jitter = result['stand_in_publish_jitter']
    print(f'  stand-in publish lateness           {jitter["median_ms"]:10.3f} '
          f'{jitter["p99_ms"]:10.3f} {jitter["max_ms"]:10.3f}')
    print(f'  missed periods (not all five efforts back within {period_ms:g} ms): '
          f'{result["missed_periods"]} of {result["periods"]} '
          f'({100 * result["missed_fraction"]:.3f} %); efforts never received in '
          f'{result["periods_with_an_effort_lost"]} periods')
    print('  CPU use (fraction of one core): ' + ', '.join(
        f'{joint} {100 * share:.0f} %' for joint, share in
        result['controller_cpu_fraction'].items())
        + f'; stand-in {100 * result["stand_in_cpu_fraction"]:.0f} %')
    p99 = result['all_five_latency'].get('p99_ms', float('inf'))
    verdict = 'met' if p99 <= TARGET_P99_PERIODS * period_ms and not result['missed_periods'] \
        else 'NOT met'
    print(f'  target (p99 within one period, no missed period): {verdict} here')


# ------------------------------------------------------------------------- the real plant
#: Run in the plant's process: the real plant_node.main(), with timing hooks around the start
#: of each tick, each state published and each effort command received. On exit (SIGINT) the
#: events are written to the file named by WALKER_BENCHMARK_EVENTS.
_PLANT_HOOK = """
import array, json, os, sys, time
from walker_sim import plant_node

# flat arrays of integers: nothing the garbage collector walks, so the probe adds no pauses
names = ('tick', 'publish_stamp', 'publish_time', 'plant_missed', 'overruns', 'effort_stamp',
         'effort_time', 'effort_count')
events = {name: array.array('q') for name in names}
heard = {}  # joints heard per stamp, until all five answer
tick, publish, on_effort = (plant_node.PlantNode._tick, plant_node.PlantNode._publish,
                            plant_node.PlantNode._on_effort)


def timed_tick(self):
    events['tick'].append(time.monotonic_ns())
    tick(self)


def timed_publish(self, state):
    events['publish_stamp'].append(self._stamp)
    events['publish_time'].append(time.monotonic_ns())
    events['plant_missed'].append(sum(self.lockstep.missed.values()))
    events['overruns'].append(self._counts['overruns'])
    publish(self, state)


def timed_effort(self, message):
    now = time.monotonic_ns()
    stamp = message.header.stamp.sec * 1000000000 + message.header.stamp.nanosec
    events['effort_stamp'].append(stamp)
    events['effort_time'].append(now)
    events['effort_count'].append(len(message.name))
    if heard is not None:
        names = heard.setdefault(stamp, set())
        names.update(message.name)
        if len(names) == 5:
            globals()['heard'] = None
            print('[plant hook] all five controllers answering', flush=True)
    on_effort(self, message)


plant_node.PlantNode._tick = timed_tick
plant_node.PlantNode._publish = timed_publish
plant_node.PlantNode._on_effort = timed_effort
try:
    code = plant_node.main(sys.argv[1:])
finally:
    with open(os.environ['WALKER_BENCHMARK_EVENTS'], 'w') as handle:
        json.dump({'tick': events['tick'].tolist(),
                   'publish': list(zip(events['publish_stamp'], events['publish_time'])),
                   'effort': list(zip(events['effort_stamp'], events['effort_time'],
                                      events['effort_count'])),
                   'plant_missed': events['plant_missed'].tolist(),
                   'overruns': events['overruns'].tolist()}, handle)
"""


def _loop_statistics(events: dict, start_ns: int, end_ns: int, period_ns: int) -> dict:
    """Latencies and missed periods of the states the plant published in a window.

    A state stamped ``s`` published at ``p`` is answered in time when the five efforts stamped
    ``s`` reached the plant's callback before the plant's next tick.
    """
    import numpy as np

    ticks = np.array(events['tick'], dtype=np.int64)
    arrivals: dict[int, list[int]] = {}
    for stamp, arrived, count in events['effort']:
        arrivals.setdefault(stamp, []).extend([arrived] * count)
    each, all_five, lateness = [], [], []
    missed = lost = states = 0
    publish = events['publish']
    for index, (stamp, sent) in enumerate(publish):
        if not start_ns <= sent < end_ns:
            continue
        states += 1
        got = [t - sent for t in arrivals.get(stamp, [])]
        each.extend(got)
        following = ticks[np.searchsorted(ticks, sent)] if sent < ticks[-1] else None
        if len(got) >= 5:
            all_five.append(max(got))
        else:
            lost += 1
        if following is None or len(got) < 5 or max(got) + sent > following:
            missed += 1
        if index + 1 < len(publish):
            lateness.append(publish[index + 1][1] - sent - period_ns)
    inside = [i for i, (_, sent) in enumerate(publish) if start_ns <= sent < end_ns]
    plant_missed = (events['plant_missed'][inside[-1]] - events['plant_missed'][inside[0]]
                    if inside else 0)
    overruns = (events['overruns'][inside[-1]] - events['overruns'][inside[0]]
                if inside else 0)
    seconds = (end_ns - start_ns) / 1e9
    return {
        'states_published': states,
        'expected_periods': int(round(seconds * 1e9 / period_ns)),
        'effort_latency': _percentiles(each),
        'all_five_latency': _percentiles(all_five),
        'missed_periods': missed, 'missed_fraction': missed / max(1, states),
        'periods_with_an_effort_lost': lost,
        'plant_counted_missed_joint_periods': plant_missed,
        'plant_overrun_periods': overruns,
        'publish_period_minus_nominal': _percentiles([max(0, v) for v in lateness]),
    }


def _run_real_plant(args: argparse.Namespace, rate: float) -> dict:
    import tempfile

    import rclpy
    from ament_index_python.packages import get_package_prefix
    from rclpy.context import Context
    from rclpy.node import Node
    from walker_msgs.msg import ControlMode

    from ros_test_support import NodeProcess, isolated_domain, ros_environment
    from walker_control.joint_controller_node import MODE_QOS
    from walker_core.joint_roles import PHYSICAL_JOINT_NAMES

    executable = f'{get_package_prefix("walker_control")}/lib/walker_control/' \
                 'joint_controller_node'
    period_ns = int(round(1e9 / rate))
    with isolated_domain() as domain, tempfile.TemporaryDirectory() as scratch:
        env = ros_environment(domain)
        events_file = Path(scratch) / 'plant_events.json'
        env['WALKER_BENCHMARK_EVENTS'] = str(events_file)
        # real time as run_all.py --realtime runs it: the loop under SCHED_FIFO 50
        ros_args = ['--ros-args', '-r', '__ns:=/walker', '-p', f'timing.control_rate:={rate}',
                    '-p', 'timing.realtime_priority:=50']
        controllers = [NodeProcess([executable, *ros_args, '-p', f'joint_name:={joint}'], env,
                                   joint) for joint in PHYSICAL_JOINT_NAMES]
        plant = NodeProcess([sys.executable, '-c', _PLANT_HOOK, *ros_args, '-p',
                             'sim.clock_mode:=real_time'], env, 'plant_node')
        context = Context()
        rclpy.init(context=context, domain_id=domain)
        node = Node('benchmark_operator', namespace='/walker', context=context)
        try:
            print(f'[benchmark] waiting for the plant and the five controllers (ROS domain '
                  f'{domain})')
            if not plant.wait_for_output('all five controllers answering', 90.0):
                raise RuntimeError('the loop did not close within 90 s:\n' + plant.output[-2000:]
                                   + '\n'.join(c.output[-500:] for c in controllers))
            node.create_publisher(ControlMode, 'control_mode', MODE_QOS).publish(
                ControlMode(mode=ControlMode.COARSE, base_gripper='a',
                            commander='/walker/supervisor'))
            print(f'[benchmark] running {args.warmup:g} s warm-up + {args.duration:g} s at '
                  f'{rate:g} Hz with the real plant (real time)')
            time.sleep(args.warmup)
            load_before = os.getloadavg()
            processes = {c.name: c.process.pid for c in controllers}
            processes['plant_node'] = plant.process.pid
            cpu_before = {name: _cpu_seconds(pid) for name, pid in processes.items()}
            start_ns = time.monotonic_ns()
            while (elapsed := (time.monotonic_ns() - start_ns) / 1e9) < args.duration:
                time.sleep(min(5.0, args.duration - elapsed))
                print(f'[benchmark] {min(elapsed + 5.0, args.duration):5.1f} / '
                      f'{args.duration:g} s', flush=True)
            end_ns = time.monotonic_ns()
            wall = (end_ns - start_ns) / 1e9
            cpu = {name: (_cpu_seconds(pid) - cpu_before[name]) / wall
                   for name, pid in processes.items()}
            load_after = os.getloadavg()
        finally:
            node.destroy_node()
            rclpy.try_shutdown(context=context)
            plant.stop()
            for controller in controllers:
                controller.stop()
        events = json.loads(events_file.read_text())

    result = {
        'benchmark': 'control_loop_benchmark', 'plant': 'real',
        'note': 'the real plant_node in real-time mode (its own process, a timing hook around '
                'its tick, publish and effort callback) and five joint_controller_node '
                'processes; latency from the plant starting to publish a state to the matching '
                'effort reaching its callback; a period is missed when the five efforts have '
                'not all reached the plant before its next tick',
        'date': datetime.datetime.now(datetime.UTC).isoformat(timespec='seconds'),
        'commit': subprocess.run(['git', 'rev-parse', '--short', 'HEAD'], cwd=REPO,
                                 capture_output=True, text=True).stdout.strip(),
        'machine': {'cpus': os.cpu_count(), 'python': platform.python_version(),
                    'load_average_1_5_15': list(load_before),
                    'load_average_after_1_5_15': list(load_after)},
        'rate_hz': rate, 'duration_s': args.duration,
        'cpu_fraction': cpu, 'cpu_fraction_total': sum(cpu.values()),
        'target': 'p99 of all-five latency within one period, no missed periods',
    }
    result.update(_loop_statistics(events, start_ns, end_ns, period_ns))
    result['periods'] = result['states_published']
    return result


def _report_real(result: dict) -> None:
    period_ms = 1e3 / result['rate_hz']
    load = result['machine']['load_average_1_5_15']
    print(f'\nControl loop with the REAL plant (real time), {result["rate_hz"]:g} Hz, '
          f'{result["duration_s"]:g} s: {result["states_published"]} states published of '
          f'{result["expected_periods"]} periods ({result["plant_overrun_periods"]} stepped '
          f'late in a catch-up, not published); {result["machine"]["cpus"]} CPUs, load '
          f'average {load[0]:.2f} before')
    print('  latency, plant publishes a state -> effort at the plant   median [ms]   p99 [ms]'
          '   max [ms]')
    for key, label in (('effort_latency', 'each effort'),
                       ('all_five_latency', 'last of the five')):
        row = result[key]
        if row.get('count'):
            print(f'  {label:55s} {row["median_ms"]:10.3f} {row["p99_ms"]:10.3f} '
                  f'{row["max_ms"]:10.3f}')
    jitter = result['publish_period_minus_nominal']
    if jitter.get('count'):
        print(f'  {"plant publish period beyond nominal":55s} {jitter["median_ms"]:10.3f} '
              f'{jitter["p99_ms"]:10.3f} {jitter["max_ms"]:10.3f}')
    print(f'  missed periods (not all five efforts at the plant before its next tick): '
          f'{result["missed_periods"]} of {result["states_published"]} '
          f'({100 * result["missed_fraction"]:.2f} %); some effort never arrived in '
          f'{result["periods_with_an_effort_lost"]}; the plant counted '
          f'{result["plant_counted_missed_joint_periods"]} missed joint-periods')
    print('  CPU use (fraction of one core): ' + ', '.join(
        f'{name} {100 * share:.0f} %' for name, share in result['cpu_fraction'].items())
        + f'; total {100 * result["cpu_fraction_total"]:.0f} % of 2 cores x 100 %')
    p99 = result['all_five_latency'].get('p99_ms', float('inf'))
    verdict = 'met' if p99 <= TARGET_P99_PERIODS * period_ms and not result['missed_periods'] \
        else 'NOT met'
    print(f'  target (p99 within one period, no missed period): {verdict} here')


def main() -> int:
    """Run the benchmark, print the table, write the JSON result."""
    args = _arguments()
    walker_env.reexec_in_environment(os.path.abspath(__file__), sys.argv[1:])
    runs = []
    for rate in args.rates:
        if args.plant == 'real':
            runs.append(_run_real_plant(args, rate))
            _report_real(runs[-1])
        else:
            runs.append(_run(args, rate))
            _report(runs[-1])
    kept = []
    if args.output.exists():
        try:
            kept = [run for run in json.loads(args.output.read_text()).get('runs', [])
                    if run.get('plant', 'stand-in') != args.plant]
        except (json.JSONDecodeError, AttributeError):
            kept = []
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps({'benchmark': 'control_loop_benchmark',
                                       'runs': runs + kept}, indent=2) + '\n')
    print(f'  written: {args.output}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
