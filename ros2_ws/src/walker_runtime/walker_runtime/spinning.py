"""ROS layer: spin the walker's nodes with the executor that keeps a 500 Hz graph affordable.

Every message a Python node handles costs executor overhead; on a 2-core machine the
default ``SingleThreadedExecutor`` spends about 600 us of CPU per message received and
answered, the C++-dispatching ``rclpy.experimental.EventsExecutor`` about 300 us (measured with
a JointState echo at 500 Hz, ``benchmarks/``). The events executor's own ``spin()`` was seen to
busy-loop and ignore SIGTERM, so it is driven here by a ``spin_once`` loop that checks for
shutdown, which works. ``WALKER_EXECUTOR=single`` selects the default executor instead (for
comparison, or should the events executor misbehave).

The events executor registers a node's entities when the node is added: a node that creates
subscriptions later (the recorder, which subscribes to topics as they appear) must keep the
default executor.
"""

from __future__ import annotations

import faulthandler
import gc
import os
import signal
import threading
import time
from collections.abc import Callable, Iterable

import rclpy
from rclpy.action import ActionClient, ActionServer
from rclpy.executors import Executor, ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.signals import SignalHandlerOptions
from rclpy.type_description_service import START_TYPE_DESCRIPTION_SERVICE_PARAM

__all__ = ['make_executor', 'spin_nodes', 'freeze_start_up_objects', 'destroy_actions',
           'StopSignals', 'init_node_process', 'TopicSampler', 'helper_node', 'hidden_name',
           'EXECUTOR_VARIABLE', 'STACK_DUMP_SIGNAL']

#: Environment variable choosing the executor: ``events`` (default) or ``single``.
EXECUTOR_VARIABLE = 'WALKER_EXECUTOR'
_SPIN_TIMEOUT = 0.1  # [s] longest wait before the loop checks for shutdown again
_SHUTDOWN_GRACE = 1.0  # [s] how long an error in spinning waits for a shutdown under way
#: The signal on which a node process writes every thread's Python stack to its stderr.
STACK_DUMP_SIGNAL = signal.SIGUSR1


def make_executor(context=None) -> Executor:
    """Create the executor selected by ``WALKER_EXECUTOR`` (default: the events executor)."""
    kind = os.environ.get(EXECUTOR_VARIABLE, 'events')
    if kind == 'single':
        return SingleThreadedExecutor(context=context)
    if kind != 'events':
        raise ValueError(f'{EXECUTOR_VARIABLE}={kind!r}: expected "events" or "single"')
    from rclpy.experimental import EventsExecutor

    return EventsExecutor(context=context)


class StopSignals:
    """SIGINT and SIGTERM as a request to stop, which the spin loop checks between callbacks.

    rclpy's own signal handlers shut the context down from another thread at any moment: in
    the middle of a callback, whose next publish then fails (the events executor logs that as
    FATAL), or while the executor takes a message. Here a signal only sets a flag; the spin
    loop ends at its next check (within a spin timeout) and the process shuts down in order on
    its main thread: nodes first, then the context. Create it on the main thread, with rclpy's
    handlers off (:func:`init_node_process` does both). Every signal sets the flag: a process
    that does not stop is for SIGABRT or SIGKILL.

    Calling the object tells whether a stop was asked for (``spin_nodes(..., stop=stop)``).
    """

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self) -> None:
        self._requested = threading.Event()
        for signum in self.SIGNALS:
            signal.signal(signum, self._handle)

    def _handle(self, signum: int, frame: object) -> None:
        self._requested.set()

    @property
    def requested(self) -> bool:
        """True once SIGINT or SIGTERM has arrived."""
        return self._requested.is_set()

    def __call__(self) -> bool:
        """Return :attr:`requested`."""
        return self.requested


def init_node_process(args: list[str] | None = None, context=None) -> StopSignals:
    """Initialise rclpy in a node process that stops in order on SIGINT and SIGTERM.

    The signal handlers are installed first, so a signal during start-up also stops the
    process as soon as it spins. Returns the :class:`StopSignals` for :func:`spin_nodes`.
    ``context``: the context to initialise (the default context when omitted).

    ``SIGUSR1`` (:data:`STACK_DUMP_SIGNAL`) makes the process write the Python stack of every
    thread to its stderr and go on (``faulthandler``, which needs no Python lock to do it): a
    node that has stopped answering can be asked where it stands (``kill -USR1 <pid>``).
    """
    stop = StopSignals()
    faulthandler.register(STACK_DUMP_SIGNAL, all_threads=True, chain=False)
    rclpy.init(args=args, context=context, signal_handler_options=SignalHandlerOptions.NO)
    return stop


def freeze_start_up_objects() -> None:
    """Take what the process made while starting out of the cyclic garbage collector's reach.

    A full collection walks every tracked object: the modules, rclpy, numpy, scipy and the
    nodes, 50 000-130 000 objects, which live as long as the process. In a soak (see
    docs/performance_log.md) the supervisor and the planner each ran one every 40 s of wall
    time or so, 16-61 ms and 38-330 ms long, freeing nothing, while the walk waited on their
    decisions and setpoints.
    Frozen (``gc.freeze()``, after a last collection), those objects are no longer walked;
    what the spinning makes afterwards is collected as before. In the same soak frozen, the
    supervisor's full collections took 1-6 ms and the planner's 9-40 ms (it keeps finished
    trajectories for a while), and no extraction took longer than 0.86 s (without: four of
    75 at 0.88-0.98 s, and two steps over 1.5 times their bound).
    """
    gc.collect()
    gc.freeze()


def destroy_actions(node: Node) -> None:
    """Destroy the node's action servers and clients; call it before ``node.destroy_node()``.

    ``Node.destroy_node`` destroys publishers, subscriptions, services, clients, timers and
    guard conditions, not action servers and clients: each keeps the node's handle alive until
    the garbage collector gets to it, at interpreter exit after the context has shut down (a
    native crash at exit is the risk), and a node of the same name created meanwhile in the
    process finds its log publisher still registered.
    """
    for waitable in list(node.waitables):
        if isinstance(waitable, (ActionServer, ActionClient)):
            waitable.destroy()


def spin_nodes(nodes: Node | Iterable[Node], stop: Callable[[], bool] | None = None,
               context=None, executor: Executor | None = None) -> None:
    """Spin nodes until ``stop()`` is true or the context shuts down.

    In a node process ``stop`` is its :class:`StopSignals` (SIGINT, SIGTERM), checked between
    callbacks; the caller then destroys its nodes and shuts rclpy down.

    A shutdown while the executor waits ends the spinning as a shutdown between two waits
    does (no ``ExternalShutdownException`` escapes, e.g. from a helper thread, nor the
    ``RuntimeError`` the events executor may raise when the context goes away under it).

    Parameters
    ----------
    nodes : Node or iterable of Node
        One node, or several sharing the executor (composition in one process).
    stop : callable, optional
        Checked every loop; return True to stop spinning.
    context : rclpy.context.Context, optional
        The nodes' context (the default context when omitted).
    executor : rclpy.executors.Executor, optional
        The executor to spin with (default: :func:`make_executor`'s choice).
    """
    nodes = [nodes] if isinstance(nodes, Node) else list(nodes)
    executor = make_executor(context) if executor is None else executor
    for node in nodes:
        executor.add_node(node)
    freeze_start_up_objects()
    try:
        while rclpy.ok(context=context) and not (stop is not None and stop()):
            executor.spin_once(timeout_sec=_SPIN_TIMEOUT)
    except ExternalShutdownException:
        pass
    except RuntimeError:
        # A callback or the events executor may fail inside spin_once while the context shuts
        # down (a signal arrived meanwhile: publishers and subscriptions are gone under it):
        # that is the end asked for, not an error. The signal's shutdown may still be under way
        # on another thread: it is given a moment to complete before the error counts.
        deadline = time.monotonic() + _SHUTDOWN_GRACE
        while rclpy.ok(context=context) and time.monotonic() < deadline:
            time.sleep(0.01)
        if rclpy.ok(context=context):
            raise
    finally:
        for node in nodes:
            executor.remove_node(node)
        executor.shutdown(timeout_sec=0.0)


def hidden_name(name: str) -> str:
    """``name`` as a hidden node name: with a leading underscore (``ros2 node list`` skips it)."""
    return name if name.startswith('_') else '_' + name


def helper_node(name: str, namespace: str | None = None, context=None,
                use_global_arguments: bool = True) -> Node:
    """Create a node that serves another one, or a tool, and is no part of the graph's design.

    Hidden, as the ROS 2 command-line tools make their own: its name starts with an underscore,
    so ``ros2 node list`` (without ``--all``) shows only the nodes docs/architecture.md
    describes; it starts no parameter services, no type description service and no
    ``/rosout`` logger, so ``ros2 service list`` shows none of its services either.
    """
    overrides = [Parameter(START_TYPE_DESCRIPTION_SERVICE_PARAM, value=False)]
    return Node(hidden_name(name), namespace=namespace, context=context,
                use_global_arguments=use_global_arguments, start_parameter_services=False,
                enable_rosout=False, parameter_overrides=overrides)


class TopicSampler:
    """Subscriptions read on demand, for high-rate topics a node needs only now and then.

    A subscription that an executor spins costs a Python callback per message, and a turn of
    the executor around it; the supervisor needs the 500 Hz joint states only at its own
    decision rate, and the recorder takes every message in batches. The sampler's subscriptions
    live on a helper node that no executor spins: DDS keeps the newest messages (up to the QoS
    depth) and :meth:`take` hands them over when asked.

    Parameters
    ----------
    name : str
        Name of the helper node: hidden (:func:`helper_node`), so ``_`` is prefixed.
    namespace : str
        Its namespace: the namespace of the node it serves. Command-line remaps are not applied
        to it, so topic names are taken literally (relative to ``namespace``).
    context : rclpy.context.Context, optional
    """

    def __init__(self, name: str, namespace: str, context=None) -> None:
        self.node = helper_node(name, namespace, context, use_global_arguments=False)
        # per subscription: (message type, QoS, raw)
        self._made: dict[object, tuple[type, object, bool]] = {}

    def subscribe(self, message_type: type, topic: str, qos, raw: bool = False) -> object:
        """Create a sampled subscription; return the handle :meth:`take` expects.

        With ``raw``, messages are taken as their serialized (CDR) bytes.
        """
        subscription = self.node.create_subscription(message_type, topic, lambda _: None, qos,
                                                     raw=raw)
        self._made[subscription] = (message_type, qos, raw)
        return subscription

    def take(self, subscription) -> list:
        """Every message received on ``subscription`` since the last call, oldest first."""
        return [message for message, _ in self.take_with_info(subscription)]

    def take_with_info(self, subscription) -> list[tuple[object, dict]]:
        """Like :meth:`take`, each message with the middleware's information on it.

        The information is rclpy's ``MessageInfo`` dict: ``source_timestamp`` and
        ``received_timestamp`` [ns, system clock], ``publication_sequence_number``, ...
        """
        message_type, _, raw = self._made[subscription]
        taken = []
        while True:
            message_and_info = subscription.handle.take_message(message_type, raw)
            if message_and_info is None:
                return taken
            taken.append(message_and_info)

    def renew(self, subscription) -> object:
        """Destroy ``subscription`` and make it anew; return the new handle.

        Messages not yet taken are lost. Use it for a stream silent for long while its
        publisher may live on (see :class:`walker_runtime.core.resubscription.Resubscription`).
        """
        message_type, qos, raw = self._made[subscription]
        topic = subscription.topic_name
        self.unsubscribe(subscription)
        return self.subscribe(message_type, topic, qos, raw)

    def unsubscribe(self, subscription) -> None:
        """Destroy ``subscription``; messages not yet taken are lost."""
        del self._made[subscription]
        self.node.destroy_subscription(subscription)

    def destroy(self) -> None:
        """Destroy the helper node and its subscriptions."""
        self.node.destroy_node()
