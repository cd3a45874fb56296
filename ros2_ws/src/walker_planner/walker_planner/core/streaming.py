"""Streaming a joint trajectory to the controllers: interpolation, validation, setpoint timing.

The planner node streams any ``trajectory_msgs/JointTrajectory`` (its own plans or an
operator's) at the control rate. Between the trajectory's points it interpolates each joint
like ros2_control's joint_trajectory_controller: quintic Hermite when the points carry
positions, velocities and accelerations, cubic with positions and velocities, linear with
positions only; at the points themselves the setpoints are the points exactly.

Timing: the stream runs on the plant's states. The trajectory's time 0 applies at
``start + period`` (``start`` is the stamp of the state the stream began on), and a setpoint
stamped ``t`` carries the trajectory's state at ``t``; the controllers use, for each state,
the newest setpoint stamped at or before it. At the state stamped ``now`` the stream sends
every setpoint not sent yet up to ``now + lookahead * period`` (:meth:`SetpointStream.due`):
with a lookahead of one period each is sent just in time, one period before it applies; with
more, the controllers hold the setpoints of the next few states before those states exist, so
in sim time, where the plant steps as soon as the controllers answer, the loop need not wait
for the planner's process every period (a pipeline, not a round trip), and in real time a late
planner is a late setpoint less often. The motion is the same either way: every setpoint is
stamped with the time it applies. All clock times are integer nanoseconds, as on the wire, so
nothing drifts.
"""

from __future__ import annotations

import bisect
import dataclasses
import functools
import math
from typing import NamedTuple

import numpy as np

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_planner.core.errors import InvalidRequestError, LimitError
from walker_planner.core.trajectory import Samples, as_times

__all__ = ['SampledTrajectory', 'Setpoint', 'SetpointStream', 'check_start', 'stamps_due']

_NANOSECONDS = 1_000_000_000


@dataclasses.dataclass(frozen=True)
class SampledTrajectory:
    """A joint trajectory given by points, physical joint order, interpolated between them.

    Attributes
    ----------
    times : ndarray, shape (N,)
        Times from the start [s], strictly increasing, the first >= 0.
    positions : ndarray, shape (N, 5)
        Joint angles [rad], physical order (``a_yaw_joint`` .. ``b_yaw_joint``).
    velocities, accelerations : ndarray, shape (N, 5), or None
        Joint rates [rad/s], [rad/s^2]; ``None`` when the points do not carry them.
    """

    times: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray | None = None
    accelerations: np.ndarray | None = None

    @classmethod
    def from_points(cls, joint_names, times, positions, velocities=(), accelerations=(),
                    robot=None) -> 'SampledTrajectory':
        """Check a trajectory as it arrives and reorder it to the physical joint order.

        Parameters
        ----------
        joint_names : sequence of str
            The five physical joint names, in any order.
        times : sequence of float
            Time from start of each point [s].
        positions, velocities, accelerations : sequence of sequences of float
            Per point, one value per joint name; velocities and accelerations may be empty
            (for every point) or given for every point.
        robot : WalkerParameters, optional
            When given, positions must be within each joint's limits and velocities within
            its velocity limit.

        Raises
        ------
        InvalidRequestError
            Unknown or missing joint names, no points, times not increasing, wrong lengths,
            NaN or infinity.
        LimitError
            A point outside a joint's position or velocity limits.
        """
        names = list(joint_names)
        if sorted(names) != sorted(PHYSICAL_JOINT_NAMES):
            raise InvalidRequestError(
                f'joint_names must be the five joints {", ".join(PHYSICAL_JOINT_NAMES)} '
                f'(any order), got {names}')
        order = [names.index(name) for name in PHYSICAL_JOINT_NAMES]
        times = np.asarray(times, dtype=float)
        if times.ndim != 1 or times.size == 0:
            raise InvalidRequestError('the trajectory has no points')
        if not np.all(np.isfinite(times)) or times[0] < 0.0 or np.any(np.diff(times) <= 0.0):
            raise InvalidRequestError(
                'time_from_start must be finite, non-negative and strictly increasing')
        arrays = []
        for what, values, required in (('positions', positions, True),
                                       ('velocities', velocities, False),
                                       ('accelerations', accelerations, False)):
            rows = [list(row) for row in values]
            if not required and all(len(row) == 0 for row in rows):
                arrays.append(None)
                continue
            if len(rows) != times.size or any(len(row) != 5 for row in rows):
                raise InvalidRequestError(
                    f'every point needs 5 {what} (one per joint name)'
                    + ('' if required else ', or none at all'))
            array = np.asarray(rows, dtype=float)[:, order]
            if not np.all(np.isfinite(array)):
                raise InvalidRequestError(f'{what} must be finite (NaN and infinity are refused)')
            arrays.append(array)
        trajectory = cls(times, *arrays)
        if robot is not None:
            trajectory.check_limits(robot)
        return trajectory

    def check_limits(self, robot) -> None:
        """Raise :class:`LimitError` naming a joint whose positions or speeds break its limits."""
        drive = robot.robot.drive
        # physical order is role order with gripper a as base
        lower, upper = drive.role_array('position_min'), drive.role_array('position_max')
        speed = drive.role_array('velocity_limit')
        for j, name in enumerate(PHYSICAL_JOINT_NAMES):
            low, high = self.positions[:, j].min(), self.positions[:, j].max()
            if low < lower[j] or high > upper[j]:
                raise LimitError(f'{name} goes to [{low:.4f}, {high:.4f}] rad, outside its '
                                 f'limits [{lower[j]:.4f}, {upper[j]:.4f}] rad')
            if self.velocities is not None:
                fastest = float(np.max(np.abs(self.velocities[:, j])))
                if fastest > speed[j] * (1.0 + 1e-9):
                    raise LimitError(f'{name} moves at {fastest:.4g} rad/s, above its velocity '
                                     f'limit {speed[j]:.4g} rad/s')

    @property
    def duration(self) -> float:
        """Time of the last point [s]."""
        return float(self.times[-1])

    def sample(self, t: float | np.ndarray) -> Samples:
        """Interpolated positions, velocities, accelerations at ``t`` [s], physical order.

        Before the first point the trajectory holds the first point's position, after the last
        the last's, at rest. A scalar ``t`` (the stream's one sample per control period) takes
        a path without array bookkeeping; both evaluate the same segment polynomials.
        """
        if isinstance(t, (int, float)) and math.isfinite(t):
            return self._sample_one(float(t))
        times, scalar = as_times(t)
        knots = self.times
        clipped = np.clip(times, knots[0], knots[-1])
        index = np.clip(np.searchsorted(knots, clipped, side='right') - 1, 0,
                        max(len(knots) - 2, 0))
        if len(knots) == 1:
            position = np.repeat(self.positions[:1], len(times), axis=0)
            zeros = np.zeros_like(position)
            result = Samples(position, zeros, zeros.copy())
        else:
            result = self._hermite(index, clipped)
        outside = (times <= knots[0]) | (times >= knots[-1])
        if np.any(outside):
            result.velocity[outside] = 0.0
            result.acceleration[outside] = 0.0
            result.position[outside] = np.where(times[outside, None] <= knots[0],
                                                self.positions[0], self.positions[-1])
        if scalar:
            return Samples(*(array[0] for array in result))
        return result

    def _sample_one(self, t: float) -> Samples:
        knots = self._knots
        if t <= knots[0] or t >= knots[-1] or len(knots) == 1:
            zeros = np.zeros(self.positions.shape[1])
            held = self.positions[0] if t <= knots[0] else self.positions[-1]
            return Samples(held.copy(), zeros, zeros.copy())
        i = bisect.bisect_right(knots, t) - 1
        h = knots[i + 1] - knots[i]
        x = (t - knots[i]) / h
        x2 = x * x
        coefficients = self._segments[i]
        return Samples(np.array([1.0, x, x2, x2 * x, x2 * x2, x2 * x2 * x]) @ coefficients,
                       np.array([0.0, 1.0, 2.0 * x, 3.0 * x2, 4.0 * x2 * x, 5.0 * x2 * x2])
                       @ coefficients / h,
                       np.array([0.0, 0.0, 2.0, 6.0 * x, 12.0 * x2, 20.0 * x2 * x])
                       @ coefficients / (h * h))

    @functools.cached_property
    def _knots(self) -> list[float]:
        return [float(t) for t in self.times]

    @functools.cached_property
    def _segments(self) -> np.ndarray:
        """Coefficients ``c0..c5`` of each segment's polynomial in ``x`` in [0, 1], (N-1, 6, 5).

        Quintic Hermite with positions, velocities and accelerations; cubic with positions and
        velocities; linear with positions only (ros2_control's joint_trajectory_controller).
        """
        h = np.diff(self.times)[:, None]
        p0, p1 = self.positions[:-1], self.positions[1:]
        d = p1 - p0
        zero = np.zeros_like(p0)
        if self.velocities is None:
            c = [p0, d, zero, zero, zero, zero]
        else:
            v0, v1 = self.velocities[:-1] * h, self.velocities[1:] * h
            if self.accelerations is None:
                c = [p0, v0, 3.0 * d - 2.0 * v0 - v1, -2.0 * d + v0 + v1, zero, zero]
            else:
                a0 = self.accelerations[:-1] * h * h
                a1 = self.accelerations[1:] * h * h
                c = [p0, v0, 0.5 * a0,
                     10.0 * d - 6.0 * v0 - 4.0 * v1 - 1.5 * a0 + 0.5 * a1,
                     -15.0 * d + 8.0 * v0 + 7.0 * v1 + 1.5 * a0 - a1,
                     6.0 * d - 3.0 * (v0 + v1) - 0.5 * (a0 - a1)]
        return np.stack(c, axis=1)

    def _hermite(self, index: np.ndarray, t: np.ndarray) -> Samples:
        h = (self.times[index + 1] - self.times[index])[:, None]
        x = ((t - self.times[index]) / h[:, 0])[:, None]
        c = [self._segments[index, k] for k in range(6)]
        position = c[0] + x * (c[1] + x * (c[2] + x * (c[3] + x * (c[4] + x * c[5]))))
        rate = c[1] + x * (2.0 * c[2] + x * (3.0 * c[3] + x * (4.0 * c[4] + x * 5.0 * c[5])))
        curvature = 2.0 * c[2] + x * (6.0 * c[3] + x * (12.0 * c[4] + x * 20.0 * c[5]))
        return Samples(position, rate / h, curvature / (h * h))


class Setpoint(NamedTuple):
    """One tick of a stream: what to send to the five controllers.

    Attributes
    ----------
    stamp : int
        Clock time the setpoint applies [ns] (one control period after it was computed).
    time_from_start : float
        Trajectory time of the setpoint [s].
    position, velocity, acceleration : ndarray, shape (5,)
        Physical joint order [rad, rad/s, rad/s^2].
    final : bool
        The trajectory's end: the stream is complete once this is sent.
    """

    stamp: int
    time_from_start: float
    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    final: bool


class SetpointStream:
    """The timing of one stream (see the module notes).

    Parameters
    ----------
    trajectory : SampledTrajectory
        What to stream.
    start : int
        Clock time the stream begins [ns]; the trajectory's time 0 applies at
        ``start + period``.
    period : int
        Control period [ns].
    """

    def __init__(self, trajectory: SampledTrajectory, start: int, period: int) -> None:
        self.trajectory = trajectory
        self.start = int(start)
        self.period = int(period)

    @property
    def origin(self) -> int:
        """Clock time [ns] at which the trajectory's time 0 applies."""
        return self.start + self.period

    @property
    def end_stamp(self) -> int:
        """Clock time [ns] of the final setpoint: the trajectory's end on the clock.

        The first of the stream's stamps (``start + k * period``, k >= 1) at which the
        trajectory's time reaches its duration, as :meth:`setpoint_at` marks it ``final``.
        """
        duration = self.trajectory.duration
        periods = max(0, math.ceil(duration * _NANOSECONDS / self.period))
        stamp = self.origin + periods * self.period
        while stamp > self.origin and self.trajectory_time(stamp - self.period) >= duration:
            stamp -= self.period
        while self.trajectory_time(stamp) < duration:
            stamp += self.period
        return stamp

    def trajectory_time(self, stamp: int) -> float:
        """Trajectory time [s] of a clock time [ns]."""
        return (int(stamp) - self.origin) / _NANOSECONDS

    def setpoint(self, now: int) -> Setpoint:
        """Setpoint that applies one period after clock time ``now`` [ns]."""
        return self.setpoint_at(int(now) + self.period)

    def setpoint_at(self, stamp: int) -> Setpoint:
        """Setpoint that applies at clock time ``stamp`` [ns] (the end's, after the end)."""
        stamp = int(stamp)
        elapsed = max(self.trajectory_time(stamp), 0.0)
        final = elapsed >= self.trajectory.duration
        elapsed = min(elapsed, self.trajectory.duration)
        sample = self.trajectory.sample(elapsed)
        return Setpoint(stamp, elapsed, sample.position, sample.velocity, sample.acceleration,
                        final)

    def due(self, now: int, sent: Setpoint | None, lookahead: int) -> list[Setpoint]:
        """Setpoints to send at the state stamped ``now`` [ns], in stamp order.

        Those not sent yet (after ``sent``, the last one sent; None: none yet), from one
        period after ``now`` (earlier ones would apply to states already answered) up to
        ``now + lookahead * period``, ending with the final one.

        Raises
        ------
        ValueError
            If ``lookahead`` is not a whole number of periods >= 1.
        """
        stamps = stamps_due(now, None if sent is None else sent.stamp, self.period, lookahead)
        if sent is not None and sent.final:
            return []
        due = []
        for stamp in stamps:
            due.append(self.setpoint_at(stamp))
            if due[-1].final:
                break
        return due

    def hold(self, now: int, last: Setpoint | None) -> Setpoint:
        """Setpoint that stops at the last position sent, at rest (after a cancel).

        It applies one period after ``now`` [ns], or after ``last`` when that was sent further
        ahead: the setpoints already sent are followed first (at most the lookahead), so the
        stop is where they end, not a jump back. With ``now`` past ``last`` (the clock of
        controllers that hold the whole trajectory ran on past the states heard here), it stops
        where the trajectory is at ``now``, not back where ``last`` was.
        """
        if last is None or int(now) > last.stamp:
            last = self.setpoint_at(max(int(now), self.origin))
        zeros = np.zeros(5)
        stamp = max(int(now), last.stamp) + self.period
        return Setpoint(stamp, last.time_from_start, last.position, zeros, zeros, True)

    def tracking_error(self, stamp: int, measured: np.ndarray) -> float:
        """Largest ``|desired - measured|`` [rad] of a state stamped ``stamp`` [ns]."""
        desired = self.trajectory.sample(max(self.trajectory_time(stamp), 0.0)).position
        return float(np.max(np.abs(desired - np.asarray(measured, dtype=float))))


def stamps_due(now: int, sent: int | None, period: int, lookahead: int) -> range:
    """Stamps [ns] of the setpoints to send at the state stamped ``now`` [ns].

    Every period after ``sent`` (the stamp of the last one sent; None: none yet), from one
    period after ``now`` (earlier ones would apply to states already answered) up to
    ``now + lookahead * period``: a stream's setpoints and the holds after it alike.

    Raises
    ------
    ValueError
        If ``lookahead`` is not a whole number of periods >= 1.
    """
    if isinstance(lookahead, bool) or not isinstance(lookahead, int) or lookahead < 1:
        raise ValueError(f'lookahead must be a whole number of periods >= 1, got '
                         f'{lookahead!r}')
    first = int(now) + period
    if sent is not None:
        first = max(first, int(sent) + period)
    return range(first, int(now) + lookahead * period + 1, period)


def check_start(trajectory: SampledTrajectory, measured: np.ndarray | None, tolerance: float
                ) -> None:
    """Refuse a stream whose first point is not where the robot is.

    Raises
    ------
    LimitError
        No measurement yet, or a measured joint farther than ``tolerance`` [rad] from the
        trajectory's first point (the message names it).
    """
    if measured is None:
        raise LimitError('no joint_states received yet: cannot check that the trajectory '
                         'starts where the robot is')
    miss = np.abs(trajectory.positions[0] - np.asarray(measured, dtype=float))
    worst = int(np.argmax(miss))
    if miss[worst] > tolerance:
        raise LimitError(
            f'the trajectory starts {miss[worst]:.4f} rad away from the measured '
            f'{PHYSICAL_JOINT_NAMES[worst]} (planner.stream.start_tolerance is {tolerance:.4f} '
            f'rad): plan from the current joint states')
