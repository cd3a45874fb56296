"""The fastest move a joint's command filter lets the controller ask for (a linear programme).

The controller of Figure 3 passes its whole command through the joint's low-pass filter ``F``
and compares the joint with the setpoint shaped by the same filter
(:mod:`~walker_control.core.reference_shaping`): whatever setpoints ``theta_p`` a plan streams,
the motion the controller asks of the joint is ``F theta_p``. This module finds, for a
rest-to-rest move of ``distance``, the earliest time at which ``F theta_p`` can be within
``tolerance`` of the target and stay there, over every setpoint sequence whose acceleration
stays within ``acceleration_limit`` (the torque the drive has left over the joint's inertia)
and whose velocity, and the shaped velocity, stay within ``rate_limit``. No plan can bring the
reference there sooner; the paper's bang-coast-bang plan, filtered, arrives later.

Discrete time at the control period ``T``, as the controller runs: the setpoint's acceleration
``u_k`` is the free variable, ``v_k = v_(k-1) + T u_k``, ``p_k = p_(k-1) + T v_k``, the filter
in state-space form ``x_(k+1) = A x_k + B p_k``, ``y_k = C x_k + D p_k``, the shaped velocity
the backward difference of ``y`` (exactly the filtered ``v``, the filter being linear). At the
end of the horizon the setpoint rests at the target and the filter is in the steady state of
that input, so the reference stays there. Each candidate entry time is a feasibility problem
(``scipy.optimize.linprog``, HiGHS, sparse); a bisection over it finds the earliest.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy import optimize, signal

__all__ = ['FastestMove', 'fastest_move_through_filter']

#: [s] the reference must stay in the band this long after the setpoint has come to rest
#: (several time constants of any filter the controllers use: 4th order at 5 rad/s and up)
_SETTLE = 1.0


@dataclasses.dataclass(frozen=True)
class FastestMove:
    """The earliest arrival of a filtered reference, and the setpoints that achieve it.

    Attributes
    ----------
    arrival : float
        Time [s] from the start of the move from which on the shaped reference stays within
        the tolerance of the target.
    times : ndarray (N,)
        Sample times [s] of the horizon (the arrival and a tail after it).
    acceleration, velocity, position : ndarray (N,)
        The setpoints: [rad/s^2], [rad/s], [rad].
    reference : ndarray (N,)
        The shaped reference ``F theta_p`` [rad].
    """

    arrival: float
    times: np.ndarray
    acceleration: np.ndarray
    velocity: np.ndarray
    position: np.ndarray
    reference: np.ndarray


def fastest_move_through_filter(distance: float, rate_limit: float, acceleration_limit: float,
                                sos: np.ndarray, sample_time: float, tolerance: float,
                                tail: float = 0.6, resolution: int = 1) -> FastestMove:
    """Find the earliest time a filtered rest-to-rest reference can arrive and stay.

    Parameters
    ----------
    distance : float
        Length of the move [rad], > 0.
    rate_limit : float
        Largest speed [rad/s] of the setpoint and of the shaped reference, > 0.
    acceleration_limit : float
        Largest setpoint acceleration [rad/s^2], > 0.
    sos : ndarray (n, 6)
        The command filter as second-order sections (:func:`~walker_control.core.lowpass.
        design_lowpass_sos`); empty for an unfiltered joint.
    sample_time : float
        Control period [s], > 0.
    tolerance : float
        Half-width [rad] of the band about the target the reference must stay in, >= 0.
    tail : float
        Time [s] after the arrival within which the setpoint must come to rest (the reference
        stays in the band meanwhile), > 0.
    resolution : int
        The arrival is searched to within this many samples, >= 1.

    Returns
    -------
    FastestMove

    Raises
    ------
    ValueError
        A non-finite or out-of-range argument.
    """
    for name, value in (('distance', distance), ('rate_limit', rate_limit),
                        ('acceleration_limit', acceleration_limit),
                        ('sample_time', sample_time), ('tail', tail)):
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0.0):
            raise ValueError(f'{name} must be a positive number, got {value!r}')
    if not (isinstance(tolerance, (int, float)) and math.isfinite(tolerance)
            and tolerance >= 0.0):
        raise ValueError(f'tolerance must be a number >= 0, got {tolerance!r}')
    if isinstance(resolution, bool) or not isinstance(resolution, int) or resolution < 1:
        raise ValueError(f'resolution must be an integer >= 1, got {resolution!r}')
    sos = np.asarray(sos, dtype=float).reshape(-1, 6)
    tail_samples = max(1, math.ceil(tail / sample_time))

    settle = max(1, math.ceil(_SETTLE / sample_time))

    def attempt(entry: int) -> FastestMove | None:
        return _solve(distance, rate_limit, acceleration_limit, sos, sample_time, tolerance,
                      entry, entry + tail_samples, settle)

    # twice the unfiltered rate-and-acceleration bound is a first feasible guess
    low = -1  # the reference cannot be at the target before the move has started
    high = max(1, math.ceil(2.0 * _rest_to_rest(distance, rate_limit, acceleration_limit)
                            / sample_time))
    best = attempt(high)
    while best is None:
        low, high = high, 2 * high
        best = attempt(high)
    while high - low > resolution:
        middle = (low + high) // 2
        found = attempt(middle)
        if found is None:
            low = middle
        else:
            high, best = middle, found
    return best


def _rest_to_rest(distance: float, rate: float, acceleration: float) -> float:
    """Fastest rest-to-rest move [s] with no filter (bang-coast-bang or bang-bang)."""
    if distance * acceleration <= rate * rate:
        return 2.0 * math.sqrt(distance / acceleration)
    return distance / rate + rate / acceleration


def _solve(distance, rate, acceleration, sos, dt, tolerance, entry, samples, settle
           ) -> FastestMove | None:
    """Feasibility at one entry sample: the setpoints, or None when there are none.

    The setpoint's acceleration over the first ``samples`` periods is the variable; the
    shaped reference is its filtered double integral, a dense linear map (the filter's impulse
    response), well scaled whatever the corner: a state-space form of a low corner at a short
    period has states millions of times larger than the signal, which no solver takes. After
    the horizon the setpoint rests at the target for ``settle`` more periods, the reference
    staying in the band meanwhile (the filter's own decay).
    """
    n, total = samples, samples + settle
    k = np.arange(total)[:, None]
    i = np.arange(n)[None, :]
    velocity = np.where(k >= i, dt, 0.0)                      # v_k = T sum_(i<=k) u_i
    position = np.where(k >= i, dt * dt * (k - i + 1), 0.0)   # p_k = T sum_(i<=k) v_i
    impulse = signal.sosfilt(sos, np.eye(1, total, 0)[0]) if len(sos) else np.eye(1, total)[0]
    shaping = np.array([np.concatenate([impulse[j::-1], np.zeros(total - j - 1)])
                        for j in range(total)])              # y = H p, H lower triangular
    reference = shaping @ position
    rate_of_reference = np.diff(np.vstack([np.zeros((1, n)), reference]), axis=0) / dt
    a_ub = np.vstack([velocity[:n], -velocity[:n], rate_of_reference, -rate_of_reference,
                      reference[entry:], -reference[entry:]])
    band = total - entry
    b_ub = np.concatenate([np.full(2 * n, rate), np.full(2 * total, rate),
                           np.full(band, distance + tolerance),
                           np.full(band, -(distance - tolerance))])
    a_eq = np.vstack([position[n - 1], velocity[n - 1]])      # at rest at the target
    result = optimize.linprog(np.zeros(n), A_ub=a_ub, b_ub=b_ub, A_eq=a_eq,
                              b_eq=[distance, 0.0], bounds=[(-acceleration, acceleration)] * n,
                              method='highs')
    if result.status != 0:
        return None
    u = result.x
    times = (np.arange(total) + 1) * dt  # sample k: after k + 1 periods of the move
    return FastestMove(arrival=float(times[entry]), times=times,
                       acceleration=np.concatenate([u, np.zeros(settle)]),
                       velocity=velocity @ u, position=position @ u, reference=reference @ u)
