"""Bang-coast-bang sweep: the node-to-node rotation when the yaw rate limit binds.

The paper's bang-bang profile (section 5) switches the torques once per half sweep; it has no
coast. When the J1/J5 rate limit, not the torque, sets its time scale, the fastest bang-bang
motion is the pure rotation ``rho = rho(0)`` scaled in time until its peak rate is the cap:
a triangle of ``Theta'`` that uses a fraction of ``tau_ref`` (3.4 of 6.8 N*m for 90 deg on the
default robot) and takes ``2 S / v`` for a sweep ``S`` at cap ``v``. Accelerating at
``tau_ref`` and coasting at the cap takes ``S / v + v / a`` instead: the time-optimal
rest-to-rest motion under a rate and an acceleration limit (2.21 s -> 1.80 s at 90 deg,
4.41 s -> 2.90 s at 180 deg on the default robot).

The tip stays on the circle of the start radius (no radial motion, so no J3 torque), as in
the rate-bound bang-bang plan. ``Theta''`` is ``+-a`` during the two acceleration phases and 0
while coasting, with ``a <= tau_ref / (m r^2)`` (eq (19) with ``r' = 0``: ``tau1 = m r^2
Theta''``).

Each acceleration phase lasts a whole number of periods of the joint-1 structural mode
(``robot.flexibility.joint1_mode``): a constant acceleration over ``k`` whole periods leaves an
undamped mode with no residual vibration (the pulse's spectrum is zero at ``2 pi k / t_a``),
so the acceleration is lowered until the phase lasts the next whole number of periods. The
command filters attenuate that mode already; this makes the plan itself leave none.

On as shipped (``planner.bang_bang.coast``): it walks 7 % faster in sim time and 22 % in real
time than the paper's triangle on the plant rooted at its base gripper (docs/planner.md).
On the earlier free-floating plant it did not: joint 1 ran on past the cruise rate when the
feed-forward dropped from the acceleration torque to the friction, and stopped short in its
friction in the deceleration.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from walker_planner.core.node_to_node import SWEEP_TYPE_NAME, PlanarModel, polar_samples
from walker_planner.core.trajectory import CARTESIAN, Samples, Trajectory

__all__ = ['CoastingSweep', 'coasting_sweep']


@dataclasses.dataclass(frozen=True)
class CoastingSweep(Trajectory):
    """A rest-to-rest rotation of the tip about the base yaw axis, accelerating and coasting.

    Parameters
    ----------
    radius : float
        Distance of the tip from the base yaw axis [m], constant.
    height : float
        Height ``Z`` of the tip above the base contact point [m].
    theta_start : float
        ``Theta`` (J1) at the start [rad].
    direction : int
        +1 counter-clockwise (seen from above), -1 clockwise.
    sweep : float
        Angle turned [rad], > 0.
    rate : float
        Largest ``|Theta'|`` [rad/s] (the coast, when there is one).
    acceleration : float
        ``|Theta''|`` [rad/s^2] of the acceleration and deceleration phases.
    """

    type_name = SWEEP_TYPE_NAME
    space = CARTESIAN

    radius: float
    height: float
    theta_start: float
    direction: int
    sweep: float
    rate: float
    acceleration: float

    def __post_init__(self) -> None:
        for name in ('radius', 'sweep', 'rate', 'acceleration'):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f'{name} must be positive and finite, got {value!r}')
        if self.direction not in (1, -1):
            raise ValueError(f'direction must be +1 or -1, got {self.direction!r}')

    @property
    def peak_rate(self) -> float:
        """``|Theta'|`` reached [rad/s]: the rate, or less if the sweep is too short to coast."""
        return min(self.rate, math.sqrt(self.sweep * self.acceleration))

    @property
    def acceleration_time(self) -> float:
        """Duration [s] of each acceleration phase."""
        return self.peak_rate / self.acceleration

    @property
    def coast_time(self) -> float:
        """Duration [s] of the coast at the peak rate (0 for a triangle)."""
        return max(0.0, self.sweep / self.peak_rate - self.acceleration_time)

    @property
    def duration(self) -> float:
        """Duration [s]."""
        return 2.0 * self.acceleration_time + self.coast_time

    def polar(self, t: np.ndarray) -> tuple[np.ndarray, ...]:
        """``r, r', r'', Theta, Theta', Theta''`` (m, s, rad) at times t."""
        t = np.clip(np.asarray(t, dtype=float), 0.0, self.duration)
        a, v, ta, tc = self.acceleration, self.peak_rate, self.acceleration_time, self.coast_time
        braking = t - ta - tc  # time into the deceleration
        angle = np.where(t <= ta, 0.5 * a * t ** 2,
                         np.where(braking <= 0.0, 0.5 * a * ta ** 2 + v * (t - ta),
                                  self.sweep - 0.5 * a * (ta - braking) ** 2))
        rate = np.where(t <= ta, a * t, np.where(braking <= 0.0, v, a * (ta - braking)))
        accel = np.where(t < ta, a, np.where(braking <= 0.0, 0.0, -a))
        accel = np.where((t <= 0.0) | (t >= self.duration), 0.0, accel)
        d = float(self.direction)
        zeros = np.zeros_like(t)
        return (np.full_like(t, self.radius), zeros, zeros, self.theta_start + d * angle,
                d * rate, d * accel)

    def _sample(self, t: np.ndarray) -> Samples:
        return polar_samples(*self.polar(t), self.height)


def coasting_sweep(model: PlanarModel, radius: float, height: float, theta_start: float,
                   direction: int, sweep: float, mode_frequency: float = 0.0) -> CoastingSweep:
    """Build the bang-coast-bang rotation at the model's yaw rate cap and circular torque.

    Parameters
    ----------
    model : PlanarModel
        Tip mass, ``tau_ref`` of J1 (``circular_torque``) and the yaw rate cap (``yaw_rate``).
    radius, height, theta_start, direction, sweep
        As :class:`CoastingSweep`.
    mode_frequency : float
        Structural mode [rad/s] whose period each acceleration phase is a whole number of
        (0: none; the acceleration is then ``tau_ref / (m r^2)``).

    Raises
    ------
    ValueError
        A non-positive radius or sweep, or a model without a finite rate cap.
    """
    if not (math.isfinite(model.yaw_rate) and model.yaw_rate > 0.0):
        raise ValueError(f'a coasting sweep needs a finite yaw rate cap, got {model.yaw_rate!r}')
    if not radius > 0.0:
        raise ValueError(f'radius must be positive, got {radius!r}')
    acceleration = model.circular_torque / (model.tip_mass * radius ** 2)
    trajectory = CoastingSweep(radius, height, theta_start, direction, abs(sweep),
                               model.yaw_rate, acceleration)
    if mode_frequency > 0.0:
        period = 2.0 * math.pi / mode_frequency
        phase = math.ceil(trajectory.acceleration_time / period - 1e-9) * period
        if abs(sweep) >= model.yaw_rate * phase:  # still coasting at the cap
            acceleration = model.yaw_rate / phase
        else:  # a triangle whose two halves last the whole periods
            acceleration = abs(sweep) / phase ** 2
        trajectory = dataclasses.replace(trajectory, acceleration=acceleration)
    return trajectory
