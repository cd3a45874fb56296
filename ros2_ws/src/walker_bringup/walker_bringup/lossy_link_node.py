r"""ROS layer: the ``lossy_link`` node relays a topic to a renamed copy, dropping and delaying.

An operator tool, documented in docs/ground_station.md ("Operator tools: the lossy link and
the transport probe"): fault injection for a link of the graph::

    ros2 run walker_bringup lossy_link --ros-args -r __ns:=/walker \
        -p input:=controllers/vertex_joint/setpoint \
        -p output:=controllers/vertex_joint/setpoint_lossy \
        -p type:=walker_msgs/msg/JointCommand -p drop_probability:=0.2 -p delay:=0.01

and the node under test reads the copy (``-r controllers/vertex_joint/setpoint:=
controllers/vertex_joint/setpoint_lossy``). ``drop_probability``, ``delay`` and ``jitter``
can be changed while it runs (``ros2 param set /walker/lossy_link drop_probability 1.0`` cuts
the link; an invalid set is refused, naming the value, and changes nothing). Messages pass
serialized (the node never deserializes them), with the QoS chosen by ``reliable``; kept
messages are delivered on the steady clock, so a link delays in wall time whatever the graph's
clock does. The decisions are
:class:`walker_bringup.lossy_link.LossyLink`'s (seeded, reproducible in order).
"""

from __future__ import annotations

import importlib
import sys

from rcl_interfaces.msg import (
    FloatingPointRange, IntegerRange, ParameterDescriptor, SetParametersResult)
from rclpy.clock import Clock, ClockType
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy

from walker_bringup.lossy_link import LossyLink
from walker_runtime.node_main import run_node

__all__ = ['LossyLinkNode', 'message_type', 'main']

_DELIVERY_PERIOD = 0.001  # [s] steady clock: how often delayed messages are checked
_REPORT_PERIOD = 5.0  # [s] steady clock: how often the counts are logged


def message_type(name: str) -> type:
    """Return the message class named ``pkg/msg/Type`` (or ``pkg/Type``).

    Raises
    ------
    ValueError
        The name is malformed or names no message type that is installed.
    """
    parts = name.split('/')
    if len(parts) == 2:
        parts = [parts[0], 'msg', parts[1]]
    if len(parts) != 3 or parts[1] != 'msg' or not all(parts):
        raise ValueError(f'type {name!r}: expected "package/msg/Type"')
    try:
        return getattr(importlib.import_module(f'{parts[0]}.msg'), parts[2])
    except (ImportError, AttributeError):
        raise ValueError(f'type {name!r}: no such message type is installed') from None


def _number(description: str, low: float, high: float) -> ParameterDescriptor:
    return ParameterDescriptor(description=description + ' (settable at run time)',
                               floating_point_range=[FloatingPointRange(
                                   from_value=low, to_value=high, step=0.0)])


class LossyLinkNode(Node):
    """Relay ``input`` to ``output``, dropping and delaying as the parameters say.

    Raises
    ------
    ValueError
        A parameter is invalid (unknown type, same input and output, a value out of range);
        the node refuses to start.
    """

    def __init__(self, **kwargs) -> None:
        super().__init__('lossy_link', **kwargs)
        input_topic = self.declare_parameter(
            'input', '', ParameterDescriptor(description='topic relayed (relative names '
                                             'resolve in the node namespace)', read_only=True)
        ).value
        output_topic = self.declare_parameter(
            'output', '', ParameterDescriptor(description='topic the relayed messages are '
                                              'published on', read_only=True)).value
        type_name = self.declare_parameter('type', '', ParameterDescriptor(
            description='message type of both topics, e.g. walker_msgs/msg/JointCommand',
            read_only=True)).value
        drop = self.declare_parameter('drop_probability', 0.0, _number(
            'chance that a message is dropped', 0.0, 1.0)).value
        delay = self.declare_parameter('delay', 0.0, _number(
            '[s] wall-clock delay of every kept message', 0.0, 10.0)).value
        jitter = self.declare_parameter('jitter', 0.0, _number(
            '[s] extra delay, uniform in [0, jitter], per message', 0.0, 10.0)).value
        seed = self.declare_parameter('seed', 0, ParameterDescriptor(
            description='seed of the drop and jitter decisions', read_only=True,
            integer_range=[IntegerRange(from_value=0, to_value=2**31 - 1, step=1)])).value
        reliable = self.declare_parameter('reliable', True, ParameterDescriptor(
            description='reliable QoS on both sides (false: best effort, as sensor data)',
            read_only=True)).value
        if not input_topic or not output_topic:
            raise ValueError('both input and output topics must be given')
        resolved_in = self.resolve_topic_name(input_topic)
        resolved_out = self.resolve_topic_name(output_topic)
        if resolved_in == resolved_out:
            raise ValueError(f'input and output are the same topic ({resolved_in}): the link '
                             f'would feed itself')
        kind = message_type(type_name)
        self.link = LossyLink(drop, delay, jitter, seed)
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        qos = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE if reliable
                         else ReliabilityPolicy.BEST_EFFORT)
        self._publisher = self.create_publisher(kind, output_topic, qos)
        self.create_subscription(kind, input_topic, self._on_message, qos, raw=True)
        self.create_timer(_DELIVERY_PERIOD, self._deliver, clock=self._steady)
        self.create_timer(_REPORT_PERIOD, self.report, clock=self._steady)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.get_logger().info(f'relaying {resolved_in} -> {resolved_out} ({type_name}), seed '
                               f'{seed}: {self._settings()}')

    def _settings(self) -> str:
        link = self.link
        return (f'drop {link.drop_probability:.0%}, delay {link.delay * 1e3:.1f} ms + up to '
                f'{link.jitter * 1e3:.1f} ms')

    def _on_set_parameters(self, parameters: list[Parameter]) -> SetParametersResult:
        """Apply new drop, delay and jitter settings together, or none of them."""
        values = {'drop_probability': self.link.drop_probability, 'delay': self.link.delay,
                  'jitter': self.link.jitter}
        for parameter in parameters:
            if parameter.name in values:
                values[parameter.name] = float(parameter.value)
        try:
            self.link.configure(**values)
        except ValueError as error:
            return SetParametersResult(successful=False, reason=str(error))
        self.get_logger().info(f'link now: {self._settings()}')
        return SetParametersResult(successful=True)

    def _now(self) -> float:
        return self._steady.now().nanoseconds * 1e-9

    def _on_message(self, serialized: bytes) -> None:
        now = self._now()
        if self.link.offer(serialized, now):
            self._deliver(now)

    def _deliver(self, now: float | None = None) -> None:
        for serialized in self.link.due(self._now() if now is None else now):
            self._publisher.publish(serialized)

    def report(self) -> None:
        """Log what the link received, dropped and delivered."""
        counts = self.link.counts
        self.get_logger().info(
            f'{counts.received} received, {counts.dropped} dropped (at most '
            f'{counts.longest_run_dropped} in a row), {counts.delivered} delivered')


def main(args: list[str] | None = None) -> int:
    """Run the link until interrupted; exit codes of :mod:`walker_runtime.node_main`.

    The default executor: a tool for trying a link needs no speed.
    """
    return run_node(LossyLinkNode, 'lossy_link', args, executor=SingleThreadedExecutor,
                    before_destroy=LossyLinkNode.report)


if __name__ == '__main__':
    sys.exit(main())
