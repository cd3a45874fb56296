"""Straight segments in joint space or Cartesian space, followed with a time scaling.

``q(t) = start + s(t) (goal - start)``: the path is a straight line (in joint space: every joint
starts and stops together; in Cartesian space: the tip moves on the segment), and its timing is
one of the scalings of :mod:`walker_planner.core.profiles`.
"""

from __future__ import annotations

import numpy as np

from walker_planner.core.profiles import ScalarProfile
from walker_planner.core.trajectory import CARTESIAN, JOINT, Samples, Trajectory

__all__ = ['Segment', 'JointSegment', 'CartesianSegment']


class Segment(Trajectory):
    """A straight segment from ``start_point`` to ``end_point`` timed by ``profile``.

    Parameters
    ----------
    type_name : str
        The registry name of the type this segment implements.
    start_point, end_point : array_like
        Joint angles J1..J5 [rad] (joint space) or tip positions X, Y, Z [m] (Cartesian).
    profile : ScalarProfile
        The time scaling ``s(t)``.
    """

    def __init__(self, type_name: str, start_point, end_point, profile: ScalarProfile) -> None:
        self.type_name = type_name
        self.start_point = np.asarray(start_point, dtype=float)
        self.end_point = np.asarray(end_point, dtype=float)
        self.profile = profile

    @property
    def duration(self) -> float:
        """Duration of the scaling [s]."""
        return self.profile.duration

    @property
    def displacement(self) -> np.ndarray:
        """``end_point - start_point``."""
        return self.end_point - self.start_point

    def _sample(self, t: np.ndarray) -> Samples:
        s, sd, sdd = self.profile.evaluate(t)
        delta = self.displacement
        return Samples(self.start_point + s[:, None] * delta, sd[:, None] * delta,
                       sdd[:, None] * delta)


class JointSegment(Segment):
    """A straight line in joint space (role order J1..J5, rad)."""

    space = JOINT


class CartesianSegment(Segment):
    """A straight line of the tip in the base-gripper frame (m), gripper vertical."""

    space = CARTESIAN
