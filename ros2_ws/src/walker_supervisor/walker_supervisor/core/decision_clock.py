"""How far the plant may run in sim time before the supervisor decides again (free of ROS).

With ``sim.wait_for_decisions`` the plant does not step past the time the supervisor last
published on ``supervisor/decided_until``: its next tick, or "now" while something it waits
for is unanswered, so that the motion the answer starts begins at the same simulated time
however long the answer takes in wall time. An unanswered gripper command holds the clock
for a bounded wall time only: a plant that never answers (gone) must not be waited for for
good, and a plant started again must not crawl (the watchdog deals with a dead plant).
"""

from __future__ import annotations

from collections.abc import Hashable

__all__ = ['DecisionClock']


class DecisionClock:
    """The simulated time the supervisor has decided up to.

    Parameters
    ----------
    answer_wait : float
        Wall time [s] an unanswered gripper command holds the clock at most (> 0).

    Raises
    ------
    ValueError
        If ``answer_wait`` is not a positive number of seconds.
    """

    def __init__(self, answer_wait: float) -> None:
        if not answer_wait > 0.0:
            raise ValueError(f'answer_wait must be > 0 s, got {answer_wait!r}')
        self.answer_wait = float(answer_wait)
        self._sent: dict[Hashable, float] = {}  # [s] wall time each unanswered command was sent
        self._plan_awaited_since: float | None = None  # [s] wall

    def command_sent(self, command: Hashable, wall: float) -> None:
        """Note a gripper command sent at ``wall`` [s] (any monotonic clock), unanswered."""
        self._sent[command] = float(wall)

    def command_answered(self, command: Hashable) -> None:
        """Note the answer to a command (one never noted, or given up on, changes nothing)."""
        self._sent.pop(command, None)

    def unanswered(self, wall: float) -> int:
        """How many commands are unanswered and still waited for at ``wall`` [s].

        Commands unanswered for ``answer_wait`` or longer are given up on (and forgotten).
        """
        self._sent = {command: sent for command, sent in self._sent.items()
                      if wall - sent < self.answer_wait}
        return len(self._sent)

    def plan_awaited(self, awaited: bool, wall: float) -> bool:
        """Return True while a plan the sequencer waits for holds the clock.

        ``awaited`` says whether it waits now (a freed gripper waiting for the sweep's plan);
        the hold lasts from the first such call for ``answer_wait`` of wall time at most: a
        plan that never comes (the planner gone) must not freeze the simulation, on which the
        sequencer's own bound on the wait is counted.
        """
        if not awaited:
            self._plan_awaited_since = None
            return False
        if self._plan_awaited_since is None:
            self._plan_awaited_since = float(wall)
        return wall - self._plan_awaited_since < self.answer_wait

    def decided_until(self, now: int, next_tick_in: int | None, busy: bool,
                      wall: float) -> int:
        """Return the simulated time [ns] the plant may run up to.

        Parameters
        ----------
        now : int
            The ROS clock now [ns].
        next_tick_in : int or None
            Time to the supervisor's next tick [ns] (None: no tick scheduled).
        busy : bool
            Something else is waited for (a planner request unanswered, a plan awaited).
        wall : float
            The wall clock now [s], the one :meth:`command_sent` was given.

        Returns
        -------
        int
            ``now`` while busy, without a next tick, or with a gripper command still waited
            for; else the next tick.
        """
        if busy or next_tick_in is None or self.unanswered(wall):
            return now
        return now + max(0, int(next_tick_in))
