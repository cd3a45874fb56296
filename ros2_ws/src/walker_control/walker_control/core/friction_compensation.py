"""Friction compensator: a constant torque whose sign follows the position error (section 3).

The paper adds "an additional torque to overcome the significant joint friction, ... a positive
or negative value ... based on the position error sign". A pure sign function chatters at
rest, where the error dithers about zero. This compensator is instead zero inside a deadband
around zero error and rises linearly over a ramp to its full level::

    tau_f(e) = 0                                        |e| <= deadband
             = level sign(e) (|e| - deadband) / ramp     deadband < |e| < deadband + ramp
             = level sign(e)                            |e| >= deadband + ramp

A ramp rather than a relay with hysteresis: the torque is a continuous function of the error,
so nothing switches at rest; inside the deadband it is exactly zero, so a joint that has
arrived is left to the PID (and to the friction that holds it). A hysteresis relay would keep
applying +-level to a joint at rest, and would jump by 2 x level when it flips.
"""

from __future__ import annotations

import dataclasses
import math

__all__ = ['FrictionCompensator', 'friction_feedforward']


@dataclasses.dataclass(frozen=True)
class FrictionCompensator:
    """Constant friction-compensation torque signed by the position error, with a deadband.

    Attributes
    ----------
    level : float
        Full compensation torque [N*m] (the identified Coulomb friction times a fraction).
    deadband : float
        Half-width of the zero band around zero error [rad].
    ramp : float
        Width over which the torque rises from 0 to ``level`` [rad], > 0.
    """

    level: float
    deadband: float
    ramp: float

    def __post_init__(self) -> None:
        for name in ('level', 'deadband', 'ramp'):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0.0):
                raise ValueError(f'friction compensation {name} must be a finite number >= 0, '
                                 f'got {value!r}')
        if self.ramp <= 0.0:
            raise ValueError(f'friction compensation ramp must be > 0 rad, got {self.ramp!r}')

    def torque(self, error: float) -> float:
        """Compensation torque [N*m] for the position error ``theta_r - theta`` [rad]."""
        if not math.isfinite(error):
            raise ValueError(f'position error must be finite, got {error!r}')
        excess = abs(error) - self.deadband
        if excess <= 0.0:
            return 0.0
        return math.copysign(self.level * min(1.0, excess / self.ramp), error)


def friction_feedforward(coulomb: float, reference_velocity: float, speed_scale: float) -> float:
    """Coulomb friction the reference motion will meet [N*m], signed by the reference velocity.

    ``coulomb tanh(omega_r / speed_scale)``: part of the model-based feed-forward, so that a
    tracking joint does not first have to fall behind by the compensator's deadband and ramp
    before the friction it meets is cancelled (on the walker, joint 1's 1.5 N*m of friction
    would otherwise cost it the compensator's whole ramp of error on every move). Smooth through
    zero velocity (the reference passes zero at the start and end of every move); zero at rest,
    where the error-signed compensator above takes over.

    Parameters
    ----------
    coulomb : float
        Coulomb friction torque of the drive [N*m], >= 0.
    reference_velocity : float
        Setpoint velocity [rad/s].
    speed_scale : float
        Reference speed [rad/s] at which the feed-forward reaches tanh(1) = 76 % of
        ``coulomb``; 0 turns the feed-forward off.
    """
    if speed_scale <= 0.0 or coulomb == 0.0:
        return 0.0
    return coulomb * math.tanh(reference_velocity / speed_scale)
