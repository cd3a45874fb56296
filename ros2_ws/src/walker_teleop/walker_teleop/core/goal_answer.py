"""Whether a goal was accepted, judged from everything its client hears (no ROS).

The server's answer to a goal request can be lost while the goal runs. Fast DDS (rmw_fastrtps)
sends a service response only once the server's response writer has matched the client's
response reader, and waits for that match for the writer's ``max_blocking_time`` (0.1 s by
default): over a slow link a new client discovers the server well before the server discovers
it, the answer is dropped ("client will not receive response") and the goal is carried out
regardless. A client that sends its goal with its own id has three other signs of the answer:

* the server's status list (``<action>/_action/status``, latched) names the goal: accepted;
* feedback for the goal arrives: accepted;
* the supervisor publishes the rejection of the goal on ``goal_rejections``: rejected.

:func:`goal_answer` takes the first sign there is; the response itself wins over the others.
"""

from __future__ import annotations

__all__ = ['goal_answer', 'ACCEPTED', 'REJECTED']

ACCEPTED = 'accepted'
REJECTED = 'rejected'


def goal_answer(response: bool | None, seen_running: bool, rejection_heard: bool) -> str:
    """Return the answer to a goal request: :data:`ACCEPTED`, :data:`REJECTED` or '' (none yet).

    Parameters
    ----------
    response : bool or None
        The server's response (``accepted``), None while it has not arrived.
    seen_running : bool
        The goal's id was named in the server's status list or in a feedback message.
    rejection_heard : bool
        A rejection of this goal (same action and target) was published after it was sent.
    """
    if response is not None:
        return ACCEPTED if response else REJECTED
    if seen_running:
        return ACCEPTED
    return REJECTED if rejection_heard else ''
