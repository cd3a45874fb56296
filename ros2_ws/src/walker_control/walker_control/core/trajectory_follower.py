"""A whole joint trajectory held by a controller and sampled at its control period.

The controllers' side of ros2_controllers' joint_trajectory_controller (JTC), free of ROS:
a trajectory is received once, as points (time from its start, positions, optionally
velocities and accelerations, per joint), and the controller samples it for every state it
answers, so that a late or lost message costs nothing while a trajectory is held.

Semantics (those of JTC's "trajectory replacement"):

* **Start time.** A trajectory carries the clock time [s] at which its ``time_from_start`` 0
  applies; 0 means "now", the time it is received.
* **Replacement from the start time.** A new trajectory replaces the one held from its start
  time on: before it, the held one (and any that start earlier) is followed still; one queued to
  start at or after the new start time is dropped. From the start time the reference goes from
  where the old reference is then to the new trajectory's first point, interpolated over the
  first point's ``time_from_start`` (at once when that is 0), so a replacement never jumps
  unless its first point is at time 0 somewhere else.
* **Points in the past.** A trajectory whose start time is in the past is sampled at its own
  time: the points already past are not replayed. One that ends before it is received is
  followed by holding its last point at rest (JTC refuses such a trajectory; here, as a
  late-arriving message must not leave the joint without a reference, its end is held).
* **After the end.** The last point is held: its position, at rest.
* **Empty or malformed.** A trajectory with no points is refused (:class:`TrajectoryError`),
  as JTC refuses it; to stop, send a one-point trajectory, or call
  :meth:`TrajectoryFollower.hold`. Times not finite, negative or not strictly increasing,
  NaN or infinite values, rows of the wrong size, a joint missing or named twice are refused
  with an error that names what was wrong, and nothing changes.

Between points each joint is interpolated as JTC does: quintic with positions, velocities and
accelerations at both ends of a segment, cubic with positions and velocities, linear with
positions only (the velocity of a linear segment is its slope, its acceleration 0).

Units: times [s], positions [rad], velocities [rad/s], accelerations [rad/s^2]. Times are the
clock of the states the controller answers (sim time or wall time alike), as float seconds.
"""

from __future__ import annotations

import bisect
import dataclasses
import math
from collections.abc import Sequence

import numpy as np

__all__ = ['JointTrajectory', 'TrajectoryError', 'TrajectoryFollower', 'TrajectorySample']


class TrajectoryError(ValueError):
    """A trajectory that cannot be followed (empty, malformed, not finite); nothing changed."""


@dataclasses.dataclass(frozen=True)
class TrajectorySample:
    """The reference of the held trajectory at one time.

    Attributes
    ----------
    positions, velocities, accelerations : ndarray, shape (J,)
        Per joint of the follower, in its order [rad, rad/s, rad/s^2].
    ended : bool
        The time is at or after the end of the trajectory in force (its last point is held).
    """

    positions: np.ndarray
    velocities: np.ndarray
    accelerations: np.ndarray
    ended: bool


@dataclasses.dataclass(frozen=True)
class JointTrajectory:
    """A validated trajectory for given joints, in their order.

    Attributes
    ----------
    start : float
        Clock time [s] at which ``times`` 0 applies; 0 for "when received".
    times : ndarray, shape (N,)
        Time from start of each point [s], finite, >= 0, strictly increasing, N >= 1.
    positions : ndarray, shape (N, J)
        [rad].
    velocities, accelerations : ndarray, shape (N, J), or None
        [rad/s], [rad/s^2]; None when the points do not carry them.
    """

    start: float
    times: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray | None = None
    accelerations: np.ndarray | None = None

    @classmethod
    def from_points(cls, joints: Sequence[str], joint_names: Sequence[str],
                    times: Sequence[float], positions: Sequence[Sequence[float]],
                    velocities: Sequence[Sequence[float]] = (),
                    accelerations: Sequence[Sequence[float]] = (),
                    start: float = 0.0) -> JointTrajectory:
        """Check a trajectory as received and take the columns of ``joints`` from it.

        Parameters
        ----------
        joints : sequence of str
            The joints wanted, in the order of the result (a controller's joints).
        joint_names : sequence of str
            The names the trajectory's columns carry; it must name every joint of ``joints``
            once, and may name others (a trajectory for the whole arm sent to one joint).
        times : sequence of float
            Each point's time from start [s].
        positions, velocities, accelerations : sequence of sequences of float
            Per point, one value per name of ``joint_names``; velocities and accelerations
            may be empty for every point (not carried); accelerations need velocities.
        start : float
            Clock time [s] of ``times`` 0; 0 for "when received".

        Raises
        ------
        TrajectoryError
            Naming what was wrong.
        """
        names = list(joint_names)
        for name in set(names):
            if names.count(name) > 1:
                raise TrajectoryError(f'joint {name!r} is named twice in the trajectory')
        missing = [joint for joint in joints if joint not in names]
        if missing:
            raise TrajectoryError(f'the trajectory does not name {", ".join(missing)} '
                                  f'(it names {names})')
        columns = [names.index(joint) for joint in joints]
        if not (isinstance(start, (int, float)) and math.isfinite(start) and start >= 0.0):
            raise TrajectoryError(f'start time must be finite and >= 0 s, got {start!r}')
        times = np.asarray(times, dtype=float)
        if times.ndim != 1 or times.size == 0:
            raise TrajectoryError('the trajectory has no points (an empty trajectory is '
                                  'refused; send one point to hold)')
        if not np.all(np.isfinite(times)):
            raise TrajectoryError('time_from_start must be finite (NaN and infinity are '
                                  'refused)')
        if times[0] < 0.0 or np.any(np.diff(times) <= 0.0):
            raise TrajectoryError(f'time_from_start must be >= 0 and strictly increasing, '
                                  f'got {times.tolist()}')
        arrays = []
        for what, rows, required in (('positions', positions, True),
                                     ('velocities', velocities, False),
                                     ('accelerations', accelerations, False)):
            rows = [list(row) for row in rows]
            if not required and all(len(row) == 0 for row in rows):
                arrays.append(None)
                continue
            if len(rows) != times.size:
                raise TrajectoryError(f'{len(rows)} rows of {what} for {times.size} points')
            for index, row in enumerate(rows):
                if len(row) != len(names):
                    raise TrajectoryError(
                        f'point {index} has {len(row)} {what} for {len(names)} joint names'
                        + ('' if required else ' (give one per name, or none at all)'))
            array = np.asarray(rows, dtype=float)[:, columns]
            if not np.all(np.isfinite(array)):
                raise TrajectoryError(f'{what} must be finite (NaN and infinity are refused)')
            arrays.append(array)
        if arrays[2] is not None and arrays[1] is None:
            raise TrajectoryError('accelerations were given without velocities')
        return cls(float(start), times, *arrays)

    @property
    def duration(self) -> float:
        """Time from start of the last point [s]."""
        return float(self.times[-1])


class _Segmented:
    """Points with absolute times and what each carries; sampled piecewise (JTC's rules)."""

    def __init__(self, times: np.ndarray, positions: np.ndarray, velocities: np.ndarray,
                 accelerations: np.ndarray, order: np.ndarray) -> None:
        # order[i]: 0 positions only, 1 with velocities, 2 with accelerations too
        self.times = times
        self.knots = [float(t) for t in times]
        self.positions = positions
        self.velocities = velocities
        self.accelerations = accelerations
        self.order = order

    @property
    def end(self) -> float:
        return self.knots[-1]

    def sample(self, t: float) -> TrajectorySample:
        knots = self.knots
        if t >= knots[-1]:
            zeros = np.zeros(self.positions.shape[1])
            return TrajectorySample(self.positions[-1].copy(), zeros, zeros.copy(), True)
        if t < knots[0]:
            # only before the first point of a trajectory with nothing before it
            zeros = np.zeros(self.positions.shape[1])
            return TrajectorySample(self.positions[0].copy(), zeros, zeros.copy(), False)
        i = bisect.bisect_right(knots, t) - 1
        h = knots[i + 1] - knots[i]
        x = (t - knots[i]) / h
        p0, p1 = self.positions[i], self.positions[i + 1]
        degree = min(self.order[i], self.order[i + 1])
        if degree == 0:
            return TrajectorySample(p0 + x * (p1 - p0), (p1 - p0) / h,
                                    np.zeros_like(p0), False)
        d = p1 - p0
        v0, v1 = self.velocities[i] * h, self.velocities[i + 1] * h
        zero = np.zeros_like(p0)
        if degree == 1:
            c = (p0, v0, 3.0 * d - 2.0 * v0 - v1, -2.0 * d + v0 + v1, zero, zero)
        else:
            a0, a1 = self.accelerations[i] * h * h, self.accelerations[i + 1] * h * h
            c = (p0, v0, 0.5 * a0,
                 10.0 * d - 6.0 * v0 - 4.0 * v1 - 1.5 * a0 + 0.5 * a1,
                 -15.0 * d + 8.0 * v0 + 7.0 * v1 + 1.5 * a0 - a1,
                 6.0 * d - 3.0 * (v0 + v1) - 0.5 * (a0 - a1))
        position = c[0] + x * (c[1] + x * (c[2] + x * (c[3] + x * (c[4] + x * c[5]))))
        rate = c[1] + x * (2.0 * c[2] + x * (3.0 * c[3] + x * (4.0 * c[4] + x * 5.0 * c[5])))
        curvature = 2.0 * c[2] + x * (6.0 * c[3] + x * (12.0 * c[4] + x * 20.0 * c[5]))
        return TrajectorySample(position, rate / h, curvature / (h * h), False)


class TrajectoryFollower:
    """The trajectories a controller holds for its joints, sampled at its control period.

    Parameters
    ----------
    joints : sequence of str
        The joints followed, in the order of every sample.

    Notes
    -----
    Not thread-safe: a node with several threads holds its own lock around every call.
    """

    def __init__(self, joints: Sequence[str]) -> None:
        self.joints = tuple(joints)
        if not self.joints:
            raise ValueError('a trajectory follower needs at least one joint')
        # (start [s], segmented points with absolute times), by start; the last one starting
        # at or before a time is in force then
        self._plans: list[tuple[float, _Segmented]] = []

    @property
    def holding_trajectory(self) -> bool:
        """True once a trajectory (or a hold) has been taken and not cleared."""
        return bool(self._plans)

    def end_time(self) -> float | None:
        """Clock time [s] of the last point of the newest trajectory held; None without one."""
        return self._plans[-1][1].end if self._plans else None

    def ended(self, t: float) -> bool:
        """Say whether the reference at clock time ``t`` [s] is a held last point (or none)."""
        sample = self._sample(t, prune=False)
        return sample is None or sample.ended

    def clear(self) -> None:
        """Forget every trajectory (a mode or base change: the joint holds where it is)."""
        self._plans.clear()

    def set_trajectory(self, trajectory: JointTrajectory, now: float,
                       measured: Sequence[float] | None = None) -> float:
        """Take ``trajectory``, received at clock time ``now`` [s]; return its start time [s].

        It replaces the trajectories held from its start time on (see the module docstring).
        Its first point is reached from the reference in force at the start time (or ``now``,
        when that is later); with no trajectory held, from ``measured`` [rad] at rest (the
        measured positions of the follower's joints), or, without it, the first point applies
        from the start time.

        Raises
        ------
        TrajectoryError
            ``trajectory`` is not for this follower's joints; nothing changes.
        """
        if trajectory.positions.shape[1] != len(self.joints):
            raise TrajectoryError(f'the trajectory has {trajectory.positions.shape[1]} joints, '
                                  f'the follower {len(self.joints)}')
        if not math.isfinite(now):
            raise TrajectoryError(f'receive time must be finite, got {now!r}')
        start = trajectory.start if trajectory.start > 0.0 else float(now)
        splice = max(start, float(now))
        before = self._sample(splice, prune=False)
        if before is None and measured is not None:
            measured = np.asarray(measured, dtype=float)
            if measured.shape != (len(self.joints),) or not np.all(np.isfinite(measured)):
                raise TrajectoryError(f'measured positions must be {len(self.joints)} finite '
                                      f'values, got {measured!r}')
            zeros = np.zeros(len(self.joints))
            before = TrajectorySample(measured, zeros, zeros, False)
        segmented = self._segmented(trajectory, start, splice, before)
        index = bisect.bisect_left([plan[0] for plan in self._plans], start)
        del self._plans[index:]
        self._plans.append((start, segmented))
        return start

    def hold(self, positions: Sequence[float], now: float, keep_queued: bool = False) -> None:
        """Hold ``positions`` [rad] at rest from ``now`` [s], in place of the trajectories.

        With ``keep_queued``, the trajectories that start after ``now`` are kept (they were
        sent ahead, for the time to come); otherwise every one is dropped (a cancel).

        Raises
        ------
        TrajectoryError
            ``positions`` are not one finite value per joint; nothing changes.
        """
        trajectory = JointTrajectory.from_points(
            self.joints, self.joints, [0.0], [list(positions)], start=0.0)
        if not math.isfinite(now):
            raise TrajectoryError(f'hold time must be finite, got {now!r}')
        queued = [plan for plan in self._plans if plan[0] > now] if keep_queued else []
        self._plans.clear()
        self.set_trajectory(trajectory, now)
        self._plans.extend(queued)

    def sample(self, t: float) -> TrajectorySample | None:
        """Return the reference at clock time ``t`` [s]; None before any trajectory applies.

        Trajectories superseded before ``t`` are forgotten: the clock of the states only
        goes forward (a repeated stamp samples the same again).
        """
        return self._sample(t, prune=True)

    # ------------------------------------------------------------------ internals
    def _sample(self, t: float, prune: bool) -> TrajectorySample | None:
        plans = self._plans
        index = bisect.bisect_right([plan[0] for plan in plans], t) - 1
        if index < 0:
            return None
        if prune and index > 0:
            del plans[:index]
            index = 0
        return plans[index][1].sample(t)

    def _segmented(self, trajectory: JointTrajectory, start: float, splice: float,
                   before: TrajectorySample | None) -> _Segmented:
        """Points on the clock, with the reference at ``splice`` first when it comes before."""
        count, joints = trajectory.positions.shape
        times = start + trajectory.times
        zeros = np.zeros((count, joints))
        velocities = trajectory.velocities if trajectory.velocities is not None else zeros
        accelerations = trajectory.accelerations if trajectory.accelerations is not None \
            else zeros
        degree = 0 if trajectory.velocities is None else (
            1 if trajectory.accelerations is None else 2)
        order = np.full(count, degree)
        positions = trajectory.positions
        if times[-1] <= splice:
            # wholly in the past when received: its last point is held
            return _Segmented(np.array([splice]), positions[-1:], zeros[:1], zeros[:1],
                              np.array([degree]))
        if before is not None and times[0] > splice:
            times = np.concatenate(([splice], times))
            positions = np.vstack((before.positions, positions))
            velocities = np.vstack((before.velocities, velocities))
            accelerations = np.vstack((before.accelerations, accelerations))
            order = np.concatenate(([2], order))
        return _Segmented(times, positions, velocities, accelerations, order)
