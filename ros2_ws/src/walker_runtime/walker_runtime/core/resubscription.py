"""When a subscription silent for long is made anew.

A ROS-free rule shared by every node that watches its inputs on a steady clock (through
:class:`walker_runtime.watched_subscription.WatchedSubscription`): the joint controllers (their
state and setpoint streams), the supervisor (the plant's and the controllers' reports) and the
planner (the joint states its stream is paced by, which :func:`clock_ran_past` tells from a
plant that stopped). A silence is the subscription's, and making it anew worth trying, only while
the stream's peers are alive (:func:`peers_alive`): a publisher that is gone or stopped is not
healed by a new subscription, and one merely stalled by a loaded machine must not be
re-matched (which lengthens the stall).
"""

from __future__ import annotations

import math

__all__ = ['Resubscription', 'peers_alive', 'clock_ran_past']


class Resubscription:
    """When to make anew the subscription of a stream that has been silent for long.

    A subscription can stop receiving while its publisher lives on: seen with Fast DDS's
    shared-memory transport after a process of the graph was killed and started again, or
    frozen and resumed (one controller then missed one topic until it was restarted). Waiting
    does not heal that; a new subscription is matched anew, and costs nothing when the
    publisher is really gone. The first attempt comes ``after`` seconds into a silence, later
    ones every ``after`` seconds while it lasts.

    Parameters
    ----------
    after : float
        [s] on the steady clock, > 0.
    """

    def __init__(self, after: float) -> None:
        self.after = after
        self._last_attempt: float | None = None
        self.attempts = 0

    @property
    def after(self) -> float:
        """[s] steady time of silence before an attempt, and between attempts."""
        return self._after

    @after.setter
    def after(self, value: float) -> None:
        if isinstance(value, bool) or not isinstance(value, (int, float)) \
                or not (math.isfinite(value) and value > 0.0):
            raise ValueError(f'resubscription interval must be positive and finite, got {value!r}')
        self._after = float(value)

    def silent(self, now: float, last_heard: float | None) -> bool:
        """Say whether the stream has been silent for ``after`` seconds (nothing counted).

        Parameters
        ----------
        now : float
            [s] steady time now.
        last_heard : float or None
            [s] steady time of the stream's last message; None when it has not been heard
            from (nothing to heal: it may not have started).
        """
        return last_heard is not None and now - last_heard >= self.after

    def due(self, now: float, last_heard: float | None, alive: bool = True) -> bool:
        """Return True, and count an attempt, when the subscription should be made anew.

        Parameters
        ----------
        now : float
            [s] steady time now.
        last_heard : float or None
            [s] steady time of the stream's last message (see :meth:`silent`).
        alive : bool
            The stream's peers are alive (:func:`peers_alive`); a silence while they are not
            is theirs, and no attempt is made.
        """
        if not (alive and self.silent(now, last_heard)):
            return False
        since = last_heard if self._last_attempt is None else max(last_heard,
                                                                   self._last_attempt)
        if now - since < self.after:
            return False
        self._last_attempt = now
        self.attempts += 1
        return True


def peers_alive(peers: int, evidence: bool = True) -> bool:
    """Say whether a silent stream's peers are alive, so that the silence is the reader's own.

    Parameters
    ----------
    peers : int
        The stream's publishers in the ROS graph now (for a publisher made anew, its
        subscribers): discovered, and their participants' leases not run out. None: a
        publisher gone for good, or never started; a new subscription hears nothing more.
    evidence : bool
        What else the reader knows of them; True when it knows nothing else. A clock the
        publisher drives running on (:func:`clock_ran_past`) tells a publisher that runs
        unheard from one that stopped (a frozen plant stays in the graph for the length of
        its lease).

    Returns
    -------
    bool
        True when there is at least one peer and the evidence does not speak against it.
    """
    return peers > 0 and evidence


def clock_ran_past(clock_now: int, newest: int | None, margin: int, sim_time: bool) -> bool:
    """Say whether the clock has run ``margin`` past a stream's newest message.

    A stream stamped from the clock that falls silent while that clock runs on was not
    stopped at its source: its subscription stopped receiving. A silence with the clock
    standing still too (a simulated clock held, a plant stopped) is its publisher's.

    Parameters
    ----------
    clock_now : int
        [ns] the ROS clock now (simulated time in sim time).
    newest : int or None
        [ns] the stamp of the newest message; None when none has been heard.
    margin : int
        [ns] how far past it the clock must have run.
    sim_time : bool
        The clock is simulated: it starts at 0 with the publisher, so a clock past ``margin``
        with nothing heard means the publisher runs unheard. On the wall clock nothing heard
        says nothing (the publisher may not have started): False.
    """
    if newest is None and not sim_time:
        return False
    return clock_now - (newest or 0) >= margin
