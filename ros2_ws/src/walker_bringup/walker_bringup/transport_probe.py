"""A talker and a listener that show whether the DDS transport delivers between two processes.

An operator tool, documented in docs/ground_station.md ("Operator tools: the lossy link and the
transport probe").

What the deaf-reader test and the transport benchmark start, two processes of one ROS domain,
each with the environment under test (the rmw default, shared memory; or the UDP-on-loopback
profile, :mod:`walker_bringup.transport`)::

    python -m walker_bringup.transport_probe talk [--rate HZ]
    python -m walker_bringup.transport_probe listen [--renew-after SECONDS] [--latencies FILE]

The talker publishes ``transport_probe/states`` (``sensor_msgs/JointState`` of five joints, as
the plant's ``joint_states``: best effort, newest only) and ``transport_probe/commands`` (the
same message, reliable, as the controllers' setpoints and efforts), both at ``--rate`` (500 Hz,
the control rate), stamped with the wall clock.

The listener prints, every 0.1 s, one line ``heard <steady s> <states> <commands>
<renewals>``: the steady time (``time.monotonic``, comparable across processes of one machine),
the messages received on each topic so far and how many times its subscriptions were made anew.
With ``--renew-after`` its subscriptions are the walker's
:class:`~walker_runtime.watched_subscription.WatchedSubscription` (made anew after that long a
silence while the talker is in the graph); without, plain subscriptions. With ``--latencies``
it writes, as it ends, the latency [ns] of every state received (wall clock at the callback
less the stamp) to that file (``numpy.save``).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from sensor_msgs.msg import JointState

from walker_runtime.node_main import run_node
from walker_runtime.qos import COMMAND_QOS, SENSOR_QOS
from walker_runtime.watched_subscription import WatchedSubscription

__all__ = ['STATES', 'COMMANDS', 'TransportTalker', 'TransportListener', 'parse_heard', 'main']

STATES = 'transport_probe/states'
COMMANDS = 'transport_probe/commands'
_TOPICS = ((STATES, SENSOR_QOS), (COMMANDS, COMMAND_QOS))
_JOINTS = ['j1', 'j2', 'j3', 'j4', 'j5']
#: [s] between two ``heard`` lines, and between two silence checks
_REPORT_PERIOD = 0.1


class TransportTalker(Node):
    """Publishes the two probe topics at ``rate`` [Hz] (see the module docstring)."""

    def __init__(self, rate: float) -> None:
        super().__init__('transport_talker')
        self._publishers = [self.create_publisher(JointState, topic, qos)
                            for topic, qos in _TOPICS]
        zeros = [0.0] * len(_JOINTS)
        self._message = JointState(name=_JOINTS, position=zeros, velocity=zeros, effort=zeros)
        self.create_timer(1.0 / rate, self._publish)

    def _publish(self) -> None:
        self._message.header.stamp = self.get_clock().now().to_msg()
        for publisher in self._publishers:
            publisher.publish(self._message)


class TransportListener(Node):
    """Counts the probe topics' messages and reports them (see the module docstring).

    Parameters
    ----------
    renew_after : float
        [s] steady time of silence before a subscription is made anew; 0: plain
        subscriptions, never made anew.
    """

    def __init__(self, renew_after: float) -> None:
        super().__init__('transport_listener')
        self.counts = {topic: 0 for topic, _ in _TOPICS}
        self.latencies: list[int] = []
        self._watched: list[WatchedSubscription] = []
        for topic, qos in _TOPICS:
            callback = self._counter(topic)
            if renew_after > 0.0:
                self._watched.append(WatchedSubscription(
                    self, JointState, topic, callback, qos, after=renew_after,
                    counts=self._talker_in_graph))
            else:
                self.create_subscription(JointState, topic, callback, qos)
        self.create_timer(_REPORT_PERIOD, self._report,
                          clock=Clock(clock_type=ClockType.STEADY_TIME))

    def _talker_in_graph(self) -> bool:
        return self.count_publishers(STATES) > 0

    def _counter(self, topic: str):
        def count(message: JointState) -> None:
            self.counts[topic] += 1
            if topic == STATES:
                stamp = message.header.stamp
                self.latencies.append(time.time_ns() - stamp.sec * 1_000_000_000
                                      - stamp.nanosec)
        return count

    def _report(self) -> None:
        for watched in self._watched:
            watched.check()
        renewals = sum(watched.renewals for watched in self._watched)
        print(f'heard {time.monotonic():.3f} {self.counts[STATES]} {self.counts[COMMANDS]} '
              f'{renewals}', flush=True)


def parse_heard(text: str) -> list[tuple[float, int, int, int]]:
    """Return the listener's ``heard`` lines in ``text``: (steady s, states, commands, renewals).

    Lines that are not whole ``heard`` lines (a process killed while printing one) are left out.
    """
    rows = []
    for line in text.splitlines():
        fields = line.split()
        if len(fields) == 5 and fields[0] == 'heard':
            try:
                rows.append((float(fields[1]), int(fields[2]), int(fields[3]), int(fields[4])))
            except ValueError:
                continue
    return rows


def main(argv: list[str] | None = None) -> int:
    """Run the talker or the listener until interrupted."""
    parser = argparse.ArgumentParser(prog='python -m walker_bringup.transport_probe',
                                     description=__doc__.split('\n', 1)[0])
    parser.add_argument('role', choices=('talk', 'listen'))
    parser.add_argument('--rate', type=float, default=500.0,
                        help="[Hz] the talker's publishing rate (default: 500)")
    parser.add_argument('--renew-after', type=float, default=0.0,
                        help="[s] the listener's subscriptions are made anew after this long "
                             'a silence (default 0: plain subscriptions)')
    parser.add_argument('--latencies', default='',
                        help="file the listener writes its states' latencies to [ns]")
    args = parser.parse_args(argv)
    if not (args.rate > 0.0 and args.renew_after >= 0.0):
        parser.error('--rate must be positive and --renew-after not negative')
    if args.role == 'talk':
        return run_node(lambda: TransportTalker(args.rate), 'transport_talker')

    def finish(node: TransportListener) -> None:
        if args.latencies:
            np.save(args.latencies, np.asarray(node.latencies, dtype=np.int64))
    return run_node(lambda: TransportListener(args.renew_after), 'transport_listener',
                    before_destroy=finish)


if __name__ == '__main__':
    raise SystemExit(main())
