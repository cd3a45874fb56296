"""spin_nodes: how spinning ends (in-process, no DDS traffic needed)."""

import gc
import threading

import pytest
from rclpy.node import Node

from walker_runtime import spinning


@pytest.fixture(autouse=True)
def _collector_unfrozen():
    """spin_nodes freezes what exists: give the test process its collector back afterwards."""
    yield
    gc.unfreeze()


class _FailingExecutor:
    """An executor whose spin_once raises, optionally shutting the context down first."""

    def __init__(self, context, shut_down_first) -> None:
        self.context, self.shut_down_first = context, shut_down_first

    def add_node(self, node) -> None:
        pass

    def remove_node(self, node) -> None:
        pass

    def shutdown(self, timeout_sec=None) -> None:
        pass

    def spin_once(self, timeout_sec=None) -> None:
        if self.shut_down_first == 'now':
            self.context.try_shutdown()
        elif self.shut_down_first == 'soon':  # a signal's shutdown still under way elsewhere
            threading.Timer(0.2, self.context.try_shutdown).start()
        raise RuntimeError('Unable to convert call argument to Python object')


@pytest.mark.parametrize('shut_down_first', ['now', 'soon', None])
def test_an_executor_error_during_shutdown_ends_spinning_quietly_and_any_other_is_raised(
        monkeypatch, rclpy_context, shut_down_first):
    context = rclpy_context
    node = Node('spin_probe', context=context, start_parameter_services=False,
                enable_rosout=False)
    monkeypatch.setattr(spinning, 'make_executor',
                        lambda ctx: _FailingExecutor(context, shut_down_first))
    try:
        if shut_down_first:
            spinning.spin_nodes(node, context=context)  # returns: the shutdown was asked for
        else:
            with pytest.raises(RuntimeError, match='Unable to convert'):
                spinning.spin_nodes(node, context=context)
    finally:
        node.destroy_node()


def test_destroy_actions_lets_the_node_go_with_its_action_servers_and_clients(
        rclpy_context, capfd):
    from rclpy.action import ActionClient, ActionServer
    from walker_msgs.action import Step

    def make_node():
        node = Node('action_probe', context=rclpy_context, start_parameter_services=False)
        ActionServer(node, Step, 'step', lambda goal: Step.Result())
        ActionClient(node, Step, 'step')
        return node

    node = make_node()
    spinning.destroy_actions(node)
    assert not [w for w in node.waitables if isinstance(w, (ActionServer, ActionClient))]
    node.destroy_node()
    # the node is gone, log publisher and all: another of its name registers its own quietly
    make_node().destroy_node()
    assert 'already registered' not in capfd.readouterr().err


_BUSY_NODE = """
import time
import rclpy
from rclpy.node import Node
from std_msgs.msg import Float64
from walker_runtime import spinning

stop = spinning.init_node_process()
node = Node('busy')
publisher = node.create_publisher(Float64, 'busy', 10)

def busy():  # most of the time is spent inside this callback, publishing at its end
    time.sleep(0.005)
    publisher.publish(Float64(data=1.0))

node.create_timer(0.001, busy)
print('ready', flush=True)
spinning.spin_nodes(node, stop=stop)
node.destroy_node()
rclpy.try_shutdown()
print('stopped', flush=True)
"""


def test_a_node_interrupted_in_a_callback_stops_in_order_without_an_error(ros_env):
    """SIGINT and SIGTERM end the spinning between callbacks; nothing fails on the way out."""
    import signal
    import subprocess
    import sys
    import time

    def interrupted(signum: int) -> tuple[int, str]:
        child = subprocess.Popen([sys.executable, '-c', _BUSY_NODE], env=ros_env,
                                 stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        assert child.stdout.readline().strip() == 'ready'
        time.sleep(0.5)
        child.send_signal(signum)
        return child.wait(timeout=20), child.stdout.read()

    for signum in (signal.SIGINT, signal.SIGTERM):
        code, output = interrupted(signum)
        assert code == 0 and 'stopped' in output, output
        assert 'Exception' not in output and 'FATAL' not in output, output


def test_a_node_process_writes_every_threads_stack_on_sigusr1_and_spins_on(ros_env):
    """``kill -USR1`` shows where each thread of a node stands, and the node keeps running."""
    import subprocess
    import sys
    import time

    from walker_runtime.spinning import STACK_DUMP_SIGNAL

    child = subprocess.Popen([sys.executable, '-c', _BUSY_NODE], env=ros_env,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert child.stdout.readline().strip() == 'ready'
        child.send_signal(STACK_DUMP_SIGNAL)
        time.sleep(0.5)
        assert child.poll() is None  # it spins on
    finally:
        child.terminate()
    code = child.wait(timeout=20)
    output, errors = child.communicate()
    assert code == 0 and 'stopped' in output, output + errors
    # the stack of the thread the signal caught (wherever it was: about to spin, spinning or in
    # the node's callback), innermost frame first, by file and line
    assert 'Current thread 0x' in errors and 'most recent call first' in errors, errors
    assert 'File "' in errors and ', line ' in errors, errors


def test_a_sampled_subscription_made_anew_keeps_its_topic_and_receives_again(rclpy_context):
    import time

    from std_msgs.msg import Int32

    from walker_runtime.qos import COMMAND_QOS

    context = rclpy_context
    publisher_node = Node('sample_source', namespace='/walker', context=context,
                          start_parameter_services=False, enable_rosout=False)
    sampler = spinning.TopicSampler('sampler_probe', '/walker', context)
    try:
        publisher = publisher_node.create_publisher(Int32, 'counts', COMMAND_QOS)

        def received(subscription, value):
            deadline = time.monotonic() + 10.0
            taken = []
            while time.monotonic() < deadline:
                publisher.publish(Int32(data=value))
                taken += [m.data for m in sampler.take(subscription)]
                if value in taken:
                    return taken
                time.sleep(0.05)
            raise AssertionError(f'{value} never sampled on {subscription.topic_name}')

        old = sampler.subscribe(Int32, 'counts', COMMAND_QOS)
        received(old, 1)
        new = sampler.renew(old)
        assert new is not old and new.topic_name == '/walker/counts'
        assert new.qos_profile.reliability == COMMAND_QOS.reliability
        assert set(received(new, 2)) == {2}
        with pytest.raises(KeyError):  # the old handle is gone
            sampler.take(old)
    finally:
        sampler.destroy()
        publisher_node.destroy_node()


def test_spinning_takes_the_start_up_objects_out_of_the_collector_and_collects_the_rest(
        monkeypatch, rclpy_context):
    """Objects made before spinning are frozen; garbage cycles made afterwards still go."""
    import weakref

    class Cycle:
        pass

    made_at_start_up = [Cycle()]
    node = Node('freeze_probe', context=rclpy_context, start_parameter_services=False,
                enable_rosout=False)
    monkeypatch.setattr(spinning, 'make_executor',
                        lambda ctx: _FailingExecutor(rclpy_context, 'now'))
    try:
        assert any(o is made_at_start_up for o in gc.get_objects())
        spinning.spin_nodes(node, context=rclpy_context)
        assert gc.get_freeze_count() > 0
        assert not any(o is made_at_start_up for o in gc.get_objects()), 'not frozen'
        later = Cycle()
        later.itself = later  # garbage only the cyclic collector can free
        gone = weakref.ref(later)
        del later
        gc.collect()
        assert gone() is None, 'a cycle made after the freeze was not collected'
    finally:
        node.destroy_node()
