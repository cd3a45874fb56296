"""Conversions between the planner core's arrays and ROS messages (no planning here)."""

from __future__ import annotations

import numpy as np
from builtin_interfaces.msg import Duration, Time
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_planner.core.chaining import chain
from walker_planner.core.planning import PlanRequest
from walker_planner.core.streaming import SampledTrajectory

__all__ = ['plan_request', 'to_duration', 'to_seconds', 'to_time', 'trajectory_message',
           'sampled_trajectory', 'chained_message']

_NANOSECONDS = 1_000_000_000


def to_duration(seconds: float) -> Duration:
    """``builtin_interfaces/Duration`` of a non-negative time [s], rounded to the nanosecond."""
    total = int(round(seconds * _NANOSECONDS))
    return Duration(sec=total // _NANOSECONDS, nanosec=total % _NANOSECONDS)


def to_seconds(duration: Duration) -> float:
    """Seconds of a ``builtin_interfaces/Duration``."""
    return duration.sec + duration.nanosec / _NANOSECONDS


def to_time(nanoseconds: int) -> Time:
    """``builtin_interfaces/Time`` of a clock time [ns]."""
    return Time(sec=int(nanoseconds) // _NANOSECONDS, nanosec=int(nanoseconds) % _NANOSECONDS)


def trajectory_message(times: np.ndarray, positions: np.ndarray, velocities: np.ndarray,
                       accelerations: np.ndarray, stamp: Time | None = None) -> JointTrajectory:
    """Build a ``trajectory_msgs/JointTrajectory`` of the five physical joints.

    Parameters
    ----------
    times : ndarray, shape (N,)
        Time from start of each point [s].
    positions, velocities, accelerations : ndarray, shape (N, 5)
        Physical joint order [rad, rad/s, rad/s^2].
    stamp : builtin_interfaces/Time, optional
        When the trajectory starts (zero: not scheduled).
    """
    message = JointTrajectory()
    if stamp is not None:
        message.header.stamp = stamp
    message.joint_names = list(PHYSICAL_JOINT_NAMES)
    message.points = [
        JointTrajectoryPoint(positions=p.tolist(), velocities=v.tolist(),
                             accelerations=a.tolist(), time_from_start=to_duration(t))
        for t, p, v, a in zip(times, positions, velocities, accelerations, strict=True)]
    return message


def sampled_trajectory(message: JointTrajectory, robot=None) -> SampledTrajectory:
    """Check a ``JointTrajectory`` and turn it into a :class:`SampledTrajectory`.

    Raises
    ------
    PlanningError
        Naming what is wrong (see :meth:`SampledTrajectory.from_points`).
    """
    points = message.points
    return SampledTrajectory.from_points(
        message.joint_names, [to_seconds(p.time_from_start) for p in points],
        [p.positions for p in points], [p.velocities for p in points],
        [p.accelerations for p in points], robot)


def chained_message(first: JointTrajectory, second: JointTrajectory,
                    lead: float) -> JointTrajectory:
    """One ``JointTrajectory`` of two, the second starting ``lead`` [s] before the first ends.

    See :func:`walker_planner.core.chaining.chain` (over the overlap the motions add).

    Raises
    ------
    PlanningError
        Naming what is wrong with either trajectory or with joining them.
    """
    joined = chain(sampled_trajectory(first), sampled_trajectory(second), lead)
    return trajectory_message(joined.times, joined.positions, joined.velocities,
                              joined.accelerations)


def plan_request(request) -> PlanRequest:
    """Return the planner core's request of a ``plan_trajectory`` request message."""
    return PlanRequest(
        trajectory_type=request.trajectory_type, base_gripper=request.base_gripper,
        start=tuple(request.start), goal=tuple(request.goal), duration=request.duration,
        max_velocity=request.max_velocity, max_acceleration=request.max_acceleration,
        start_joints=tuple(request.start_joints), min_radius=request.min_radius,
        sweep_direction=int(request.sweep_direction))


class JointStateReader:
    """The five physical joints' positions of ``sensor_msgs/JointState`` messages.

    The plant's name order is looked up once, and again only when it changes.
    """

    def __init__(self) -> None:
        self._names: tuple[str, ...] = ()
        self._index: list[int] = []

    def positions(self, message) -> tuple[int, np.ndarray] | None:
        """Return (stamp [ns], positions [rad] in physical order), or None.

        None when a physical joint is missing or a position is not finite.
        """
        names = tuple(message.name)
        if names != self._names:
            try:
                self._index = [names.index(name) for name in PHYSICAL_JOINT_NAMES]
            except ValueError:
                return None
            self._names = names
        try:
            positions = np.asarray(message.position, dtype=float)[self._index]
        except IndexError:
            return None
        if not np.all(np.isfinite(positions)):
            return None
        stamp = message.header.stamp
        return stamp.sec * 1_000_000_000 + stamp.nanosec, positions
