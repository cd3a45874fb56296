"""Effort commands arriving at the plant: the newest per joint, the drive watchdog, lock-step.

Times are integer nanoseconds (ROS stamps): the plant's state at step k is stamped ``t_k``, and
each controller answers with an effort stamped ``t_k`` (docs/architecture.md, Timing).

* :class:`EffortCommands` keeps the newest effort of each joint with the stamp it answers and
  turns them into the torques of a step: a joint that never spoke, or whose newest effort
  answers a state older than ``command_timeout``, gets zero torque, as a drive's watchdog
  disables it (joint friction then holds it).
* :class:`LockStep` is the sim-time handshake: a step waits until every joint it waits for has
  answered the current stamp, or until a wall-clock timeout; a joint that timed out is no longer
  waited for (its periods are counted as missed) until it answers a current stamp again, so a
  dead controller slows the simulation once, not at every step.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable

import numpy as np

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES

__all__ = ['CommandError', 'EffortCommands', 'LockStep', 'seconds_to_ns']

_NS_PER_S = 1_000_000_000


def seconds_to_ns(seconds: float) -> int:
    """Convert seconds to integer nanoseconds (rounded)."""
    return round(seconds * _NS_PER_S)


class CommandError(ValueError):
    """An effort command that is refused (unknown joint, malformed); nothing changed."""


@dataclasses.dataclass
class _Command:
    effort: float
    stamp: int


class EffortCommands:
    """The newest effort command of each joint.

    Parameters
    ----------
    command_timeout : float
        Age [s] (plant clock, from the stamp the command answers) beyond which a joint's
        command is no longer applied.
    """

    def __init__(self, command_timeout: float) -> None:
        self.command_timeout = command_timeout
        self._latest: dict[str, _Command] = {}
        self.refused = 0

    def receive(self, joint: str, effort: float, stamp: int) -> None:
        """Record a joint's effort [N*m] answering the state stamped ``stamp`` [ns].

        A non-finite effort is kept (the drive refuses it and applies 0, and the plant reports
        it): it still answers the state, so lock-step does not wait for it.

        Raises
        ------
        CommandError
            If the joint is unknown (nothing changes).
        """
        if joint not in PHYSICAL_JOINT_NAMES:
            raise CommandError(f'effort command for unknown joint {joint!r}: expected one of '
                               f'{", ".join(PHYSICAL_JOINT_NAMES)}')
        latest = self._latest.get(joint)
        if latest is not None and stamp < latest.stamp:
            return  # an answer to an older state than one already heard: stale
        self._latest[joint] = _Command(float(effort), int(stamp))

    def stamp_of(self, joint: str) -> int | None:
        """Stamp [ns] answered by the joint's newest command (None if it never spoke)."""
        latest = self._latest.get(joint)
        return None if latest is None else latest.stamp

    def answered(self, stamp: int) -> set[str]:
        """Joints whose newest command answers the state stamped ``stamp``."""
        return {joint for joint, command in self._latest.items() if command.stamp == stamp}

    def torques(self, now: int) -> tuple[np.ndarray, list[str]]:
        """Torques [N*m] to apply from time ``now`` [ns], physical order.

        Returns
        -------
        torques : ndarray, shape (5,)
            The newest effort of each joint, or 0 for a joint that never spoke or whose
            command is older than ``command_timeout``.
        expired : list of str
            The joints that have spoken but whose command expired.
        """
        limit = seconds_to_ns(self.command_timeout)
        torques = np.zeros(5)
        expired = []
        for index, joint in enumerate(PHYSICAL_JOINT_NAMES):
            command = self._latest.get(joint)
            if command is None:
                continue
            if now - command.stamp > limit:
                expired.append(joint)
                continue
            torques[index] = command.effort
        return torques, expired


class LockStep:
    """Sim-time handshake between the plant and the five controllers.

    Parameters
    ----------
    timeout : float
        Wall-clock time [s] a step waits for the efforts of the joints it waits for.
    joints : iterable of str, optional
        The joints to wait for (default: all five).
    """

    def __init__(self, timeout: float, joints: Iterable[str] = PHYSICAL_JOINT_NAMES) -> None:
        self.timeout = timeout
        self.joints = tuple(joints)
        self.lost: set[str] = set()
        self.missed = dict.fromkeys(self.joints, 0)
        self.timeouts = 0
        self.stamp: int | None = None
        self._since = math.nan

    def begin(self, stamp: int, wall_now: float) -> None:
        """Wait for the answers to the state stamped ``stamp`` [ns], sent at ``wall_now`` [s]."""
        self.stamp = stamp
        self._since = wall_now

    def waiting_for(self, commands: EffortCommands) -> list[str]:
        """Joints the step still waits for (not lost, not yet answered)."""
        answered = commands.answered(self.stamp)
        self.lost -= answered  # a lost joint that answers a current state is back
        return [joint for joint in self.joints if joint not in answered and joint not in
                self.lost]

    def ready(self, commands: EffortCommands) -> bool:
        """Return True when every joint waited for has answered the current stamp."""
        return not self.waiting_for(commands)

    def expired(self, wall_now: float) -> bool:
        """Return True when the wait for the current stamp has lasted ``timeout``."""
        return wall_now - self._since >= self.timeout

    def give_up(self, commands: EffortCommands) -> list[str]:
        """End the wait for the current step: count and return the joints that missed it.

        Every joint that did not answer the current stamp missed the period; those that were
        waited for are no longer waited for until they answer a current state again.
        """
        answered = commands.answered(self.stamp)
        late = [joint for joint in self.joints if joint not in answered]
        newly_lost = [joint for joint in late if joint not in self.lost]
        if newly_lost:
            self.timeouts += 1
        self.lost.update(late)
        for joint in late:
            self.missed[joint] += 1
        return newly_lost

    def count_misses(self, commands: EffortCommands) -> list[str]:
        """Count the joints that have spoken but did not answer the current stamp.

        Used when a step goes ahead without waiting for them (lost joints in sim time, late
        ones in real time). Returns the joints counted.
        """
        answered = commands.answered(self.stamp)
        late = [joint for joint in self.joints if joint not in answered
                and commands.stamp_of(joint) is not None]
        for joint in late:
            self.missed[joint] += 1
        return late


class DecisionGate:
    """Sim time: how far the plant may step before the supervisor has decided.

    The supervisor releases the clock up to a time (its next decision, or where it is when a
    request of it is still unanswered); the plant steps to a stamp only if it is not later
    than that, so the supervisor's decisions fall at the same simulated times however long
    they take on the wall clock. Inactive until the first release. A wait longer than
    ``timeout`` [s] of wall time drops the gate until the next release: a supervisor that
    died does not stop the simulation.
    """

    def __init__(self, timeout: float) -> None:
        self.timeout = timeout
        self.until: int | None = None  # [ns] newest time released; None: not waiting for it
        self.timeouts = 0
        self._waiting_since = math.nan

    def release(self, until: int) -> None:
        """Take a release up to stamp ``until`` [ns]."""
        self.until = int(until)
        self._waiting_since = math.nan

    def allows(self, stamp: int) -> bool:
        """Say whether the plant may step to the state stamped ``stamp`` [ns]."""
        return self.until is None or stamp <= self.until

    def wait(self, wall_now: float) -> None:
        """Note that the plant waits at the gate, from ``wall_now`` [s] if not already."""
        if math.isnan(self._waiting_since):
            self._waiting_since = wall_now

    def expired(self, wall_now: float) -> bool:
        """Return True when the plant has waited at the gate for ``timeout``."""
        return wall_now - self._waiting_since >= self.timeout

    def open(self) -> None:
        """Stop waiting (``sim.wait_for_decisions`` turned off); not a timeout."""
        self.until = None
        self._waiting_since = math.nan

    def drop(self) -> None:
        """Stop waiting for the supervisor until its next release; count it."""
        self.until = None
        self._waiting_since = math.nan
        self.timeouts += 1
