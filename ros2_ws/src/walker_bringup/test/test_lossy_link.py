"""The lossy link: reproducible drops, delays without reordering, and the node over DDS."""

import time

import numpy as np
import pytest

from ros_test_support import NodeProcess
from walker_bringup.lossy_link import LossyLink


def kept(link, count, spacing=0.0):
    return [i for i in range(count) if link.offer(i, i * spacing)]


def test_drops_are_seeded_and_near_the_asked_probability():
    first, again = kept(LossyLink(0.2, seed=7), 5000), kept(LossyLink(0.2, seed=7), 5000)
    other = kept(LossyLink(0.2, seed=8), 5000)
    assert first == again and first != other
    assert len(first) / 5000 == pytest.approx(0.8, abs=0.02)
    assert kept(LossyLink(0.0), 100) == list(range(100))
    assert kept(LossyLink(1.0), 100) == []


def test_kept_messages_come_after_the_delay_in_arrival_order_and_are_counted():
    link = LossyLink(0.3, delay=0.05, jitter=0.02, seed=3)
    arrived = kept(link, 200, spacing=0.001)
    assert link.due(0.049) == []  # nothing before the delay
    delivered, now = [], 0.0
    while link.pending:
        now += 0.001
        for message in link.due(now):
            delivered.append(message)
            assert now >= message * 0.001 + 0.05 - 1e-12
    assert delivered == arrived  # jitter never reorders
    counts = link.counts
    assert counts.received == 200 and counts.delivered == len(arrived)
    assert counts.dropped == 200 - len(arrived) and counts.longest_run_dropped >= 1


@pytest.mark.parametrize('arguments, words', [
    ((1.5,), 'drop_probability'),
    ((-0.1,), 'drop_probability'),
    ((0.1, -1.0), 'delay'),
    ((0.1, 0.0, float('nan')), 'jitter'),
])
def test_invalid_settings_are_refused_by_name(arguments, words):
    with pytest.raises(ValueError, match=words):
        LossyLink(*arguments)


def _start_link(ros_env, *parameters):
    from ament_index_python.packages import get_package_prefix

    executable = f'{get_package_prefix("walker_bringup")}/lib/walker_bringup/lossy_link'
    args = [executable, '--ros-args', '-r', '__ns:=/test']
    for name, value in parameters:
        args += ['-p', f'{name}:={value}']
    return NodeProcess(args, ros_env, 'lossy_link')


def test_the_node_relays_the_kept_messages_in_order_late_by_the_delay(ros_env, rclpy_context):
    from rclpy.node import Node
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from std_msgs.msg import UInt32

    delay, count, seed, drop = 0.05, 300, 11, 0.25
    expected = kept(LossyLink(drop, seed=seed), count)
    with _start_link(ros_env, ('input', 'numbers'), ('output', 'numbers_lossy'),
                     ('type', 'std_msgs/msg/UInt32'), ('drop_probability', drop),
                     ('delay', delay), ('seed', seed)) as link:
        assert link.wait_for_output('relaying /test/numbers -> /test/numbers_lossy', 60.0), \
            link.output
        node = Node('probe', namespace='/test', context=rclpy_context)
        qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
        received, sent_at = [], {}
        node.create_subscription(UInt32, 'numbers_lossy',
                                 lambda m: received.append((m.data, time.monotonic())), qos)
        publisher = node.create_publisher(UInt32, 'numbers', qos)
        from rclpy.executors import SingleThreadedExecutor

        executor = SingleThreadedExecutor(context=rclpy_context)
        executor.add_node(node)
        deadline = time.monotonic() + 30.0
        while (publisher.get_subscription_count() == 0 or node.count_publishers(
                'numbers_lossy') == 0) and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        time.sleep(1.0)  # both sides matched both ways
        for i in range(count):
            sent_at[i] = time.monotonic()
            publisher.publish(UInt32(data=i))
            executor.spin_once(timeout_sec=0.002)
        deadline = time.monotonic() + 30.0
        while len(received) < len(expected) and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        executor.shutdown()
        node.destroy_node()
        assert link.stop() == 0, link.output
        assert f'{count} received, {count - len(expected)} dropped' in link.output
    assert [data for data, _ in received] == expected
    lateness = np.array([t - sent_at[data] for data, t in received])
    assert lateness.min() >= delay, f'a message came {lateness.min() * 1e3:.1f} ms late'


@pytest.mark.parametrize('parameters, words', [
    ((('input', 'a'), ('output', 'a'), ('type', 'std_msgs/msg/UInt32')), 'same topic'),
    ((('input', 'a'), ('output', 'b'), ('type', 'std_msgs/msg/Nothing')), 'no such message'),
    ((('input', 'a'), ('type', 'std_msgs/msg/UInt32')), 'input and output'),
    ((('input', 'a'), ('output', 'b'), ('type', 'std_msgs/msg/UInt32'),
      ('drop_probability', 1.5)), 'drop_probability'),
])
def test_the_node_refuses_to_start_on_invalid_parameters(ros_env, parameters, words):
    with _start_link(ros_env, *parameters) as link:
        link.process.wait(timeout=60.0)
        assert link.process.returncode == 2, link.output
        assert 'refusing to start' in link.output and words in link.output


def test_the_settings_change_at_run_time_and_invalid_ones_change_nothing(rclpy_context):
    from rclpy.parameter import Parameter

    from walker_bringup.lossy_link_node import LossyLinkNode

    node = LossyLinkNode(context=rclpy_context, namespace='/test', parameter_overrides=[
        Parameter('input', value='a'), Parameter('output', value='b'),
        Parameter('type', value='std_msgs/msg/UInt32')])
    try:
        applied = node.set_parameters_atomically([Parameter('drop_probability', value=1.0),
                                                  Parameter('delay', value=0.02)])
        assert applied.successful
        assert (node.link.drop_probability, node.link.delay) == (1.0, 0.02)
        refused = node.set_parameters([Parameter('jitter', value=-0.5)])[0]
        assert not refused.successful and 'jitter' in refused.reason
        assert node.link.jitter == 0.0 and node.get_parameter('jitter').value == 0.0
        frozen = node.set_parameters([Parameter('seed', value=3)])[0]
        assert not frozen.successful
    finally:
        node.destroy_node()
