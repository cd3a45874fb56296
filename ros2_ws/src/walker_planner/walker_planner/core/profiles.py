"""Time scalings ``s(t)`` from 0 to 1: parabolic blend, minimum jerk and constant velocity.

Every path type of the planner is a geometric path (a joint-space segment, a Cartesian segment)
followed with one of these scalings; the scaling's limits are those of the path divided by its
length, so a limit on ``ds/dt`` of ``v / length`` is a speed limit of ``v`` along the path.

All times are in s, ``s`` is dimensionless, its rates in 1/s and 1/s^2.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from walker_planner.core.errors import LimitError

__all__ = ['ScalarProfile', 'BlendProfile', 'MinJerkProfile', 'ConstantVelocityProfile',
           'MIN_JERK_PEAK_RATE', 'MIN_JERK_PEAK_ACCELERATION']

#: Peak of ds/dt times T for the quintic 10 x^3 - 15 x^4 + 6 x^5 (at x = 1/2).
MIN_JERK_PEAK_RATE = 1.875
#: Peak of |d2s/dt2| times T^2 for the same quintic (at x = 1/2 -+ sqrt(3)/6): 10 / sqrt(3).
MIN_JERK_PEAK_ACCELERATION = 10.0 / math.sqrt(3.0)


class ScalarProfile:
    """A time scaling: ``duration`` [s] and ``evaluate(t) -> (s, ds/dt, d2s/dt2)``."""

    duration: float

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return ``s``, ``ds/dt`` [1/s] and ``d2s/dt2`` [1/s^2] at times ``t`` in [0, T]."""
        raise NotImplementedError

    @property
    def peak_rate(self) -> float:
        """Largest ``|ds/dt|`` [1/s]."""
        raise NotImplementedError

    @property
    def peak_acceleration(self) -> float:
        """Largest ``|d2s/dt2|`` [1/s^2]."""
        raise NotImplementedError


@dataclasses.dataclass(frozen=True)
class BlendProfile(ScalarProfile):
    """Linear segment with parabolic blends (trapezoidal rate, or triangular without cruise).

    Parameters
    ----------
    duration : float
        Total time T [s].
    blend_time : float
        Duration of each parabolic blend, ``0 < tb <= T/2`` [s].

    Notes
    -----
    With ``a`` the blend acceleration and ``V = a tb`` the cruise rate, ``s(T) = 1`` requires
    ``V (T - tb) = 1``. Two constructors give the paper's two ways of specifying a parabolic
    trajectory (section 5): :meth:`by_time` (settling time) and :meth:`by_acceleration`.
    """

    duration: float
    blend_time: float

    @property
    def cruise_rate(self) -> float:
        """Rate ``ds/dt`` on the linear segment [1/s]."""
        return 1.0 / (self.duration - self.blend_time)

    @property
    def acceleration(self) -> float:
        """Blend acceleration ``d2s/dt2`` [1/s^2]."""
        return self.cruise_rate / self.blend_time

    @property
    def peak_rate(self) -> float:
        """Largest ``ds/dt`` [1/s]: the cruise rate."""
        return self.cruise_rate

    @property
    def peak_acceleration(self) -> float:
        """Largest ``|d2s/dt2|`` [1/s^2]: the blend acceleration."""
        return self.acceleration

    @classmethod
    def by_acceleration(cls, max_rate: float, max_acceleration: float) -> 'BlendProfile':
        """Fastest blend under a rate and an acceleration limit.

        Parameters
        ----------
        max_rate : float
            Limit on ``ds/dt`` [1/s].
        max_acceleration : float
            Acceleration of the blends, ``d2s/dt2`` [1/s^2].

        Returns
        -------
        BlendProfile
            Triangular (``T = 2 sqrt(1/a)``) when the rate limit is not reached, else
            trapezoidal with ``tb = V/a`` and ``T = 1/V + V/a``.
        """
        if max_rate * max_rate >= max_acceleration:
            blend = math.sqrt(1.0 / max_acceleration)
            return cls(2.0 * blend, blend)
        blend = max_rate / max_acceleration
        return cls(1.0 / max_rate + blend, blend)

    @classmethod
    def by_time(cls, duration: float, max_rate: float, max_acceleration: float
                ) -> 'BlendProfile':
        """Blend that settles in ``duration`` with the least acceleration the rate limit allows.

        Parameters
        ----------
        duration : float
            Settling time T [s].
        max_rate, max_acceleration : float
            Limits on ``ds/dt`` [1/s] and ``d2s/dt2`` [1/s^2].

        Returns
        -------
        BlendProfile
            Triangular (``a = 4/T^2``) when its peak rate ``2/T`` is within the limit, else
            cruising at the rate limit ``V`` with ``tb = T - 1/V``.

        Raises
        ------
        LimitError
            If T is too short for the limits; the message gives the shortest possible T.
        """
        shortest = cls.by_acceleration(max_rate, max_acceleration).duration
        if duration < shortest * (1.0 - 1e-12):
            raise LimitError(
                f'settling time {duration:.4g} s is too short for the limits: the shortest '
                f'parabolic blend takes {shortest:.4g} s')
        if 2.0 / duration <= max_rate:
            return cls(duration, 0.5 * duration)
        return cls(duration, min(0.5 * duration, duration - 1.0 / max_rate))

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return ``s``, ``ds/dt`` and ``d2s/dt2`` at times ``t`` in [0, T]."""
        t = np.asarray(t, dtype=float)
        total, blend, accel = self.duration, self.blend_time, self.acceleration
        rate = self.cruise_rate
        rising, falling = t < blend, t > total - blend
        remaining = total - t
        s = np.where(rising, 0.5 * accel * t * t,
                     np.where(falling, 1.0 - 0.5 * accel * remaining * remaining,
                              0.5 * accel * blend * blend + rate * (t - blend)))
        sd = np.where(rising, accel * t, np.where(falling, accel * remaining, rate))
        sdd = np.where(rising, accel, np.where(falling, -accel, 0.0))
        return s, sd, sdd


@dataclasses.dataclass(frozen=True)
class MinJerkProfile(ScalarProfile):
    """Quintic ``s = 10 x^3 - 15 x^4 + 6 x^5``, ``x = t/T``: rest to rest, minimum jerk.

    Velocity and acceleration are continuous and zero at both ends, so it excites the flexible
    links least of the time scalings.
    """

    duration: float

    @classmethod
    def by_limits(cls, max_rate: float, max_acceleration: float) -> 'MinJerkProfile':
        """Shortest quintic with ``|ds/dt| <= max_rate`` and ``|d2s/dt2| <= max_acceleration``."""
        return cls(max(MIN_JERK_PEAK_RATE / max_rate,
                       math.sqrt(MIN_JERK_PEAK_ACCELERATION / max_acceleration)))

    @property
    def peak_rate(self) -> float:
        """Largest ``ds/dt`` [1/s]: ``1.875 / T``."""
        return MIN_JERK_PEAK_RATE / self.duration

    @property
    def peak_acceleration(self) -> float:
        """Largest ``|d2s/dt2|`` [1/s^2]: ``(10/sqrt(3)) / T^2``."""
        return MIN_JERK_PEAK_ACCELERATION / self.duration ** 2

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return ``s``, ``ds/dt`` and ``d2s/dt2`` at times ``t`` in [0, T]."""
        total = self.duration
        x = np.asarray(t, dtype=float) / total
        s = x ** 3 * (10.0 + x * (-15.0 + 6.0 * x))
        sd = 30.0 * x * x * (1.0 - x) ** 2 / total
        sdd = 60.0 * x * (1.0 - x) * (1.0 - 2.0 * x) / total ** 2
        return s, sd, sdd


@dataclasses.dataclass(frozen=True)
class ConstantVelocityProfile(ScalarProfile):
    """``s = t/T``: constant rate, with a step of the rate at both ends (the paper's fine motion).

    The acceleration is zero throughout (the steps are not fed forward); the trajectory rests
    at ``t <= 0`` and ``t >= T``.
    """

    duration: float

    @property
    def peak_rate(self) -> float:
        """Rate ``ds/dt = 1/T`` [1/s]."""
        return 1.0 / self.duration

    @property
    def peak_acceleration(self) -> float:
        """Zero: the rate steps at the ends are not accelerations that can be fed forward."""
        return 0.0

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return ``s``, ``ds/dt`` and ``d2s/dt2`` at times ``t`` in [0, T]."""
        t = np.asarray(t, dtype=float)
        rate = np.full_like(t, 1.0 / self.duration)
        return t / self.duration, rate, np.zeros_like(t)


def check_limit(value: float, limit: float, what: str, unit: str) -> None:
    """Raise :class:`LimitError` if ``value`` exceeds ``limit`` (with a relative slack of 1e-9)."""
    if value > limit * (1.0 + 1e-9):
        raise LimitError(f'{what} {value:.4g} {unit} exceeds the limit {limit:.4g} {unit}')
