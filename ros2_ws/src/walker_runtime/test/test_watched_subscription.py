"""WatchedSubscription on a real rclpy node: silence, renewal, and a stream that still flows."""

import math
import time

import pytest
from ros_test_support import spin_executor_until
from std_msgs.msg import Int32

from walker_runtime.qos import COMMAND_QOS
from walker_runtime.spinning import TopicSampler
from walker_runtime.watched_subscription import SampledSubscription, WatchedSubscription

SPIN = 5.0  # [s] wall clock, for a message to come through on a loaded machine


class _Logger:
    def __init__(self):
        self.warnings = []

    def warning(self, text):
        self.warnings.append(text)


class _Steady:
    """A steady clock the test sets by hand [s]."""

    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now


@pytest.fixture
def node(rclpy_context):
    from rclpy.node import Node

    node = Node('watched', context=rclpy_context)
    yield node
    node.destroy_node()


def _deliver(node, publisher, received, value):
    """Publish ``value`` and spin until the callback has it."""
    from rclpy.executors import SingleThreadedExecutor

    executor = SingleThreadedExecutor(context=node.context)
    executor.add_node(node)
    try:
        publisher.publish(Int32(data=value))
        return spin_executor_until(executor, lambda: value in received, SPIN)
    finally:
        executor.remove_node(node)
        executor.shutdown(timeout_sec=0.0)


def _watched(node, received, steady, logger, **watch):
    return WatchedSubscription(node, Int32, 'numbers', lambda m: received.append(m.data),
                               COMMAND_QOS, after=1.0, steady_now=steady, logger=logger, **watch)


def test_a_silent_subscription_is_made_anew_and_the_stream_flows_again(node):
    steady, logger, received = _Steady(), _Logger(), []
    publisher = node.create_publisher(Int32, 'numbers', COMMAND_QOS)
    watched = _watched(node, received, steady, logger)
    assert _deliver(node, publisher, received, 1)
    assert watched.last_heard == steady.now
    first = watched.subscription
    steady.now += 0.9
    assert not watched.check() and watched.subscription is first
    steady.now += 0.1
    assert watched.check()
    assert watched.subscription is not first
    assert list(node.subscriptions) == [watched.subscription]
    assert watched.renewals == 1
    assert logger.warnings == ['numbers: silent for 1.0 s while 1 publisher(s) in the graph, '
                               'subscription made anew (a restarted or resumed peer is matched '
                               'again)']
    steady.now += 0.5
    assert not watched.check(), 'once per interval while the silence lasts'
    steady.now += 0.5
    assert watched.check() and watched.renewals == 2
    assert _deliver(node, publisher, received, 2), 'the new subscription receives'
    assert watched.last_heard == steady.now


def test_a_stream_never_heard_from_is_left_alone_unless_counted_from_the_start(node):
    steady, logger = _Steady(), _Logger()
    node.create_publisher(Int32, 'numbers', COMMAND_QOS)
    alone = _watched(node, [], steady, logger)
    counted = _watched(node, [], steady, logger, count_from_start=True)
    steady.now += 5.0
    assert not alone.check() and alone.last_heard is None
    assert counted.check() and counted.last_heard == steady.now - 5.0


def test_a_silence_counts_only_while_the_condition_holds(node):
    steady, logger, heard = _Steady(), _Logger(), {'at': 100.0}
    running = {'clock': False}
    node.create_publisher(Int32, 'numbers', COMMAND_QOS)
    watched = _watched(node, [], steady, logger, last_heard=lambda: heard['at'],
                       counts=lambda: running['clock'])
    steady.now += 3.0
    assert not watched.check(), "the clock stands still: the silence is the publisher's"
    running['clock'] = True
    assert watched.check()
    heard['at'] = steady.now  # the caller's own watchdog heard the stream
    steady.now += 0.5
    assert not watched.check()


def test_a_silence_with_no_publisher_in_the_graph_is_the_publishers_and_left_alone(node):
    """Gone (or never started): a new subscription would hear nothing more."""
    steady, logger = _Steady(), _Logger()
    watched = _watched(node, [], steady, logger)
    watched.heard()
    steady.now += 5.0
    assert watched.peers() == 0
    assert not watched.check() and watched.renewals == 0 and logger.warnings == []
    publisher = node.create_publisher(Int32, 'numbers', COMMAND_QOS)
    assert watched.peers() == 1
    assert watched.check(), "a publisher back in the graph: the silence is the reader's"
    node.destroy_publisher(publisher)
    steady.now += 5.0
    assert not watched.check() and watched.renewals == 1


def test_the_interval_follows_a_parameter_change_and_refuses_nonsense(node):
    steady, logger, received = _Steady(), _Logger(), []
    node.create_publisher(Int32, 'numbers', COMMAND_QOS)
    watched = _watched(node, received, steady, logger)
    watched.heard()
    watched.after = 4.0
    steady.now += 3.9
    assert not watched.check()
    steady.now += 0.1
    assert watched.check()
    for bad in (0.0, -1.0, math.nan, math.inf, True):
        with pytest.raises(ValueError, match='positive and finite'):
            watched.after = bad
    assert watched.after == 4.0


def test_renew_and_destroy_act_at_once_and_log_nothing(node):
    steady, logger = _Steady(), _Logger()
    watched = _watched(node, [], steady, logger)
    first = watched.subscription
    watched.renew()
    assert watched.subscription is not first and list(node.subscriptions) == [
        watched.subscription]
    watched.destroy()
    assert watched.subscription is None and list(node.subscriptions) == []
    assert logger.warnings == [] and watched.renewals == 0


def test_a_subscription_destroyed_for_good_is_never_made_anew(node):
    """Its stream now comes another way (by call): a silence is not the subscription's."""
    steady, logger = _Steady(), _Logger()
    watched = _watched(node, [], steady, logger)
    watched.heard()
    watched.destroy()
    steady.now += 10.0
    assert not watched.check()
    watched.renew()
    assert watched.subscription is None and list(node.subscriptions) == []
    assert logger.warnings == []


def _take_until(sampled, publisher, value):
    """Publish ``value`` until a take of ``sampled`` has it (matching takes a while)."""
    deadline = time.monotonic() + SPIN
    while time.monotonic() < deadline:
        publisher.publish(Int32(data=value))
        time.sleep(0.05)
        if value in [m.data for m in sampled.take()]:
            return True
    return False


def test_a_sampled_subscription_is_made_anew_and_takes_again(node):
    """A stream read in batches: a take counts as heard; renewed on the sampler's node."""
    steady, logger = _Steady(), _Logger()
    sampler = TopicSampler('sampled', node.get_namespace(), node.context)
    try:
        publisher = node.create_publisher(Int32, 'numbers', COMMAND_QOS)
        sampled = SampledSubscription(sampler, Int32, 'numbers', COMMAND_QOS, after=1.0,
                                      steady_now=steady, logger=logger)
        assert sampled.take() == [] and sampled.last_heard is None
        assert _take_until(sampled, publisher, 1)
        assert sampled.last_heard == steady.now
        first = sampled.subscription
        steady.now += 1.0
        assert sampled.check() and sampled.subscription is not first
        assert list(sampler.node.subscriptions) == [sampled.subscription]
        assert logger.warnings[0].startswith('numbers: silent for 1.0 s while 1 publisher(s) '
                                             'in the graph, subscription made anew')
        assert _take_until(sampled, publisher, 2), 'the new subscription receives'
        sampled.destroy()
        assert sampled.subscription is None and list(sampler.node.subscriptions) == []
    finally:
        sampler.destroy()


def test_a_renewable_publisher_is_made_anew_by_its_owner_only_and_delivers_again(node):
    """The supervisor's control_mode publisher: renewed when its commands have no effect."""
    from walker_runtime.watched_subscription import RenewablePublisher

    steady, logger, received = _Steady(), _Logger(), []
    node.create_subscription(Int32, 'numbers', lambda m: received.append(m.data), COMMAND_QOS)
    renewable = RenewablePublisher(node, Int32, 'numbers', COMMAND_QOS, logger=logger,
                                   steady_now=steady)
    assert renewable.after is None and renewable.peers() == 1
    first = renewable.publisher
    steady.now += 1e6
    assert not renewable.check() and renewable.publisher is first  # no silence rule
    renewable.renew()
    assert renewable.publisher is not first and list(node.publishers)[-1] is renewable.publisher
    assert len([p for p in node.publishers if p.topic_name == '/numbers']) == 1
    assert _deliver(node, renewable, received, 3), 'the new publisher delivers'
    renewable.destroy()
    assert renewable.publisher is None
