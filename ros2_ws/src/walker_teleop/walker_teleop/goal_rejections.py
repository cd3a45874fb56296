"""Why the supervisor rejected a goal: its ``goal_rejections`` topic, as a client reads it.

A ROS 2 action server can only accept or reject a goal: a rejected goal has no result to carry
a reason. The supervisor rejects an unknown, malformed or unreachable target, and a goal it
cannot take now, at goal time, and publishes why on ``goal_rejections``
(``walker_msgs/GoalRejection``, latched: ``ros2 topic echo --once`` shows the newest) as well as
in its log. A client subscribes before it sends a goal and, when the goal is rejected, takes the
rejection of its goal (same action and target) that arrived after it was sent.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from walker_msgs.msg import GoalRejection

__all__ = ['GoalRejections', 'GoalRejectedError', 'REASON_WAIT']

#: [s] how long a client waits for the reason of a rejection (it travels beside the answer)
REASON_WAIT = 2.0
# Volatile: a client hears only the rejections made after it subscribed, so an older one of
# the same goal is never taken for its own.
_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                  durability=DurabilityPolicy.VOLATILE, history=HistoryPolicy.KEEP_LAST)


class GoalRejectedError(RuntimeError):
    """A goal the supervisor rejected; the message says why (``reason``: its words alone)."""

    def __init__(self, action: str, target: str, reason: str) -> None:
        super().__init__(f'the {action} goal to {target!r} was rejected: {reason}')
        self.action, self.target, self.reason = action, target, reason


class GoalRejections:
    """The rejections a client's node hears on ``goal_rejections``.

    Parameters
    ----------
    node : Node
        The client's node (in the robot's namespace).
    """

    def __init__(self, node: Node) -> None:
        self._heard: list[tuple[float, GoalRejection]] = []
        self._subscription = node.create_subscription(
            GoalRejection, 'goal_rejections',
            lambda msg: self._heard.append((time.monotonic(), msg)), _QOS)

    @property
    def matched(self) -> bool:
        """True once the supervisor's publisher is matched (its rejections will be heard)."""
        return self._subscription.get_publisher_count() > 0

    def heard(self, action: str, target: str, since: float) -> str | None:
        """Return the reason of a rejection of this goal heard since ``since`` (monotonic [s]).

        None when none was heard.
        """
        for received, message in self._heard:
            if received >= since and message.action == action \
                    and message.target_node == target:
                return message.reason
        return None

    def reason(self, action: str, target: str, since: float,
               spin: Callable[[float], None], wait: float = REASON_WAIT) -> str:
        """Return why the goal sent at ``since`` (monotonic [s]) was rejected.

        Spins (``spin(seconds)``) up to ``wait`` [s] for the rejection; says where to look when
        it does not come.
        """
        deadline = time.monotonic() + wait
        while True:
            reason = self.heard(action, target, since)
            if reason is not None:
                return reason
            if time.monotonic() > deadline:
                return ("no reason received: see the supervisor's log, or its "
                        'goal_rejections topic')
            spin(0.1)
