"""What to do about a planner request still unanswered (free of ROS).

A request the planner has not answered within a short wait is sent again over a newly created
client: a planner restarted after a crash was seen never to answer the old client (its requests
or its answers lost in discovery) while a new one was answered at once. Sent again for good, a
restarted planner that answered no client at all kept a step in its phase for five minutes,
with no hold to resume from; so a request unanswered for a longer, bounded time since it was
first sent fails its motion instead, and the step holds.
"""

from __future__ import annotations

import dataclasses

__all__ = ['UnansweredRequest', 'WAIT', 'ASK_AGAIN', 'GIVE_UP']

WAIT, ASK_AGAIN, GIVE_UP = 'wait', 'ask again', 'give up'


@dataclasses.dataclass(frozen=True)
class UnansweredRequest:
    """A request in flight: when it was first sent and when last [s, any monotonic clock].

    Parameters
    ----------
    first_sent, last_sent : float
        Wall times of its first sending and of its newest.
    ask_again_after : float
        How long [s] each sending is waited for before the request is sent again (> 0).
    give_up_after : float
        How long [s] after its first sending an unanswered request is given up (>= the wait).

    Raises
    ------
    ValueError
        If the times are not in order or the waits not positive and ordered.
    """

    first_sent: float
    last_sent: float
    ask_again_after: float
    give_up_after: float

    def __post_init__(self) -> None:
        if not 0.0 < self.ask_again_after <= self.give_up_after:
            raise ValueError(f'need 0 < ask_again_after ({self.ask_again_after!r} s) <= '
                             f'give_up_after ({self.give_up_after!r} s)')
        if not self.first_sent <= self.last_sent:
            raise ValueError(f'last_sent ({self.last_sent!r}) is before first_sent '
                             f'({self.first_sent!r})')

    def action(self, now: float) -> str:
        """Return WAIT, ASK_AGAIN or GIVE_UP for the request at wall time ``now`` [s]."""
        if now - self.last_sent < self.ask_again_after:
            return WAIT
        if now - self.first_sent >= self.give_up_after:
            return GIVE_UP
        return ASK_AGAIN

    def sent_again(self, now: float) -> UnansweredRequest:
        """Return the request as sent again at ``now`` [s], still counted from its first."""
        return dataclasses.replace(self, last_sent=float(now))
