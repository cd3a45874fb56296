#!/usr/bin/env python3
"""Throughput and CPU cost of the walk recorder against real publishers over Fast DDS.

Usage: ``python3 benchmarks/recorder_benchmark.py [--duration SECONDS]``. For each scenario a
publisher process publishes ``sensor_msgs/JointState`` messages (five joints, the walker's
joint states) on several topics at the control rate, with best-effort or reliable QoS, for a
fixed time; the recorder node records them. The table gives what was published and recorded,
the loss, the recorder's CPU use (user + system time of its process over the publishing time)
and the bag's data rate. Results go to ``benchmarks/results/recorder.json``.

The numbers are noisy: the machine has two cores and other work runs beside the benchmark; the
publisher, also Python, may not reach the rate it is asked for (the table shows what it did).
Every process keeps DDS discovery on loopback, in a ROS domain of its own.
"""

import argparse
import json
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO_ROOT / 'scripts'))

import walker_env  # noqa: E402

CONTROL_RATE = 500.0  # [Hz] timing.control_rate of the parameter file
# (topics, QoS) of each scenario.
SCENARIOS = [(1, 'best_effort'), (4, 'best_effort'), (4, 'reliable'), (12, 'best_effort')]
START_TIMEOUT = 60.0  # [s]

PUBLISHER = """
import sys, time
import rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
topics, reliability, rate, duration = int(sys.argv[1]), sys.argv[2], float(sys.argv[3]), \\
    float(sys.argv[4])
rclpy.init()
node = Node('bench_publisher', namespace='/walker')
qos = QoSProfile(depth=10, reliability=ReliabilityPolicy[reliability.upper()])
pubs = [node.create_publisher(JointState, f'bench/t{i}', qos) for i in range(topics)]
while any(p.get_subscription_count() == 0 for p in pubs):
    time.sleep(0.05)
names = ['a_yaw_joint', 'a_pitch_joint', 'vertex_joint', 'b_pitch_joint', 'b_yaw_joint']
count = [0]
def tick():
    msg = JointState(name=names, position=[0.1] * 5, velocity=[0.0] * 5, effort=[0.0] * 5)
    msg.header.stamp = node.get_clock().now().to_msg()
    for p in pubs:
        p.publish(msg)
        count[0] += 1
timer = node.create_timer(1.0 / rate, tick)
print('publishing', flush=True)
end = time.monotonic() + duration
while time.monotonic() < end:
    rclpy.spin_once(node, timeout_sec=0.01)
timer.cancel()
print(f'published {count[0]}', flush=True)
try:
    rclpy.spin(node)
except KeyboardInterrupt:
    pass
node.destroy_node()
rclpy.try_shutdown()
"""


def cpu_seconds(pid: int) -> float:
    """User plus system CPU time of a process [s]."""
    fields = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')


def run_scenario(topics: int, reliability: str, duration: float, workdir: Path) -> dict:
    """Record one scenario; return its measurements."""
    from ros_test_support import NodeProcess, isolated_domain, ros_environment
    from walker_bag.core.bag_metadata import read_metadata
    from walker_bag.recorder_command import recorder_command

    bag = workdir / f'bench_{topics}_{reliability}'
    with isolated_domain() as domain:
        env = ros_environment(domain)
        recorder = NodeProcess(recorder_command(workdir, bag_name=bag.name), env, 'recorder')
        with recorder:
            assert recorder.wait_for_output('recording', START_TIMEOUT), recorder.output
            publisher = NodeProcess([sys.executable, '-c', PUBLISHER, str(topics), reliability,
                                     str(CONTROL_RATE), str(duration)], env, 'publisher')
            with publisher:
                assert publisher.wait_for_output('publishing', START_TIMEOUT), publisher.output
                cpu_start, wall_start = cpu_seconds(recorder.process.pid), time.monotonic()
                assert publisher.wait_for_output('published ', duration + START_TIMEOUT)
                cpu = cpu_seconds(recorder.process.pid) - cpu_start
                wall = time.monotonic() - wall_start
                published = int(publisher.output.split('published ')[1].split()[0])
            recorder.stop()
    metadata = read_metadata(bag)
    size = sum((bag / f).stat().st_size for f in metadata.relative_file_paths)
    recorded = metadata.message_count
    return {
        'topics': topics, 'reliability': reliability, 'rate_hz_per_topic': CONTROL_RATE,
        'published': published, 'published_per_s': published / wall,
        'recorded': recorded, 'lost_percent': 100.0 * max(0, published - recorded) / published,
        'recorder_cpu_percent': 100.0 * cpu / wall,
        'recorder_cpu_us_per_message': 1e6 * cpu / max(recorded, 1),
        'bag_mib_per_s': size / wall / 2**20,
    }


def main() -> int:
    """Run every scenario, print the table, write the JSON results."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--duration', type=float, default=5.0,
                        help='publishing time of each scenario [s]')
    args = parser.parse_args()
    walker_env.reexec_in_environment(os.path.abspath(__file__), sys.argv[1:])
    sys.path.insert(0, str(REPO_ROOT / 'tests'))
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    results = []
    with tempfile.TemporaryDirectory() as workdir:
        for topics, reliability in SCENARIOS:
            results.append(run_scenario(topics, reliability, args.duration, Path(workdir)))
            r = results[-1]
            print(f'{r["topics"]:>3} x {r["rate_hz_per_topic"]:.0f} Hz {r["reliability"]:<11} '
                  f'published {r["published_per_s"]:7.0f}/s  recorded {r["recorded"]:6d} of '
                  f'{r["published"]:6d} ({r["lost_percent"]:5.1f}% lost)  '
                  f'recorder CPU {r["recorder_cpu_percent"]:5.1f}% '
                  f'({r["recorder_cpu_us_per_message"]:4.0f} us/message)  '
                  f'{r["bag_mib_per_s"]:.2f} MiB/s', flush=True)
    out = REPO_ROOT / 'benchmarks' / 'results' / 'recorder.json'
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({
        'machine': {'cpus': os.cpu_count(), 'load_average': os.getloadavg(),
                    'python': platform.python_version()},
        'duration_s': args.duration, 'scenarios': results}, indent=1) + '\n')
    print(f'results written to {out.relative_to(REPO_ROOT)}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
