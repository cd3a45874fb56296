"""PID with anti-windup and output clamping, the feedback part of the joint controller (Figure 3).

The law, with ``e = theta_r - theta`` and ``de = omega_r - omega`` (the error rate from the
measured velocity, not a differentiated position)::

    i[k] = clamp(i[k-1] + Ki e[k] dt, +-integral_limit)     (unless integration is held)
    u[k] = clamp(Kp e[k] + i[k] + Kd de[k], +-output_limit)

The integral is kept as a torque, ``i = integral of Ki e dt``, so the gains may change from one
sample to the next (the controller scales them with the configuration-dependent inertia) without
a jump of the integral term.

Anti-windup is by *conditional integration* (clamping): the integral is not advanced when doing
so would push an output that is already at its limit further into saturation: either this
PID's own output, or (``hold_integral=True``) the joint command downstream, which the caller
knows is clamped. The integral is also bounded on its own by ``integral_limit``. Back-calculation
was not chosen because the low-pass filter between this PID and the torque clamp delays the
saturation error it would feed back.
"""

from __future__ import annotations

import math
from typing import NamedTuple

__all__ = ['PidGains', 'PidTerms', 'Pid']


def _clamp(value: float, limit: float) -> float:
    return max(-limit, min(limit, value))


class _Gains(NamedTuple):
    p: float
    i: float
    d: float
    output_limit: float
    integral_limit: float


class PidGains(_Gains):
    """Gains and limits of a :class:`Pid` (immutable; validated when built).

    Attributes
    ----------
    p : float
        Proportional gain [N*m/rad].
    i : float
        Integral gain [N*m/(rad*s)]; 0 disables integral action.
    d : float
        Derivative gain [N*m*s/rad].
    output_limit : float
        The output is clamped to +-output_limit [N*m].
    integral_limit : float
        The integral term is clamped to +-integral_limit [N*m].

    Raises
    ------
    ValueError
        If a value is not a finite number >= 0.
    """

    __slots__ = ()

    def __new__(cls, p: float, i: float, d: float, output_limit: float,
                integral_limit: float) -> 'PidGains':
        """Build and validate the gains."""
        # the common case first, cheaply: the controllers build gains every control period
        if not (type(p) is float and type(i) is float and type(d) is float
                and type(output_limit) is float and type(integral_limit) is float
                and 0.0 <= p < math.inf and 0.0 <= i < math.inf and 0.0 <= d < math.inf
                and 0.0 <= output_limit < math.inf and 0.0 <= integral_limit < math.inf):
            for name, value in (('p', p), ('i', i), ('d', d), ('output_limit', output_limit),
                                ('integral_limit', integral_limit)):
                if not (isinstance(value, (int, float)) and math.isfinite(value)
                        and value >= 0.0):
                    raise ValueError(f'PID {name} must be a finite number >= 0, got {value!r}')
        return super().__new__(cls, p, i, d, output_limit, integral_limit)


class PidTerms(NamedTuple):
    """One PID evaluation, each term in N*m."""

    proportional: float
    integral: float
    derivative: float
    command: float
    saturated: bool


class Pid:
    """PID controller with conditional-integration anti-windup and output clamping.

    Parameters
    ----------
    gains : PidGains
        Initial gains and limits.
    """

    def __init__(self, gains: PidGains) -> None:
        self._gains = gains
        self._integral = 0.0

    @property
    def gains(self) -> PidGains:
        """Gains in force."""
        return self._gains

    @property
    def integral_term(self) -> float:
        """The integral term ``sum Ki e dt`` [N*m]."""
        return self._integral

    def set_gains(self, gains: PidGains) -> None:
        """Change the gains; the integral term (a torque) is kept, clamped to the new limit."""
        self._gains = gains
        self._integral = _clamp(self._integral, gains.integral_limit)

    def reset(self, integral: float = 0.0) -> None:
        """Set the integral term [N*m] (0 by default)."""
        if not math.isfinite(integral):
            raise ValueError(f'integral term must be finite, got {integral!r}')
        self._integral = _clamp(float(integral), self._gains.integral_limit)

    def compute_command(self, error: float, error_rate: float, dt: float, *,
                        hold_integral: bool = False) -> PidTerms:
        """Advance one sample and return the terms and the clamped command.

        Parameters
        ----------
        error : float
            Position error ``theta_r - theta`` [rad].
        error_rate : float
            Velocity error ``omega_r - omega`` [rad/s].
        dt : float
            Time since the previous sample [s], > 0.
        hold_integral : bool
            Do not integrate on this sample (the caller sets it when its downstream command is
            saturated in the direction the error would push the integral).

        Returns
        -------
        PidTerms

        Raises
        ------
        ValueError
            If an input is not finite or ``dt`` is not positive; nothing changes.
        """
        if not (math.isfinite(error) and math.isfinite(error_rate)):
            raise ValueError(f'PID inputs must be finite, got error={error!r}, '
                             f'error_rate={error_rate!r}')
        if not (math.isfinite(dt) and dt > 0.0):
            raise ValueError(f'dt must be a positive number of seconds, got {dt!r}')
        g = self._gains
        proportional = g.p * error
        derivative = g.d * error_rate
        integral = self._integral
        if g.i > 0.0 and not hold_integral:
            candidate = _clamp(integral + g.i * error * dt, g.integral_limit)
            unclamped = proportional + candidate + derivative
            pushes_up = candidate > integral
            deepens = abs(unclamped) > g.output_limit and (unclamped > 0.0) == pushes_up
            if not deepens:
                integral = candidate
        self._integral = integral
        total = proportional + integral + derivative
        command = _clamp(total, g.output_limit)
        return PidTerms(proportional=proportional, integral=integral, derivative=derivative,
                        command=command, saturated=command != total)
