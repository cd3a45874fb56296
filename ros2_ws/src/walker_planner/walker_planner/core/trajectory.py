"""The trajectory protocol every planner type follows, and small helpers shared by the types.

A trajectory is an object that knows its duration and can be sampled at any time for position,
velocity and acceleration (vectorised over time). Before ``t = 0`` it rests at its start, after
``t = duration`` at its goal. Joint-space trajectories are sampled in role order J1..J5 [rad];
Cartesian ones give the tip position in the base-gripper frame [m] (gripper vertical).
"""

from __future__ import annotations

import abc
import math
from typing import ClassVar, NamedTuple

import numpy as np

from walker_planner.core.errors import InvalidRequestError

__all__ = [
    'Samples', 'Trajectory', 'as_times', 'finite_vector', 'positive', 'JOINT', 'CARTESIAN',
]

JOINT = 'joint'
CARTESIAN = 'cartesian'


class Samples(NamedTuple):
    """Position, velocity and acceleration, each of shape ``(N, dim)`` (or ``(dim,)``)."""

    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray


class Trajectory(abc.ABC):
    """A trajectory of one of the planner's named types.

    Attributes
    ----------
    type_name : str
        The registry name of the type (``'joint_parabolic_time'``, ...).
    space : str
        ``'joint'`` (rad, role order J1..J5) or ``'cartesian'`` (tip position, m).
    """

    type_name: ClassVar[str] = ''
    space: ClassVar[str] = JOINT

    @property
    @abc.abstractmethod
    def duration(self) -> float:
        """Time from start to goal [s]."""

    @abc.abstractmethod
    def _sample(self, t: np.ndarray) -> Samples:
        """Sample at times ``t`` (1-D array, already clipped to ``[0, duration]``)."""

    def sample(self, t: float | np.ndarray) -> Samples:
        """Position, velocity and acceleration at time(s) ``t`` [s].

        Parameters
        ----------
        t : float or array_like
            Time(s) since the start [s]; values outside ``[0, duration]`` give the rest state
            at the start or the goal.

        Returns
        -------
        Samples
            Arrays of shape ``(dim,)`` for a scalar ``t``, ``(N, dim)`` for N times.
        """
        times, scalar = as_times(t)
        inside = np.clip(times, 0.0, self.duration)
        samples = self._sample(inside)
        outside = (times <= 0.0) | (times >= self.duration)
        if np.any(outside):
            velocity = samples.velocity.copy()
            acceleration = samples.acceleration.copy()
            velocity[outside] = 0.0
            acceleration[outside] = 0.0
            samples = Samples(samples.position, velocity, acceleration)
        if scalar:
            return Samples(*(array[0] for array in samples))
        return samples


def as_times(t: float | np.ndarray) -> tuple[np.ndarray, bool]:
    """Return ``t`` as a finite 1-D float array and whether it was a scalar."""
    times = np.asarray(t, dtype=float)
    scalar = times.ndim == 0
    times = np.atleast_1d(times)
    if times.ndim != 1:
        raise InvalidRequestError(f'sample times must be a scalar or 1-D, got shape {times.shape}')
    if not np.all(np.isfinite(times)):
        raise InvalidRequestError('sample times must be finite')
    return times, scalar


def finite_vector(values, length: int, what: str) -> np.ndarray:
    """Return ``values`` as ``length`` finite floats, or raise naming ``what``."""
    try:
        array = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise InvalidRequestError(f'{what} must be {length} numbers, got {values!r}') from None
    if array.shape != (length,):
        raise InvalidRequestError(f'{what} must have {length} values, got {array.size}')
    if not np.all(np.isfinite(array)):
        raise InvalidRequestError(f'{what} must be finite (NaN and infinity are refused), got '
                                  f'{array.tolist()}')
    return array


def positive(value: float, what: str, unit: str) -> float:
    """Return ``value`` if it is a finite positive number, else raise naming ``what``."""
    if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0.0):
        raise InvalidRequestError(f'{what} must be a finite positive number [{unit}], got '
                                  f'{value!r}')
    return float(value)
