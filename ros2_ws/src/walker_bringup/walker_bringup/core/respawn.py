"""When a dead node process is started again, and when the bring-up gives up on it (ROS-free).

The decisions of the supervised bring-up (``run_all.py``), as ROS 2 launch's ``respawn``,
``respawn_delay`` and ``respawn_max_retries`` make them for a launched node, kept here without
processes or clocks: the caller reports deaths and restarts with the time on a monotonic clock
[s], asks which restarts are due, and reads the record of each node for the walk summary.

* A node that dies is started again ``delay`` seconds later (a crash that repeats at once does
  not spin the machine).
* A node that dies more than ``limit`` times in a row is given up: the graph is then a dead
  graph, as before respawning existed. A node that ran ``stable_after`` seconds or longer
  before it died starts its count again: rare crashes over a long ``--serve`` session do not
  add up to a node that keeps dying.
* A node that refused its configuration (exit code ``EXIT_REFUSED`` of
  :mod:`walker_runtime.node_main`) is given up at once: started again with the same parameter
  file it would refuse it again.
"""

from __future__ import annotations

import dataclasses
import math

__all__ = ['RespawnPolicy', 'NodeRecord', 'Decision', 'RespawnBook', 'REFUSED_EXIT_CODE',
           'DEFAULT_DELAY', 'DEFAULT_LIMIT', 'DEFAULT_STABLE_AFTER']

#: Exit code of a node that refused its parameters (``walker_runtime.node_main.EXIT_REFUSED``;
#: the value is repeated here because a core imports nothing of the ROS layer).
REFUSED_EXIT_CODE = 2
#: [s] wait before a dead node is started again (launch's ``respawn_delay``).
DEFAULT_DELAY = 1.0
#: Restarts of one node in a row before the bring-up gives up on it.
DEFAULT_LIMIT = 3
#: [s] a node that ran this long before it died starts its count of restarts in a row again.
DEFAULT_STABLE_AFTER = 60.0


@dataclasses.dataclass(frozen=True)
class RespawnPolicy:
    """How dead nodes are started again.

    Attributes
    ----------
    delay : float
        Seconds between a death and the restart (>= 0).
    limit : int
        Restarts in a row allowed per node (0: a death is never answered by a restart, as
        before respawning existed).
    stable_after : float
        Seconds of running after which a death no longer counts as "in a row" (> 0).
    """

    delay: float = DEFAULT_DELAY
    limit: int = DEFAULT_LIMIT
    stable_after: float = DEFAULT_STABLE_AFTER

    def __post_init__(self) -> None:
        if not (isinstance(self.delay, (int, float)) and math.isfinite(self.delay)
                and self.delay >= 0.0):
            raise ValueError(f'respawn delay must be a number of seconds >= 0, got '
                             f'{self.delay!r}')
        if isinstance(self.limit, bool) or not isinstance(self.limit, int) or self.limit < 0:
            raise ValueError(f'respawn limit must be a whole number >= 0, got {self.limit!r}')
        if not (isinstance(self.stable_after, (int, float)) and math.isfinite(self.stable_after)
                and self.stable_after > 0.0):
            raise ValueError(f'stable_after must be a positive number of seconds, got '
                             f'{self.stable_after!r}')


@dataclasses.dataclass
class NodeRecord:
    """What happened to one node's processes in a run (the walk summary's entry).

    Attributes
    ----------
    deaths : int
        Processes of the node that ended while the graph ran.
    restarts : int
        Processes started again after a death.
    exit_codes : list of int
        Exit code of each death (negative: killed by that signal).
    gave_up : str
        Why the bring-up stopped starting the node again ('' while it has not).
    in_a_row : int
        Restarts since the node last ran ``stable_after`` seconds.
    due_at : float or None
        Monotonic time [s] of the pending restart, None when none is pending.
    """

    deaths: int = 0
    restarts: int = 0
    exit_codes: list[int] = dataclasses.field(default_factory=list)
    gave_up: str = ''
    in_a_row: int = 0
    due_at: float | None = None

    def as_dict(self) -> dict:
        """Return the record as the walk summary holds it."""
        return {'deaths': self.deaths, 'restarts': self.restarts,
                'exit_codes': list(self.exit_codes), 'gave_up': self.gave_up}


@dataclasses.dataclass(frozen=True)
class Decision:
    """The answer to a death: a restart at ``restart_at`` [s], or ``gave_up`` with the reason."""

    node: str
    restart_at: float | None
    gave_up: str = ''

    @property
    def respawn(self) -> bool:
        """True when the node will be started again."""
        return self.restart_at is not None


class RespawnBook:
    """The deaths and restarts of a graph's nodes, and the decisions about them.

    Parameters
    ----------
    policy : RespawnPolicy
        Delay, limit, and when a node counts as having run well.
    """

    def __init__(self, policy: RespawnPolicy) -> None:
        self.policy = policy
        self._records: dict[str, NodeRecord] = {}

    def record(self, node: str) -> NodeRecord:
        """Return the record of ``node`` (an empty one for a node that never died)."""
        return self._records.setdefault(node, NodeRecord())

    def on_death(self, node: str, exit_code: int | None, ran_for: float, now: float
                 ) -> Decision:
        """Decide what a death of ``node`` leads to.

        Parameters
        ----------
        node : str
            The node's name.
        exit_code : int or None
            The process's exit code (negative: the signal that killed it).
        ran_for : float
            Seconds the process ran before it died.
        now : float
            Monotonic time [s] of the death.
        """
        record = self.record(node)
        record.deaths += 1
        record.exit_codes.append(exit_code if exit_code is not None else -1)
        if ran_for >= self.policy.stable_after:
            record.in_a_row = 0
        if record.gave_up:
            return Decision(node, None, record.gave_up)
        if exit_code == REFUSED_EXIT_CODE:
            record.gave_up = ('it refused its configuration (exit code '
                              f'{REFUSED_EXIT_CODE}): started again it would refuse it again')
        elif self.policy.limit == 0:
            record.gave_up = 'respawning is off (--respawn-limit 0)'
        elif record.in_a_row >= self.policy.limit:
            record.gave_up = (f'it died {record.in_a_row + 1} times in a row, each within '
                              f'{self.policy.stable_after:g} s of its start (--respawn-limit '
                              f'{self.policy.limit})')
        if record.gave_up:
            record.due_at = None
            return Decision(node, None, record.gave_up)
        record.due_at = now + self.policy.delay
        return Decision(node, record.due_at)

    def due(self, now: float) -> list[str]:
        """Nodes whose restart is due at ``now`` [s], in the order they died."""
        waiting = [(r.due_at, n) for n, r in self._records.items()
                   if r.due_at is not None and r.due_at <= now]
        return [n for _, n in sorted(waiting)]

    def on_restart(self, node: str) -> None:
        """Note that ``node`` was started again."""
        record = self.record(node)
        record.restarts += 1
        record.in_a_row += 1
        record.due_at = None

    @property
    def pending(self) -> bool:
        """True while some restart waits for its delay."""
        return any(r.due_at is not None for r in self._records.values())

    @property
    def given_up(self) -> dict[str, str]:
        """Node -> why it is no longer started again."""
        return {n: r.gave_up for n, r in self._records.items() if r.gave_up}

    def summary(self) -> dict[str, dict]:
        """Node -> its record (:meth:`NodeRecord.as_dict`), for every node that died."""
        return {n: r.as_dict() for n, r in self._records.items() if r.deaths}
