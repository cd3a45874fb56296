"""The walk recorder: records the walker's topics into a rosbag2 bag (MCAP storage).

Run as ``recorder_node --ros-args -r __ns:=/walker --params-file walker.yaml``. The node
(``/walker/recorder``) looks for new topics every ``recorder.discovery_period`` and subscribes
to those selected by ``recorder.topics`` (default: every topic of its namespace and ``/clock``)
as soon as they have a publisher, with a QoS that matches every publisher's offer (transient
local when all publishers are latched, so messages published before the recorder started are
recorded too; best effort when any publisher is). The subscriptions are raw: the CDR bytes are
written exactly as received, with the publishers' offered QoS and type hash in the bag. No
executor spins them: every ``recorder.take_period`` the node takes what each has received, all
topics at once, sorts it by log time and hands it to the writer (an executor turn per message
cost more CPU than a real-time walk leaves the recorder; see TopicSampler).

Timestamps: the log time is the receive time, in sim time when ``use_sim_time`` is true (the
node's ROS clock when the message is taken, at most ``recorder.take_period`` of wall time
after it arrived; it reads 0 until the first ``/clock`` message arrives) and otherwise the
middleware's receive timestamp; the publish time is the publisher's source timestamp [ns].

Nothing received is lost on the way out: SIGINT (Ctrl-C) and SIGTERM stop the spinning, the
messages already received are taken and written, and the bag is closed (summary, footer,
``metadata.yaml``). Received messages are written out every ``recorder.flush_period``, so
even a SIGKILL loses at most that much; at its start the recorder completes, in place, every
bag of its directory that a killed recorder left cut (:mod:`walker_bag.core.bag_recovery`).
The bag goes on in a new file at ``recorder.max_bag_size`` or ``recorder.max_bag_duration``
and keeps ``recorder.max_bag_files`` files; with ``recorder.append`` the recorder continues an
existing bag in its next file (a recorder started again).

Messages the middleware reports lost on the way (the recorder stalled while publishers went on:
best-effort ones dropped, reliable ones overwritten in the publisher's history) are counted per
topic (:mod:`walker_bag.core.losses`) and said in the log, on ``/diagnostics`` (the status
``<node>: recording``, 1 Hz on the steady clock) and in the bag's ``custom_data``
(``messages_lost``). A recorder started again on its bag measures what it did not record while
it was down (:mod:`walker_bag.core.restart_gaps`): at each topic's first message, the span and
an estimated count, logged, written into the bag as a ``DiagnosticStatus`` on ``/diagnostics``
and into its ``custom_data`` (``recorder_gap``). All bag logic is in :mod:`walker_bag.core`.
"""

from __future__ import annotations

import datetime
import importlib
import sys
import time
from pathlib import Path
from typing import Any

import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.clock import Clock, ClockType
from rclpy.event_handler import EventHandler, QoSSubscriptionEventType
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import (
    DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy)
from rclpy.serialization import serialize_message
from rclpy.topic_endpoint_info import TopicEndpointInfo

from walker_runtime.node_parameters import declare_section
from walker_runtime.node_main import run_node
from walker_runtime.spinning import TopicSampler, freeze_start_up_objects

from walker_bag.core.bag_metadata import TopicMetadata
from walker_bag.core.bag_recovery import recover_abandoned_bags
from walker_bag.core.bag_writer import BagWriter
from walker_bag.core.errors import MessageDefinitionError
from walker_bag.core.losses import LossLedger
from walker_bag.core.message_definitions import message_definition, type_description_hash
from walker_bag.core.qos import QosProfile, subscription_policies
from walker_bag.core.recorder_parameters import RECORDER_PREFIX, RecorderParameters
from walker_bag.core.restart_gaps import RestartGaps, TopicGap
from walker_bag.core.topic_selection import TopicSelection

__all__ = ['RecorderNode', 'offered_qos', 'message_class', 'main']

#: Longest time spent taking already-received messages when asked to stop [s].
DRAIN_LIMIT = 1.0
#: How long the executor waits for work before the stop flag is checked again [s].
_SPIN_TIMEOUT = 0.1
#: Wait of one drain step [s]; two idle steps in a row mean nothing is left to take.
_DRAIN_STEP = 0.02
_INVALID_HASH = 'INVALID'
_DIAGNOSTICS_PERIOD = 1.0  # [s] steady clock
_OK, _WARN = bytes([0]), bytes([1])  # diagnostic_msgs/DiagnosticStatus levels
#: The QoS the recorder's own ``/diagnostics`` publisher offers (its gap records in the bag).
_DIAGNOSTICS_OFFER = QosProfile(reliability='reliable', durability='volatile',
                                history='keep_last', depth=10)


def offered_qos(endpoint: TopicEndpointInfo) -> QosProfile:
    """Return a publisher's offered QoS, as discovered, in the bag's form."""
    profile = endpoint.qos_profile
    return QosProfile(
        reliability=profile.reliability.name.lower(),
        durability=profile.durability.name.lower(),
        history=profile.history.name.lower(), depth=int(profile.depth),
        deadline_ns=profile.deadline.nanoseconds, lifespan_ns=profile.lifespan.nanoseconds,
        liveliness=profile.liveliness.name.lower(),
        liveliness_lease_duration_ns=profile.liveliness_lease_duration.nanoseconds,
        avoid_ros_namespace_conventions=bool(profile.avoid_ros_namespace_conventions))


def message_class(type_name: str) -> Any:
    """Import the Python class of ``pkg/msg/Type`` (rclpy needs it for the type support)."""
    package, _, name = type_name.split('/')
    return getattr(importlib.import_module(f'{package}.msg'), name)


class RecorderNode(Node):
    """Subscribe to the selected topics and hand every received message to the bag writer.

    Raises
    ------
    ParameterError
        If the ``recorder`` parameters are invalid.
    BagError
        If the bag cannot be created (existing directory, unwritable location).
    """

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('recorder', **kwargs)
        self._settings: RecorderParameters = declare_section(
            self, RecorderParameters, RECORDER_PREFIX)
        self._selection = TopicSelection(self._settings.topics, self.get_namespace())
        self._use_sim_time = bool(self.get_parameter('use_sim_time').value)
        for report in recover_abandoned_bags(self._settings.directory):
            self.get_logger().warning(
                f'{report.source}: left cut by a killed recorder; completed in place, '
                f'{report.message_count} messages (the cut files kept as *.incomplete)')
        self._losses = LossLedger()
        self._writer = BagWriter(
            self._settings.bag_path(datetime.datetime.now()),
            max_chunk_size=self._settings.max_chunk_size,
            custom_data={'clock': 'sim_time' if self._use_sim_time else 'system_time',
                         **self._losses.custom_data()},
            split=self._settings.split, append=self._settings.append)
        self._gaps = RestartGaps.after(self._writer.earlier_files, self._writer.custom_data)
        self._loss_handlers: list[EventHandler] = []
        self._subscriptions_by_topic: dict[str, Any] = {}
        # the subscriptions live on a node no executor spins: taken every take_period
        self._sampler = TopicSampler(f'{self.get_name()}_reader', self.get_namespace(),
                                     self.context)
        self._skipped: set[str] = set()
        self._received = 0
        try:
            steady = Clock(clock_type=ClockType.STEADY_TIME)
            self._discovery_timer = self.create_timer(
                self._settings.discovery_period, self._discover, clock=steady)
            self._flush_timer = self.create_timer(
                self._settings.flush_period, self._writer.flush, clock=steady)
            self._take_timer = self.create_timer(
                self._settings.take_period, self.take_received, clock=steady)
            self._diagnostics = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
            self.create_timer(_DIAGNOSTICS_PERIOD, self._publish_diagnostics, clock=steady)
            self.get_logger().info(
                f'recording {self._selection!r} to {self._writer.path} '
                f'({"sim" if self._use_sim_time else "system"} time)')
            self._discover()
        except BaseException:
            self._writer.close()
            self._sampler.destroy()
            raise

    @property
    def bag_path(self) -> Path:
        """The bag directory being written."""
        return self._writer.path

    @property
    def received_count(self) -> int:
        """Messages received (and handed to the writer) so far."""
        return self._received

    def _discover(self) -> None:
        """Subscribe to selected topics that have appeared since the last look."""
        for topic, types in self.get_topic_names_and_types():
            if (topic in self._subscriptions_by_topic or topic in self._skipped
                    or not self._selection.matches(topic)):
                continue
            if len(types) != 1:
                self._skip(topic, f'it has several types ({", ".join(types)})')
                continue
            publishers = self.get_publishers_info_by_topic(topic)
            if publishers:
                self._subscribe(topic, types[0], publishers)

    def _skip(self, topic: str, reason: str) -> None:
        self._skipped.add(topic)
        self.get_logger().error(f'not recording {topic}: {reason}')

    def _subscribe(self, topic: str, type_name: str,
                   publishers: list[TopicEndpointInfo]) -> None:
        try:
            type_class = message_class(type_name)
        except (ImportError, AttributeError, ValueError):
            self._skip(topic, f'its type {type_name} is not installed here')
            return
        offers = tuple(offered_qos(p) for p in publishers)
        type_hash = str(publishers[0].topic_type_hash)
        if type_hash == _INVALID_HASH:
            try:
                type_hash = type_description_hash(type_name)
            except MessageDefinitionError:
                type_hash = ''
        try:
            definition = message_definition(type_name)
        except MessageDefinitionError as error:
            self.get_logger().warning(f'{topic}: {error}; recording it without a definition')
            definition = None
        reliability, durability = subscription_policies(offers)
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=self._settings.queue_depth,
                         reliability=ReliabilityPolicy[reliability.upper()],
                         durability=DurabilityPolicy[durability.upper()])
        self._writer.add_topic(TopicMetadata(topic, type_name, offers, type_hash), definition)
        subscription = self._sampler.subscribe(type_class, topic, qos, raw=True)
        self._subscriptions_by_topic[topic] = subscription
        self._watch_losses(topic, subscription, reliability == 'reliable')
        self.get_logger().info(f'recording {topic} [{type_name}] ({reliability}, {durability}, '
                               f'{len(offers)} publisher(s))')

    def _watch_losses(self, topic: str, subscription, reliable: bool) -> None:
        """Count what the middleware reports lost on ``topic`` (this node's executor serves it)."""
        handler = EventHandler(
            callback_group=self.default_callback_group,
            callback=lambda info: self._on_lost(topic, info.total_count_change, reliable),
            event_type=QoSSubscriptionEventType.RCL_SUBSCRIPTION_MESSAGE_LOST,
            parent_impl=subscription.handle)
        self.add_waitable(handler)
        self._loss_handlers.append(handler)

    def _on_lost(self, topic: str, count: int, reliable: bool) -> None:
        line = self._losses.lost(topic, count, reliable, self.get_clock().now().nanoseconds)
        if line:
            self.get_logger().warning(line)
            for key, value in self._losses.custom_data().items():
                self._writer.set_custom_data(key, value)

    @property
    def losses(self) -> LossLedger:
        """The messages reported lost so far, per topic."""
        return self._losses

    def _publish_diagnostics(self) -> None:
        status = DiagnosticStatus(
            name=f'{self.get_fully_qualified_name()}: recording',
            hardware_id=self.get_namespace(), level=_WARN if self._losses.total else _OK,
            message=f'{self._writer.path}: {self._received} messages, '
                    f'{self._losses.summary()}')
        status.values = [KeyValue(key='bag', value=str(self._writer.path)),
                         KeyValue(key='file', value=self._writer.storage_file.name),
                         KeyValue(key='messages', value=str(self._received))]
        status.values += [KeyValue(key=key, value=value)
                          for key, value in self._losses.custom_data().items()]
        message = DiagnosticArray(status=[status])
        message.header.stamp = self.get_clock().now().to_msg()
        self._diagnostics.publish(message)

    def take_received(self) -> int:
        """Take every message received on every topic, write them in log-time order.

        Returns how many were taken.
        """
        now = self.get_clock().now().nanoseconds
        batch = []
        for topic, subscription in self._subscriptions_by_topic.items():
            for data, info in self._sampler.take_with_info(subscription):
                received = info.get('received_timestamp') or 0
                if self._use_sim_time or received <= 0:
                    received = now
                batch.append((received, info.get('source_timestamp') or received, topic, data,
                              info.get('publication_sequence_number') or 0))
        batch.sort(key=lambda message: message[:2])
        for received, published, topic, data, sequence in batch:
            self._writer.write(topic, data, received, published, sequence)
            gap = self._gaps.first_message(topic, received) if self._gaps else None
            if gap is not None:
                self._record_gap(gap, received)
        self._received += len(batch)
        return len(batch)

    def _record_gap(self, gap: TopicGap, now: int) -> None:
        """Say in the log and in the bag (a diagnostic status, custom_data) what was missed."""
        self.get_logger().warning(gap.text())
        for key, value in self._gaps.custom_data().items():
            self._writer.set_custom_data(key, value)
        type_name = 'diagnostic_msgs/msg/DiagnosticArray'
        self._writer.add_topic(TopicMetadata('/diagnostics', type_name, (_DIAGNOSTICS_OFFER,),
                                             type_description_hash(type_name)),
                               message_definition(type_name))
        status = DiagnosticStatus(
            name=f'{self.get_fully_qualified_name()}: not recorded', level=_WARN,
            hardware_id=self.get_namespace(), message=gap.text(),
            values=[KeyValue(key='topic', value=gap.topic),
                    KeyValue(key='start_ns', value=str(gap.start_ns)),
                    KeyValue(key='end_ns', value=str(gap.end_ns)),
                    KeyValue(key='estimated_count', value=str(gap.estimated))])
        message = DiagnosticArray(status=[status])
        message.header.stamp.sec, message.header.stamp.nanosec = divmod(now, 1_000_000_000)
        self._writer.write('/diagnostics', serialize_message(message), now, now)

    def drain(self, executor: SingleThreadedExecutor, limit: float = DRAIN_LIMIT) -> None:
        """Take and write the messages already received, for at most ``limit`` seconds."""
        self._discovery_timer.cancel()
        self._take_timer.cancel()
        deadline = time.monotonic() + limit
        idle_steps = 0
        while idle_steps < 2 and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=_DRAIN_STEP)  # the sim clock, if any, moves on
            idle_steps = 0 if self.take_received() else idle_steps + 1

    def destroy_node(self) -> None:
        """Destroy the node and the one its subscriptions live on."""
        for handler in self._loss_handlers:
            self.remove_waitable(handler)
            handler.destroy()
        self._loss_handlers.clear()
        self._sampler.destroy()
        super().destroy_node()

    def close_bag(self) -> None:
        """Close the bag (idempotent) and log what it holds."""
        if self._writer.closed:
            return
        metadata = self._writer.close()
        for name in self._selection.names:
            if name not in self._subscriptions_by_topic and name not in self._skipped:
                self.get_logger().info(f'{name} was asked for but never had a publisher')
        self.get_logger().info(
            f'closed {self._writer.path}: {metadata.message_count} messages on '
            f'{len(metadata.topics_with_message_count)} topics in '
            f'{len(metadata.relative_file_paths)} file(s); {self._losses.summary()}')


def _spin_then_drain(node: RecorderNode, stop) -> None:
    """Spin until a stop is asked, then take and write what was received meanwhile.

    A signal sets a flag the spin loop checks (no exception in the middle of a write).
    """
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    freeze_start_up_objects()
    while not stop.requested and rclpy.ok():
        executor.spin_once(timeout_sec=_SPIN_TIMEOUT)
    node.drain(executor)


def main(args: list[str] | None = None) -> int:
    """Run the recorder until SIGINT or SIGTERM, then close the bag; return the exit code.

    Exit codes of :mod:`walker_runtime.node_main`: a bag that cannot be created is a refusal
    to start (2), as invalid parameters are.
    """
    return run_node(RecorderNode, 'recorder', args, spin=_spin_then_drain,
                    before_destroy=RecorderNode.close_bag)


if __name__ == '__main__':
    sys.exit(main())
