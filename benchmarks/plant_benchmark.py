#!/usr/bin/env python3
"""Benchmark of the plant: real-time factor and step cost, and real-time JointState jitter.

Usage: ``python3 benchmarks/plant_benchmark.py [--seconds S] [--jitter-seconds S]``. Sets up the
environment like the other scripts, runs in well under a minute, prints a table and writes
``benchmarks/results/plant.json``.

1. Sim-time physics, no ROS: the plant core (:class:`walker_sim.core.plant.WalkerPlant`) steps
   the full model (flexible links, geared rotors, friction, the attachment) one control period
   at a time, gripper a attached and gripper b swinging under torques that beat friction,
   as in a step. Reports the real-time factor and the cost of a control step and of a physics
   step (median and 99th percentile), and the same at rest.
2. Contact with a node: the free gripper held pressed on a node's face beside the hole, and
   free above its node, each with the node's contact on and switched off; the cost of a
   control step and the real-time factor.
3. Accuracy of the shipped physics settings: each of joints 1-3, friction on, is driven by half
   its torque limit for 0.3 s and left free for 0.7 s; its speed and the tip's path are
   compared with those of a converged reference (4 kHz physics, 300 solver iterations). Reports
   the largest speed difference relative to the peak speed, and the largest tip difference.
4. Real-time mode over DDS: the plant node runs in its own process (isolated ROS domain, loopback
   discovery) and a subscriber here records the period between JointState messages: by their
   stamps (the plant's timer) and by their arrival (what a controller sees).

Timing depends on the machine and its load; the JSON records the CPU count and load average.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO_ROOT / 'scripts'))
sys.path.insert(0, str(REPO_ROOT / 'tests'))

import walker_env  # noqa: E402

RESULTS = REPO_ROOT / 'benchmarks' / 'results' / 'plant.json'


def percentiles(values, points=(50, 99)):
    """Percentiles of a sequence (numpy), as a dict ``{'p50': ..., 'p99': ...}``."""
    import numpy as np

    array = np.asarray(values, dtype=float)
    return {f'p{p}': float(np.percentile(array, p)) for p in points}


def physics_benchmark(seconds: float) -> dict:
    """Step the plant core in sim time; return real-time factors and step costs."""
    import numpy as np

    from walker_core.robot_parameters import load_walker_parameters
    from walker_sim.core.config import StartConfiguration, load_sim_parameters
    from walker_sim.core.plant import WalkerPlant

    import pybullet

    engine = []
    step_simulation = pybullet.stepSimulation

    def timed_step(*args, **kwargs):
        tick = time.perf_counter()
        step_simulation(*args, **kwargs)
        engine.append(time.perf_counter() - tick)

    params, sim = load_walker_parameters(), load_sim_parameters()
    period = 1.0 / params.timing.control_rate
    substeps = round(sim.physics_rate / params.timing.control_rate)
    steps = round(seconds / period)
    results = {'control_rate_hz': params.timing.control_rate,
               'physics_rate_hz': sim.physics_rate, 'simulated_s': steps * period}
    with WalkerPlant(params, sim) as plant:
        start = StartConfiguration('a', sim.start.base_node, sim.start.other_node, False, 0.0)
        limits = plant.drive.torque_limit
        plant.enable_contact(False)  # free swinging, as before the contact: see contact_benchmark
        pybullet.stepSimulation = timed_step  # the plant calls it through the module
        for case in ('moving', 'at_rest'):
            plant.reset(start)
            engine.clear()
            costs = np.empty(steps)
            began = time.perf_counter()
            for k in range(steps):
                t = k * period
                torque = (0.6 * limits * np.sin(2 * np.pi * 0.5 * t + np.arange(5))
                          if case == 'moving' else np.zeros(5))
                tick = time.perf_counter()
                plant.step(torque, period)
                costs[k] = time.perf_counter() - tick
            wall = time.perf_counter() - began
            stepping = costs.sum()
            results[case] = {
                'real_time_factor': steps * period / stepping,
                'real_time_factor_with_torque_generation': steps * period / wall,
                'control_step_us': {k: v * 1e6 for k, v in percentiles(costs).items()},
                'physics_step_us': {k: v * 1e6 / substeps
                                    for k, v in percentiles(costs).items()},
                'engine_step_us': {k: v * 1e6 for k, v in percentiles(engine).items()},
                'engine_share': float(np.sum(engine) / stepping),
                'engine_only_real_time_factor': steps * period / float(np.sum(engine)),
            }
        pybullet.stepSimulation = step_simulation
    return results


def contact_benchmark(seconds: float) -> dict:
    """Step the plant core with its free gripper on a node's face, contact on and off.

    Cases: ``pressed``, the gripper held pressed on the face 4 mm off the hole by a joint PD
    (the node's forces are computed and applied every physics step); ``above``, the gripper
    free 30 mm above its node, the approach height (the plant only looks where the gripper is,
    as seldom as its distance from the face allows).
    Each with the contact on and switched off (``WalkerPlant.enable_contact``); the PD's
    torques are computed outside the timed ``step()``.
    """
    import numpy as np

    from walker_core.robot_parameters import load_walker_parameters
    from walker_sim.core.config import StartConfiguration, load_sim_parameters
    from walker_sim.core.contact import SCREW_LENGTH
    from walker_sim.core.plant import WalkerPlant

    params, sim = load_walker_parameters(), load_sim_parameters()
    period = 1.0 / params.timing.control_rate
    steps = round(seconds / period)
    results = {'simulated_s': steps * period}
    with WalkerPlant(params, sim) as plant:
        start = StartConfiguration('a', sim.start.base_node, sim.start.other_node, False, 0.03)
        base = plant.node_position(sim.start.base_node)
        node = plant.node_position(sim.start.other_node)
        for case, point in (('pressed', [0.004, 0.0, SCREW_LENGTH - 0.001]),
                            ('above', [0.0, 0.0, 0.03])):
            goal = np.array(plant.kinematics.inverse([*(node - base + point), 0.0, 0.0]))
            for contact in (True, False):
                plant.enable_contact(contact)
                plant.enable_friction(False)  # the joints go where the PD and the face say
                state = plant.reset(start)
                costs = np.empty(steps)
                touching = 0
                for k in range(steps):
                    torque = 300.0 * (goal - plant.true_joint_positions()) - 20.0 * state.velocity
                    tick = time.perf_counter()
                    state = plant.step(torque, period)
                    costs[k] = time.perf_counter() - tick
                    touching += bool(plant.contacts) or (
                        not contact and state.poses['b'].position[2] - node[2] < SCREW_LENGTH)
                results[f'{case}_contact_{"on" if contact else "off"}'] = {
                    'real_time_factor': steps * period / float(costs.sum()),
                    'control_step_us': {k: v * 1e6 for k, v in percentiles(costs).items()},
                    'periods_touching': int(touching)}
        plant.enable_contact(True)
    return results


# Converged reference for the accuracy check: physics rate [Hz], solver iterations, residual.
_REFERENCE_PHYSICS = (4000.0, 300, 1e-12)


def _pulse_response(params, sim, joint: int, iterations: int, residual: float,
                    seconds: float = 1.0, pulse: float = 0.3):
    """Speed of ``joint`` and tip path under a torque pulse (half the limit), friction on."""
    import numpy as np

    from walker_sim.core.config import StartConfiguration
    from walker_sim.core.plant import WalkerPlant

    period = 1.0 / params.timing.control_rate
    with WalkerPlant(params, sim) as plant:
        plant.set_solver(iterations, residual)
        plant.enable_contact(False)  # free motion: the gripper starts at its node's mouth
        plant.reset(StartConfiguration('a', sim.start.base_node, sim.start.other_node, False,
                                       0.0))
        torque = np.zeros(5)
        speed, tip = [], []
        for k in range(round(seconds / period)):
            torque[joint] = 0.5 * plant.drive.torque_limit[joint] if k * period < pulse else 0.0
            state = plant.step(torque, period)
            speed.append(state.velocity[joint])
            tip.append(state.tip_position)
    return np.array(speed), np.array(tip)


def accuracy_benchmark() -> dict:
    """Compare the shipped physics settings with a converged reference (joints 1-3)."""
    import dataclasses

    import numpy as np

    from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
    from walker_core.robot_parameters import load_walker_parameters
    from walker_sim.core.config import load_sim_parameters
    from walker_sim.core.plant import SOLVER_ITERATIONS, SOLVER_RESIDUAL

    params, sim = load_walker_parameters(), load_sim_parameters()
    rate, iterations, residual = _REFERENCE_PHYSICS
    reference_sim = dataclasses.replace(sim, physics_rate=rate)
    joints = {}
    for joint in range(3):
        speed, tip = _pulse_response(params, sim, joint, SOLVER_ITERATIONS, SOLVER_RESIDUAL)
        ref_speed, ref_tip = _pulse_response(params, reference_sim, joint, iterations,
                                             residual)
        joints[PHYSICAL_JOINT_NAMES[joint]] = {
            'speed_error_relative': float(np.abs(speed - ref_speed).max()
                                          / np.abs(ref_speed).max()),
            'tip_error_m': float(np.linalg.norm(tip - ref_tip, axis=1).max()),
            'tip_travel_m': float(np.linalg.norm(ref_tip[-1] - ref_tip[0])),
        }
    return {'physics_rate_hz': sim.physics_rate, 'solver_iterations': SOLVER_ITERATIONS,
            'reference': {'physics_rate_hz': rate, 'solver_iterations': iterations},
            'joints': joints}


def jitter_benchmark(seconds: float) -> dict:
    """Run the plant node in real time and measure the JointState period at a subscriber."""
    import numpy as np
    import rclpy
    from ament_index_python.packages import get_package_prefix
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from sensor_msgs.msg import JointState

    from ros_test_support import NodeProcess, isolated_domain, ros_environment
    from walker_sim.messages import SENSOR_QOS

    executable = str(Path(get_package_prefix('walker_sim')) / 'lib' / 'walker_sim' /
                     'plant_node')
    with isolated_domain() as domain:
        env = ros_environment(domain)
        context = Context()
        rclpy.init(context=context, domain_id=domain)
        arrivals, stamps = [], []
        node = Node('jitter_probe', context=context)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)

        def on_state(message):
            arrivals.append(time.monotonic_ns())
            stamps.append(message.header.stamp.sec * 10**9 + message.header.stamp.nanosec)

        node.create_subscription(JointState, '/walker/joint_states', on_state, SENSOR_QOS)
        args = [executable, '--ros-args', '-r', '__ns:=/walker', '-p',
                'sim.clock_mode:=real_time', '-p', 'timing.realtime_priority:=50']  # --realtime
        try:
            with NodeProcess(args, env, 'plant'):
                deadline = time.monotonic() + 60.0
                while not arrivals and time.monotonic() < deadline:
                    executor.spin_once(timeout_sec=0.05)
                if not arrivals:
                    raise RuntimeError('the plant node published nothing within 60 s')
                time.sleep(1.0)  # let start-up settle
                arrivals.clear()
                stamps.clear()
                deadline = time.monotonic() + seconds
                while time.monotonic() < deadline:
                    executor.spin_once(timeout_sec=0.01)
        finally:
            executor.shutdown()
            node.destroy_node()
            rclpy.try_shutdown(context=context)
    arrival_periods = np.diff(np.asarray(arrivals)) * 1e-6
    stamp_periods = np.diff(np.unique(np.asarray(stamps))) * 1e-6
    expected = len(np.unique(stamps))
    span = (max(stamps) - min(stamps)) * 1e-9 if stamps else 0.0
    return {
        'measured_s': seconds,
        'messages_received': len(arrivals),
        'stamps_seen': expected,
        'published_rate_hz': (expected - 1) / span if span else 0.0,
        'stamp_period_ms': {**percentiles(stamp_periods, (1, 50, 99)),
                            'max': float(stamp_periods.max())},
        'arrival_period_ms': {**percentiles(arrival_periods, (1, 50, 99)),
                              'max': float(arrival_periods.max())},
    }


def main() -> int:
    """Run both benchmarks, print a table, write the JSON."""
    walker_env.reexec_in_environment(os.path.abspath(__file__), sys.argv[1:])
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--seconds', type=float, default=10.0,
                        help='simulated seconds of the physics benchmark')
    parser.add_argument('--jitter-seconds', type=float, default=10.0,
                        help='wall-clock seconds of the real-time jitter measurement')
    parser.add_argument('--output', type=Path, default=RESULTS)
    parser.add_argument('--contact-only', action='store_true',
                        help='measure the contact only and update that part of the JSON')
    args = parser.parse_args()
    from importlib.metadata import version

    machine = {'cpus': os.cpu_count(), 'load_average_1_5_15': list(os.getloadavg()),
               'python': platform.python_version(), 'pybullet': version('pybullet'),
               'date': time.strftime('%Y-%m-%d %H:%M:%S %Z')}
    if args.contact_only:
        contact = contact_benchmark(args.seconds)
        machine['load_average_after'] = list(os.getloadavg())
        contact['machine'] = machine
        document = json.loads(args.output.read_text()) if args.output.exists() else {}
        document['contact'] = contact
        args.output.write_text(json.dumps(document, indent=2) + '\n')
        _print_contact(contact)
        return 0
    physics = physics_benchmark(args.seconds)
    contact = contact_benchmark(args.seconds)
    accuracy = accuracy_benchmark()
    jitter = jitter_benchmark(args.jitter_seconds)
    machine['load_average_after'] = list(os.getloadavg())
    document = {'machine': machine, 'physics': physics, 'contact': contact,
                'accuracy': accuracy,
                'real_time_jitter': jitter}
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(document, indent=2) + '\n')

    print(f'plant benchmark ({machine["cpus"]} CPUs, load average '
          f'{machine["load_average_1_5_15"][0]:.2f})')
    print(f'physics, sim time: {physics["physics_rate_hz"]:g} Hz physics, '
          f'{physics["control_rate_hz"]:g} Hz control, {physics["simulated_s"]:g} s simulated')
    print(f'  {"case":<8} {"RTF":>6} {"control step p50/p99":>21} {"physics step p50/p99":>21} '
          f'{"engine p50/p99":>15} {"engine RTF":>10}')
    for case in ('moving', 'at_rest'):
        row = physics[case]
        control, step, engine = (row['control_step_us'], row['physics_step_us'],
                                 row['engine_step_us'])
        print(f'  {case:<8} {row["real_time_factor"]:>6.1f} '
              f'{control["p50"]:>10.0f} / {control["p99"]:<5.0f} us '
              f'{step["p50"]:>10.0f} / {step["p99"]:<5.0f} us '
              f'{engine["p50"]:>5.0f} / {engine["p99"]:<5.0f} us '
              f'{row["engine_only_real_time_factor"]:>7.1f}')
    _print_contact(contact)
    reference = accuracy['reference']
    print(f'accuracy: {accuracy["physics_rate_hz"]:g} Hz, {accuracy["solver_iterations"]} '
          f'iterations against {reference["physics_rate_hz"]:g} Hz, '
          f'{reference["solver_iterations"]} iterations (torque pulse, friction on)')
    for name, row in accuracy['joints'].items():
        print(f'  {name:<14} speed {100 * row["speed_error_relative"]:.2f} % of peak, tip '
              f'{1e3 * row["tip_error_m"]:.3f} mm of {1e3 * row["tip_travel_m"]:.0f} mm travel')
    print(f'real time, JointState over DDS ({jitter["measured_s"]:g} s, '
          f'{jitter["published_rate_hz"]:.1f} Hz published, '
          f'{jitter["messages_received"]} received):')
    for name in ('stamp_period_ms', 'arrival_period_ms'):
        row = jitter[name]
        print(f'  {name:<18} p1 {row["p1"]:.3f}  median {row["p50"]:.3f}  p99 {row["p99"]:.3f}'
              f'  max {row["max"]:.3f} ms')
    print(f'wrote {args.output.relative_to(REPO_ROOT)}')
    return 0


def _print_contact(contact: dict) -> None:
    print(f'contact with a node, sim time ({contact["simulated_s"]:g} s simulated each):')
    for name, row in contact.items():
        if not isinstance(row, dict) or 'control_step_us' not in row:
            continue
        control = row['control_step_us']
        print(f'  {name:<20} RTF {row["real_time_factor"]:>5.1f}  control step p50/p99 '
              f'{control["p50"]:>4.0f} / {control["p99"]:<4.0f} us  '
              f'({row["periods_touching"]} periods below the face)')


if __name__ == '__main__':
    sys.exit(main())
