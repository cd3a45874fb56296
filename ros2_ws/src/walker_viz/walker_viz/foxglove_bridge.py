"""The Foxglove bridge: the graph's topics, live, over the Foxglove WebSocket protocol.

``ros2 run walker_viz foxglove_bridge --ros-args -r __ns:=/walker -p port:=8765`` (what
``run_all.py --foxglove`` starts). The Python counterpart of foxglove_bridge, on the official
Foxglove SDK's server, bound to 127.0.0.1 only: every topic of the selection (``topics``,
names or glob patterns as the recorder takes them; by default the robot's namespace, ``/tf``,
``/tf_static``, ``/diagnostics`` and ``/clock``) is advertised once it has a publisher, as a
channel with the ``ros2msg`` schema of its type (the ``.msg`` text with its dependencies, as
rosbag2 stores it) and ``cdr`` message encoding, and its messages are passed on as the CDR
bytes DDS delivered, never decoded here. Each topic is subscribed with a QoS that matches all
its publishers (transient local where they all latch). A latched topic's newest messages (as
many as its publishers keep, :mod:`walker_viz.core.latched`) are sent again whenever a client
subscribes to its channel, so a client that connects at any time gets the robot description,
the static transforms, the markers, the phase, the control mode and the step reports, as a
transient-local subscriber would (the WebSocket server itself keeps no message; the others
subscribed to that channel get them once more). The subscriptions live on a helper
node no executor spins; what they received is taken every ``take_period`` seconds, all topics
at once, oldest first, so the bridge costs no callback per message of the 500 Hz topics.

Message log times are the node's clock (the simulated clock under ``use_sim_time``, which is
also broadcast to clients as the server's time, so Foxglove's time follows the simulation).
"""

from __future__ import annotations

import sys
from collections import deque
from typing import Any

import foxglove
from foxglove.websocket import Capability, ChannelView, Client, ServerListener
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rcl_interfaces.msg import IntegerRange, ParameterDescriptor

from walker_bag.core.errors import MessageDefinitionError, TopicNameError
from walker_bag.core.message_definitions import message_definition
from walker_bag.core.qos import subscription_policies
from walker_bag.core.topic_selection import TopicSelection
from walker_bag.recorder_node import message_class, offered_qos
from walker_runtime.node_main import run_node
from walker_runtime.spinning import TopicSampler
from walker_viz.core.latched import LatchedMessages

__all__ = ['FoxgloveBridge', 'DEFAULT_TOPICS', 'main']

#: What the bridge serves unless told otherwise.
DEFAULT_TOPICS = ('*', '/tf', '/tf_static', '/diagnostics', '/clock')
#: Host the server binds to: this machine only.
HOST = '127.0.0.1'
_DISCOVERY_PERIOD = 0.5  # [s] how often new topics are looked for (steady clock)
_TAKE_PERIOD = 0.02  # [s] how often received messages are taken and sent (steady clock)
_QUEUE_DEPTH = 100  # messages each subscription holds between two takes


class BridgeError(ValueError):
    """The bridge cannot start: a bad parameter, or a port it cannot bind."""


class _Subscriptions(ServerListener):
    """Note the channels clients subscribe to (called on the server's thread)."""

    def __init__(self) -> None:
        self.subscribed: deque[str] = deque()

    def on_subscribe(self, client: Client, channel: ChannelView) -> None:
        self.subscribed.append(channel.topic)


class FoxgloveBridge(Node):
    """Serve the selected topics of the graph to Foxglove clients.

    Raises
    ------
    BridgeError
        If ``port`` or ``topics`` is invalid, or the server cannot listen on the port.
    """

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('foxglove_bridge', **kwargs)
        port = self.declare_parameter(
            'port', 8765, ParameterDescriptor(
                description='TCP port of the WebSocket server on 127.0.0.1 (0: any free port)',
                read_only=True, integer_range=[IntegerRange(from_value=0, to_value=65535,
                                                            step=1)])).value
        topics = self.declare_parameter(
            'topics', list(DEFAULT_TOPICS), ParameterDescriptor(
                description='topics served: names or glob patterns, relative ones in the '
                            "node's namespace", read_only=True)).value
        try:
            self._selection = TopicSelection(list(topics), self.get_namespace())
        except TopicNameError as error:
            raise BridgeError(f'topics: {error}') from None
        if not 0 <= port <= 65535:
            raise BridgeError(f'port must be 0..65535, got {port}')
        self._sim_time = bool(self.get_parameter('use_sim_time').value)
        self._latched = LatchedMessages()
        self._joins = _Subscriptions()
        try:
            self.server = foxglove.start_server(
                name=f'walker {self.get_namespace()}', host=HOST, port=port,
                capabilities=[Capability.Time] if self._sim_time else [],
                server_listener=self._joins)
        except (RuntimeError, OSError) as error:
            raise BridgeError(f'cannot serve on {HOST}:{port}: {error}') from None
        self._channels: dict[str, tuple[Any, foxglove.Channel]] = {}
        self._skipped: set[str] = set()
        self._sampler = TopicSampler(f'{self.get_name()}_sampler', self.get_namespace(),
                                     self.context)
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.create_timer(_DISCOVERY_PERIOD, self._discover, clock=steady)
        self.create_timer(_TAKE_PERIOD, self.forward_received, clock=steady)
        self.get_logger().info(f'serving {self._selection!r} to Foxglove at '
                               f'ws://{HOST}:{self.port}')
        self._discover()

    @property
    def port(self) -> int:
        """The port the server listens on."""
        return self.server.port

    def _discover(self) -> None:
        """Advertise and subscribe to selected topics that have appeared since the last look."""
        for topic, types in self.get_topic_names_and_types():
            if topic in self._channels or topic in self._skipped \
                    or not self._selection.matches(topic):
                continue
            publishers = self.get_publishers_info_by_topic(topic)
            if len(types) != 1:
                self._skip(topic, f'it has several types ({", ".join(types)})')
            elif publishers:
                self._serve(topic, types[0], publishers)

    def _skip(self, topic: str, reason: str) -> None:
        self._skipped.add(topic)
        self.get_logger().warning(f'not serving {topic}: {reason}')

    def _serve(self, topic: str, type_name: str, publishers) -> None:
        try:
            definition = message_definition(type_name)
            type_class = message_class(type_name)
        except (MessageDefinitionError, ImportError, AttributeError, ValueError) as error:
            self._skip(topic, f'its type {type_name} is not installed here ({error})')
            return
        reliability, durability = subscription_policies(offered_qos(p) for p in publishers)
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=_QUEUE_DEPTH,
                         reliability=ReliabilityPolicy[reliability.upper()],
                         durability=DurabilityPolicy[durability.upper()])
        schema = foxglove.Schema(name=type_name, encoding=definition.encoding,
                                 data=definition.text.encode())
        channel = foxglove.Channel(topic, schema=schema, message_encoding='cdr')
        subscription = self._sampler.subscribe(type_class, topic, qos, raw=True)
        if durability == 'transient_local':  # DDS discovery seldom tells a history's depth
            self._latched.latch(topic, max(offered_qos(p).depth for p in publishers) or 1)
        self._channels[topic] = (subscription, channel)
        self.get_logger().info(f'serving {topic} [{type_name}] ({reliability}, {durability})')

    def forward_received(self) -> int:
        """Send every message received since the last call, oldest first; return how many.

        Then a latched topic's newest messages again on each channel a client subscribed to
        since the last call.
        """
        now = self.get_clock().now().nanoseconds
        batch = []
        for topic, (subscription, channel) in self._channels.items():
            for data, info in self._sampler.take_with_info(subscription):
                received = info.get('received_timestamp') or 0
                batch.append((received, topic, channel, data))
        batch.sort(key=lambda item: item[0])
        for _, topic, channel, data in batch:
            channel.log(bytes(data), log_time=now)
            self._latched.passed_on(topic, data, now)
        replayed = set()
        while self._joins.subscribed:
            topic = self._joins.subscribed.popleft()
            if topic in self._channels and topic not in replayed:
                replayed.add(topic)
                for data, log_time in self._latched.newest(topic):
                    self._channels[topic][1].log(data, log_time=log_time)
        if self._sim_time and batch:
            self.server.broadcast_time(now)
        return len(batch)

    def destroy_node(self) -> None:
        """Stop the server, close the channels, destroy the node and its helper."""
        self.server.stop()
        for _, channel in self._channels.values():
            channel.close()
        self._sampler.destroy()
        super().destroy_node()


def main(args=None) -> int:
    """Run the bridge until shut down; exit codes of :mod:`walker_runtime.node_main`.

    A port it cannot listen on is a refusal to start (2), as invalid parameters are.
    """
    return run_node(FoxgloveBridge, 'foxglove_bridge', args)


if __name__ == '__main__':
    sys.exit(main())
