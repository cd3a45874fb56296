"""Goals sent so that their answer is known even when the server's response to them is lost.

rclpy's ``send_goal_async`` waits for the server's response alone, and that response can be lost
while the goal runs (see :mod:`walker_teleop.core.goal_answer`: over a slow link the server has
not matched a new client's reader in time). A :class:`GoalSender` sends each goal with an id of
its own and also listens to the server's status list and to the goal's feedback; a
:class:`SentGoal` says its answer (:meth:`SentGoal.answer`) from whichever sign comes first and
gives a goal handle (:meth:`SentGoal.handle`) for the result and for cancelling, the server's or
one made from the goal's id when the response never came.
"""

from __future__ import annotations

import time
import uuid
from collections.abc import Callable

from action_msgs.msg import GoalStatusArray
from rclpy.action import ActionClient
from rclpy.action.client import ClientGoalHandle
from rclpy.node import Node
from rclpy.qos import qos_profile_action_status_default
from unique_identifier_msgs.msg import UUID

from walker_teleop.core.goal_answer import ACCEPTED, goal_answer
from walker_teleop.goal_rejections import GoalRejections

__all__ = ['GoalSender', 'SentGoal']


class GoalSender:
    """A client of one action of the supervisor (``walk_to`` or ``step``) and its goals.

    Parameters
    ----------
    node : Node
        The client's node, in the robot's namespace (its executor is spun by the caller).
    action_type : type
        The action's type (``walker_msgs.action.WalkTo`` or ``Step``).
    action : str
        The action's name relative to the node's namespace (``walk_to`` or ``step``).
    rejections : GoalRejections
        The node's listener to the supervisor's ``goal_rejections``.
    """

    def __init__(self, node: Node, action_type, action: str,
                 rejections: GoalRejections) -> None:
        self.client = ActionClient(node, action_type, action)
        self.action_type, self.action, self.rejections = action_type, action, rejections
        self.running: set[bytes] = set()  # ids of goals the server has been seen to run
        # made with the client, so it is matched long before a goal is sent (latched anyway)
        node.create_subscription(GoalStatusArray, f'{action}/_action/status', self._on_status,
                                 qos_profile_action_status_default)

    def _on_status(self, msg: GoalStatusArray) -> None:
        self.running.update(bytes(status.goal_info.goal_id.uuid) for status in msg.status_list)

    def send(self, goal, feedback: Callable[[object], None] | None = None) -> SentGoal:
        """Send ``goal``; ``feedback`` is called with each feedback message (its ``feedback``)."""
        return SentGoal(self, goal, feedback)


class SentGoal:
    """One goal sent by a :class:`GoalSender`, until its answer is known."""

    def __init__(self, sender: GoalSender, goal, feedback: Callable[[object], None] | None):
        self._sender = sender
        self.target = goal.target_node
        self.goal_id = UUID(uuid=list(uuid.uuid4().bytes))
        self._key = bytes(self.goal_id.uuid)
        self.sent_at = time.monotonic()

        def on_feedback(message) -> None:
            sender.running.add(self._key)
            if feedback is not None:
                feedback(message.feedback)

        self.response = sender.client.send_goal_async(goal, feedback_callback=on_feedback,
                                                      goal_uuid=self.goal_id)

    def answer(self) -> str:
        """Return the answer so far: ``accepted``, ``rejected`` or '' (none yet)."""
        handle = self.response.result() if self.response.done() else None
        return goal_answer(None if handle is None else bool(handle.accepted),
                           self._key in self._sender.running,
                           self.rejection_reason() is not None)

    def rejection_reason(self) -> str | None:
        """Return the supervisor's reason for rejecting this goal, if heard."""
        return self._sender.rejections.heard(self._sender.action, self.target, self.sent_at)

    def handle(self) -> ClientGoalHandle:
        """Return the accepted goal's handle: the server's, or one made from the goal's id.

        Raises
        ------
        RuntimeError
            The goal is not known to have been accepted.
        """
        if self.answer() != ACCEPTED:
            raise RuntimeError(f'the goal to {self.target!r} is not known to be accepted')
        if self.response.done() and self.response.result() is not None:
            return self.response.result()
        response_type = self._sender.action_type.Impl.SendGoalService.Response
        return ClientGoalHandle(self._sender.client, self.goal_id,
                                response_type(accepted=True))
