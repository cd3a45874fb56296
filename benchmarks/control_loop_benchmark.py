#!/usr/bin/env python3
"""Control-loop latency of the five joint controllers over DDS, against a STAND-IN plant.

Usage: ``python3 benchmarks/control_loop_benchmark.py [--duration 60] [--rates 500 ...]``

Five real ``joint_controller_node`` processes (COARSE mode, joint 1 with acceleration
feedback) run against a minimal stand-in plant in this process: an rclpy node that publishes
``joint_accelerations`` then ``joint_states`` every control period on the wall clock (as the
plant's real-time mode does), with constant positions, and timestamps the ``effort_commands``
that come back. There is no physics: this measures the controllers' share of the loop (DDS
both ways, message conversion, the control law), not the pybullet plant's.

Reported: the latency from a state leaving the stand-in to each matching effort arriving back,
and to the last of the five (when a plant would have all it needs), as median, p99 and max;
the fraction of control periods missed (not all five efforts back before the next state); the
stand-in's own publishing jitter; each controller's CPU use. The machine has 2 cores and other
work runs on it: the numbers are noisy and pessimistic; rerun on a quiet machine to compare.
Writes ``benchmarks/results/control_loop_benchmark.json``.
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


def _arguments() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--duration', type=float, default=60.0, help='measured seconds')
    parser.add_argument('--rates', type=float, nargs='+', default=[500.0],
                        help='control rates to run, one after the other [Hz] (default 500)')
    parser.add_argument('--warmup', type=float, default=3.0, help='seconds not measured')
    parser.add_argument('--output', type=Path, default=RESULT, help='JSON result file')
    return parser.parse_args()


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
            plant.mode_pub.publish(ControlMode(mode=ControlMode.COARSE, base_gripper='a'))
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
        'benchmark': 'control_loop_benchmark',
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


def main() -> int:
    """Run the benchmark, print the table, write the JSON result."""
    args = _arguments()
    walker_env.reexec_in_environment(os.path.abspath(__file__), sys.argv[1:])
    runs = []
    for rate in args.rates:
        runs.append(_run(args, rate))
        _report(runs[-1])
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps({'benchmark': 'control_loop_benchmark', 'runs': runs},
                                      indent=2) + '\n')
    print(f'  written: {args.output}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
