"""Acceleration feedback of joint 1 in coarse motion (paper section 4, Figure 4, eq (14)).

The measured joint acceleration, times ``Ka``, is subtracted from the command before the
low-pass filter: ``s^2 theta = F(s) [u - Ka s^2 theta]`` in the unit-inertia loop of eq (14).
In torque units the controller multiplies by the rigid model's inertia ``I_ii(q)``, so the term
is ``-Ka I_ii(q) a_measured``. At low frequency it acts as an added inertia ``Ka I_ii``; through
the filter it damps the resonance that the filter's lag causes, which is what lets the
stability condition eq (15)/(16) hold with ``wc`` closer to ``wf``.
"""

from __future__ import annotations

import math

__all__ = ['acceleration_feedback_torque']


def acceleration_feedback_torque(gain: float, inertia: float, acceleration: float) -> float:
    """Acceleration feedback term ``-Ka I a`` [N*m] (eq (14), in torque units).

    Parameters
    ----------
    gain : float
        ``Ka`` (dimensionless, >= 0).
    inertia : float
        Rigid-model inertia of the joint at the current configuration [kg*m^2].
    acceleration : float
        Measured joint acceleration [rad/s^2].

    Returns
    -------
    float
        The torque to add to the command before the filter [N*m].

    Raises
    ------
    ValueError
        If an input is not finite, or the gain or inertia is negative.
    """
    if not (math.isfinite(gain) and math.isfinite(inertia) and math.isfinite(acceleration)):
        raise ValueError(f'acceleration feedback inputs must be finite, got Ka={gain!r}, '
                         f'I={inertia!r}, a={acceleration!r}')
    if gain < 0.0 or inertia < 0.0:
        raise ValueError(f'Ka and the inertia must be >= 0, got Ka={gain!r}, I={inertia!r}')
    return -gain * inertia * acceleration
