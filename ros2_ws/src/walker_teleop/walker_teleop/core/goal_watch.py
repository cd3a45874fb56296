"""Whether the server of a walk or step goal still runs it, judged by what a client can observe.

A client waiting for the result of a ``walk_to`` or ``step`` goal cannot tell, from the goal
alone, a long walk from a supervisor that died or was started again: the result request went
to the process that accepted the goal, and a dead process never answers it. Two observations
tell them apart within seconds:

* *Liveness.* The supervisor publishes its status on ``/diagnostics`` every second on the
  steady clock (also while the simulated clock stands still). Silent for ``silence_limit``,
  it is taken for dead or out of reach: over a link that was cut, the client cannot tell, and
  the supervisor goes on with the goal on its own.
* *Knowledge of the goal.* Every ``probe_period`` the client asks for the result again, with a
  new request. A supervisor that runs the goal keeps the request until the goal ends; a
  supervisor started again in its place does not know the goal and answers at once (rclpy's
  action server: status UNKNOWN), or ends it (ABORTED, the reason in the result). Such an
  answer to a probe while the first request is still unanswered means the goal's server is
  gone (an end answered by the same server reaches both requests: the first is given
  ``ANSWER_GRACE`` to arrive).

:class:`GoalWatch` holds these observations and says, once either is conclusive, why the goal
is lost; it does no ROS (see :mod:`walker_teleop.goal_monitor`).
"""

from __future__ import annotations

__all__ = ['GoalWatch', 'supervisor_status_name', 'SILENCE_LIMIT', 'PROBE_PERIOD',
           'ANSWER_GRACE']

#: [s] the supervisor's status silent this long: it is taken for dead (it publishes every 1 s)
SILENCE_LIMIT = 5.0
#: [s] how often the result is asked for again, to find a supervisor started again
PROBE_PERIOD = 2.0
#: [s] a probe answered with an end: how long the first request may take to be answered too
ANSWER_GRACE = 1.0


def supervisor_status_name(namespace: str) -> str:
    """Name of the supervisor's status on ``/diagnostics`` (``<namespace>/supervisor: walker``)."""
    return f'{namespace.rstrip("/")}/supervisor: walker'


class GoalWatch:
    """What a client has seen of a goal's server (times [s] on a monotonic clock).

    Parameters
    ----------
    server : str
        The server's name, for the messages (e.g. ``/walker/supervisor``).
    what : str
        The goal, for the messages (e.g. ``the walk to n4_3``).
    now : float
        When the wait began: the silence counts from here until the first status.
    silence_limit, probe_period : float
        See :data:`SILENCE_LIMIT` and :data:`PROBE_PERIOD` [s].
    """

    def __init__(self, server: str, what: str, now: float,
                 silence_limit: float = SILENCE_LIMIT, probe_period: float = PROBE_PERIOD
                 ) -> None:
        self.server = server
        self.what = what
        self.silence_limit = silence_limit
        self.probe_period = probe_period
        self._last_heard = now
        self._last_probe = now
        self._forgotten = ''
        self._forgotten_at = now

    def heard(self, now: float) -> None:
        """Note that the server's status arrived at ``now``."""
        self._last_heard = max(self._last_heard, now)

    def probe_due(self, now: float) -> bool:
        """Say whether to ask for the result again now (and count it as asked)."""
        if now - self._last_probe < self.probe_period:
            return False
        self._last_probe = now
        return True

    def probe_answered(self, status: str, message: str, now: float) -> None:
        """Note a probe answered at ``now`` while the first request was not.

        ``status`` is the goal status the answer gives (``'unknown'``, ``'aborted'``, ...);
        ``message`` the result's message, if any. An unknown goal is conclusive at once: the
        server that accepted it would know it. An end is conclusive if the first request is
        still unanswered ``ANSWER_GRACE`` later.
        """
        if self._forgotten:
            return
        if status == 'unknown':
            self._forgotten = (f'{self.server} was started again and does not know '
                               f'{self.what}: it has ended')
            self._forgotten_at = now - ANSWER_GRACE
        else:
            self._forgotten = (f'{self.server} was started again and ended {self.what} '
                               f'({status}' + (f': {message}' if message else '') + ')')
            self._forgotten_at = now

    def verdict(self, now: float) -> str:
        """Why the goal is lost, or ``''`` while its server may still be running it."""
        if self._forgotten and now - self._forgotten_at >= ANSWER_GRACE:
            return self._forgotten
        silent = now - self._last_heard
        if silent >= self.silence_limit:
            return (f'{self.server} has been silent for {silent:.1f} s (it publishes its '
                    f'status on /diagnostics every second): it is not running or cannot be '
                    f'reached, and the outcome of {self.what} is unknown: check with walkerctl '
                    f'status')
        return ''
