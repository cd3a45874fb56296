"""Which action goals this supervisor runs, and which it inherited from a process before it.

A ``walk_to`` or ``step`` goal belongs to the supervisor process that accepted it: its result
is owed by that process alone. When the process dies, a supervisor started in its place
cannot take the goal up (an action server knows only goals it accepted itself), but it can
say what became of it. The supervisor therefore keeps, in a small file beside its step-state
file, the ids of the goals it runs (:class:`OwnedGoals`); a supervisor that starts finds the
ids the dead process left there and takes them as *orphaned*: it answers a result request for
one of them at once with the goal ABORTED and :func:`orphan_message` as the reason, where an
action server that never heard of a goal would answer UNKNOWN and leave its client guessing.

The ledger is plain data: goal ids as 32 hexadecimal digits (the goal's UUID), the action's
name (``walk_to`` or ``step``) and the target node. It does no file or ROS work
(:mod:`walker_supervisor.owned_goal_server` does).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

__all__ = ['OwnedGoals', 'OrphanedGoal', 'orphan_message', 'ORPHANS_KEPT']

#: at most this many orphaned goals are remembered (the newest), over any number of restarts
ORPHANS_KEPT = 64


@dataclasses.dataclass(frozen=True)
class OrphanedGoal:
    """A goal accepted by a supervisor process that has since died."""

    goal_id: str  # the goal's UUID, 32 hexadecimal digits
    action: str  # 'walk_to' or 'step'
    target_node: str


def orphan_message(goal: OrphanedGoal) -> str:
    """Return the reason given with an orphaned goal's ABORTED result."""
    what = 'walk' if goal.action == 'walk_to' else 'step'
    return (f'the supervisor that accepted this {what} to {goal.target_node} died and '
            f'was started again; the new one does not run it (a step under way is adopted and '
            f'held: check with walkerctl status, then resume or send a new goal)')


class OwnedGoals:
    """The goals a supervisor runs now, and those orphaned by its predecessors.

    Parameters
    ----------
    previous : Mapping, optional
        What the file of the process before this one held (:meth:`to_record`); every goal it
        ran becomes orphaned, and its orphans stay so.
    """

    def __init__(self, previous: Mapping | None = None) -> None:
        self._running: dict[str, OrphanedGoal] = {}
        orphans: list[OrphanedGoal] = []
        for key in ('orphaned', 'running'):
            for entry in (previous or {}).get(key, []) or []:
                try:
                    orphans.append(OrphanedGoal(_goal_id(entry['goal_id']),
                                                str(entry['action']),
                                                str(entry['target_node'])))
                except (KeyError, TypeError, ValueError):
                    continue  # a damaged entry is dropped, the others are kept
        self._orphaned = {goal.goal_id: goal for goal in orphans[-ORPHANS_KEPT:]}

    @property
    def running(self) -> tuple[str, ...]:
        """Ids of the goals this process runs."""
        return tuple(self._running)

    @property
    def orphaned(self) -> tuple[str, ...]:
        """Ids of the goals accepted by an earlier process, now orphaned."""
        return tuple(self._orphaned)

    def started(self, goal_id: bytes | str, action: str, target_node: str) -> None:
        """Note a goal this process runs (its result is owed)."""
        key = _goal_id(goal_id)
        self._running[key] = OrphanedGoal(key, action, target_node)

    def ended(self, goal_id: bytes | str) -> None:
        """Note that a goal's result was given."""
        self._running.pop(_goal_id(goal_id), None)

    def orphan(self, goal_id: bytes | str) -> OrphanedGoal | None:
        """Return the orphaned goal of this id, or None when it is not one."""
        return self._orphaned.get(_goal_id(goal_id))

    def to_record(self) -> dict:
        """Return what the file keeps: the goals running and orphaned, plain data."""
        return {key: [dataclasses.asdict(goal) for goal in goals.values()]
                for key, goals in (('running', self._running), ('orphaned', self._orphaned))}


def _goal_id(goal_id: bytes | bytearray | str | list) -> str:
    """Return a goal UUID as 32 lowercase hexadecimal digits."""
    if isinstance(goal_id, str):
        text = goal_id.lower()
        if len(text) != 32 or any(c not in '0123456789abcdef' for c in text):
            raise ValueError(f'not a goal id: {goal_id!r} (32 hexadecimal digits)')
        return text
    raw = bytes(goal_id)
    if len(raw) != 16:
        raise ValueError(f'not a goal id: {len(raw)} bytes (a UUID has 16)')
    return raw.hex()
