"""The ROS side of :class:`~walker_teleop.core.goal_watch.GoalWatch`: a goal's server watched.

A client about to send a ``walk_to`` or ``step`` goal makes a :class:`GoalMonitor` (its
subscription is matched while the goal is sent: over a thin link, matching a reader made later
can take longer than the silence allowed), notes the goal's acceptance and each feedback with
:meth:`GoalMonitor.heard` (the server's own messages: as good a sign of life as its status), and
calls :meth:`GoalMonitor.check` between spins of its executor. The monitor subscribes to
``/diagnostics`` for the supervisor's status and asks for the goal's result again every
:data:`~walker_teleop.core.goal_watch.PROBE_PERIOD` seconds; :meth:`~GoalMonitor.check` gives
the goal's end if a probe brought it, and raises :class:`GoalLostError` (with the reason) once
the supervisor is judged dead or started again. Times are taken on the monotonic clock: the
question is whether a process runs, whatever the graph's clock.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from action_msgs.msg import GoalStatus
from diagnostic_msgs.msg import DiagnosticArray

from walker_runtime.qos import COMMAND_QOS
from walker_teleop.core.goal_watch import GoalWatch, supervisor_status_name

__all__ = ['GoalMonitor', 'GoalLostError']

_ENDED = (GoalStatus.STATUS_SUCCEEDED, GoalStatus.STATUS_CANCELED, GoalStatus.STATUS_ABORTED)


class GoalLostError(RuntimeError):
    """The server of a goal died or was started again: the goal's outcome is unknown."""


class GoalMonitor:
    """Watch the supervisor that runs a goal, from a client node.

    Parameters
    ----------
    node : rclpy.node.Node
        The client's node (its executor must be spun by the caller).
    namespace : str
        The robot's namespace (the supervisor is ``<namespace>/supervisor``).
    what : str
        The goal, for the messages (e.g. ``the walk to n4_3``).
    clock : callable
        Monotonic time [s] (replaceable in tests).
    """

    def __init__(self, node, namespace: str, what: str,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self._node = node
        self._clock = clock
        self._status_name = supervisor_status_name(namespace)
        self.watch = GoalWatch(f'{namespace.rstrip("/")}/supervisor', what, clock())
        self._probes: list = []
        self._subscription = node.create_subscription(DiagnosticArray, '/diagnostics',
                                                      self._on_diagnostics, COMMAND_QOS)

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        if any(status.name == self._status_name for status in msg.status):
            self.heard()

    def heard(self) -> None:
        """Note that the server was heard now: its status, the goal's acceptance or feedback."""
        self.watch.heard(self._clock())

    def check(self, handle, result) -> object | None:
        """Probe the goal's server; return the goal's end (its wrapped result) if a probe has it.

        ``handle`` is the accepted goal's ``ClientGoalHandle``, ``result`` the future of the
        first result request. Returns None while the goal may still run.

        Raises
        ------
        GoalLostError
            The supervisor has been silent too long, or answered a probe as a process that
            does not know the goal.
        """
        now = self._clock()
        for probe in [p for p in self._probes if p.done()]:
            self._probes.remove(probe)
            answer = probe.result()
            if result.done() or answer is None:
                continue
            if answer.status == GoalStatus.STATUS_ABORTED:
                # a supervisor started again ends the goals it inherited; the same server's
                # abort reaches the first request too (the watch waits ANSWER_GRACE for it)
                self.watch.probe_answered('aborted', answer.result.message, now)
            elif answer.status in _ENDED:
                return answer  # the same server's end: the first answer may have been lost
            else:
                self.watch.probe_answered('unknown', '', now)
        if not result.done() and self.watch.probe_due(now):
            self._probes.append(handle.get_result_async())
        verdict = '' if result.done() else self.watch.verdict(now)
        if verdict:
            raise GoalLostError(verdict)
        return None

    def close(self) -> None:
        """Stop listening (the probes in flight are left to the action client)."""
        self._node.destroy_subscription(self._subscription)
