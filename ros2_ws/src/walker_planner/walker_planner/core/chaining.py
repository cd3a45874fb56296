"""Two motions streamed as one, the second starting before the first has ended.

A step's lift and its sweep: joint 1's reference filter (a fourth-order Bessel at 5 rad/s)
holds the sweep's first tenths of a second back, so its setpoints can begin while the gripper
is still rising. Over the overlap every joint moves by the sum of the two motions.
"""

from __future__ import annotations

import numpy as np

from walker_planner.core.errors import InvalidRequestError
from walker_planner.core.streaming import SampledTrajectory

__all__ = ['chain']

_NANOSECONDS = 1_000_000_000


def chain(first: SampledTrajectory, second: SampledTrajectory, lead: float,
          tolerance: float = 1e-6) -> SampledTrajectory:
    """Join ``second`` to ``first``, its motion starting ``lead`` [s] before ``first`` ends.

    With ``t0 = T1 - lead`` (``T1`` the first's duration), the joined trajectory is

    ``q(t) = q1(t) + q2(t - t0) - q2(0)``

    where each motion holds its first point before it starts and its last after it ends, so
    that it is ``first`` up to ``t0``, ``second`` shifted by ``t0`` after ``T1``, and their
    sum in between; velocities and accelerations add the same way. Its points are those of
    both (the second's moved by ``t0``), where the sum is exact; it lasts
    ``T1 + T2 - lead``.

    Parameters
    ----------
    first, second : SampledTrajectory
        Physical joint order, both with velocities and accelerations (quintic segments).
    lead : float
        Overlap [s], from 0 up to the shorter of the two durations.
    tolerance : float
        Largest joint distance [rad] between the first's last point and the second's first:
        the motions must meet.

    Returns
    -------
    SampledTrajectory

    Raises
    ------
    InvalidRequestError
        Naming what is wrong: a lead out of range, motions that do not meet, or a motion
        without velocities or accelerations.
    """
    for name, motion in (('first', first), ('second', second)):
        if motion.velocities is None or motion.accelerations is None:
            raise InvalidRequestError(f'the {name} motion has no velocities or accelerations: '
                                      f'only quintic segments are joined')
    if not 0.0 <= lead <= min(first.duration, second.duration):
        raise InvalidRequestError(
            f'a lead of {lead:g} s is outside [0, {min(first.duration, second.duration):g}] s '
            f'(the shorter motion)')
    gap = float(np.max(np.abs(second.positions[0] - first.positions[-1])))
    if gap > tolerance:
        raise InvalidRequestError(f'the second motion starts {gap:.3g} rad from where the first '
                                  f'ends (at most {tolerance:g} rad)')
    start = first.duration - lead
    # both sets of points, on the nanosecond (what the wire carries): no near-duplicates
    stamps = np.unique(np.round(np.concatenate([first.times, second.times + start])
                                * _NANOSECONDS).astype(np.int64))
    times = stamps / _NANOSECONDS
    one, two = first.sample(times), second.sample(times - start)
    return SampledTrajectory(times, one.position + two.position - second.positions[0],
                             one.velocity + two.velocity,
                             one.acceleration + two.acceleration)
