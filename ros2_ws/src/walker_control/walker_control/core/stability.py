"""Stability of the joint loop: eq (14), the Routh-Hurwitz conditions (15)/(16), discrete poles.

The paper's loop (section 4, Figure 4) is a unit-inertia rigid joint ``1/s^2`` under the PD law
with feed-forward ``u = (s^2 + 2 zc wc s + wc^2) theta_r - (2 zc wc s + wc^2) theta``, the
acceleration feedback ``-Ka s^2 theta`` added to the command, and the second-order filter
``F(s) = wf^2 / (s + wf)^2`` applied to the whole command: ``s^2 theta = F(s) [u - Ka s^2
theta]``. Multiplying out gives eq (14), as printed. Routh-Hurwitz on its quartic denominator
gives, besides positive coefficients, ``b1 = wf^2 (1 + Ka) - zc wc wf > 0`` and
``c1 = 2 zc wc wf^2 - 2 wc^2 wf^3 / b1 > 0``; the second implies the first and is eq (15);
``zc = 1`` gives eq (16). All three are right as printed.

The controller that runs is discrete and more general than eq (14): PID (integral action in fine
mode), a Bessel, Butterworth or critically damped filter of any order designed with scipy.signal
and discretised at the control rate, the measured acceleration of the last period, a zero-order
hold, and possibly one period of transport delay. :func:`discrete_loop_matrix` builds that loop
as a discrete state-space system on the rigid model and :func:`check_loop` refuses a design
whose closed-loop poles are not inside the unit circle with a minimum damping, for a range of
mismatches between the model inertia and the true one. Because the controller multiplies its
whole command by the rigid model's inertia ``I_ii(q)`` (eqs (9)-(13)) at the current
configuration, the nominal loop is the unit-inertia loop at every configuration; a mismatch
ratio ``r = I_model / I_true`` scales the loop gain.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Sequence

import numpy as np
from scipy import signal

from walker_control.core.lowpass import design_lowpass_sos

__all__ = [
    'LoopDesign', 'LoopReport', 'UnstableLoopError',
    'eq14_transfer_function', 'eq14_poles', 'eq15_margin', 'eq16_margin', 'routh_array',
    'routh_hurwitz_stable', 'discrete_loop_matrix', 'discrete_closed_loop_poles',
    'pole_damping', 'check_loop', 'inertia_ratio_grid', 'eq15_applies',
]


class UnstableLoopError(ValueError):
    """A loop design is unstable or too poorly damped; the message names the loop and why."""


@dataclasses.dataclass(frozen=True)
class LoopDesign:
    """The design quantities of one joint loop in one mode (normalised to unit inertia).

    Attributes
    ----------
    bandwidth : float
        Desired closed-loop frequency ``wc`` [rad/s].
    damping : float
        Desired closed-loop damping ratio ``zc``.
    integral_time : float
        Integral time ``Ti`` [s]; 0 means no integral action.
    acceleration_feedback : float
        ``Ka`` (dimensionless).
    filter_order : int
        0 for no filter.
    filter_corner : float
        ``wf`` [rad/s] (ignored for order 0).
    filter_kind : str
        ``'butterworth'``, ``'critical'`` or ``'bessel'`` (:mod:`walker_control.core.lowpass`).
    """

    bandwidth: float
    damping: float
    integral_time: float = 0.0
    acceleration_feedback: float = 0.0
    filter_order: int = 0
    filter_corner: float = 0.0
    filter_kind: str = 'butterworth'

    @property
    def kp(self) -> float:
        """Normalised proportional gain ``wc^2`` [1/s^2]."""
        return self.bandwidth ** 2

    @property
    def kd(self) -> float:
        """Normalised derivative gain ``2 zc wc`` [1/s]."""
        return 2.0 * self.damping * self.bandwidth

    @property
    def ki(self) -> float:
        """Normalised integral gain ``wc^2 / Ti`` [1/s^3], 0 without integral action."""
        return self.kp / self.integral_time if self.integral_time > 0.0 else 0.0


@dataclasses.dataclass(frozen=True)
class LoopReport:
    """What :func:`check_loop` found for one loop.

    Attributes
    ----------
    largest_pole_magnitude : float
        Largest ``|z|`` over every case checked (< 1 is stable).
    smallest_damping : float
        Smallest equivalent damping ratio of a closed-loop pole over every case.
    eq15_margin : float or None
        ``(1 + Ka) zc / (1 + zc^2) - wc / wf`` (> 0 satisfies eq (15)) when eq (15) applies
        (a 2nd-order critically damped filter, :func:`eq15_applies`); None otherwise.
    worst_case : str
        The inertia ratio and delay of the case with the smallest damping.
    stability_condition : str
        What judged the loop: the sampled poles, with or without eq (15), and why not.
    """

    largest_pole_magnitude: float
    smallest_damping: float
    eq15_margin: float | None
    worst_case: str
    stability_condition: str = 'sampled poles'


# --------------------------------------------------------------------------- the paper's model
def eq14_transfer_function(wc: float, zc: float, wf: float, Ka: float
                           ) -> tuple[np.ndarray, np.ndarray]:
    """Numerator and denominator of theta / theta_r, eq (14), highest power first.

    Parameters
    ----------
    wc : float
        Desired closed-loop frequency [rad/s].
    zc : float
        Desired damping ratio.
    wf : float
        Corner of the second-order critically damped filter ``wf^2 / (s + wf)^2`` [rad/s].
    Ka : float
        Acceleration feedback gain.

    Returns
    -------
    (ndarray, ndarray)
        ``(s^2 + 2 zc wc s + wc^2) wf^2`` and
        ``s^4 + 2 wf s^3 + wf^2 (1 + Ka) s^2 + 2 zc wc wf^2 s + wc^2 wf^2``.
    """
    numerator = np.array([1.0, 2.0 * zc * wc, wc ** 2]) * wf ** 2
    denominator = np.array([1.0, 2.0 * wf, wf ** 2 * (1.0 + Ka), 2.0 * zc * wc * wf ** 2,
                            wc ** 2 * wf ** 2])
    return numerator, denominator


def eq14_poles(wc: float, zc: float, wf: float, Ka: float) -> np.ndarray:
    """Closed-loop poles of eq (14) [rad/s]."""
    return np.roots(eq14_transfer_function(wc, zc, wf, Ka)[1])


def eq15_margin(wc: float, zc: float, wf: float, Ka: float) -> float:
    """Margin of the stability condition eq (15): ``(1 + Ka) zc / (1 + zc^2) - wc / wf``.

    Positive when eq (14) is stable (for positive wc, zc, wf and 1 + Ka > 0).
    """
    return (1.0 + Ka) * zc / (1.0 + zc ** 2) - wc / wf


def eq16_margin(wc: float, wf: float, Ka: float) -> float:
    """Margin of eq (16), eq (15) with unit damping: ``(1 + Ka) - 2 wc / wf``.

    It is twice :func:`eq15_margin` at ``zc = 1``, so it has the same sign.
    """
    return (1.0 + Ka) - 2.0 * wc / wf


def eq15_applies(design: 'LoopDesign') -> bool:
    """Tell whether eq (15) is the stability condition of a loop's filter.

    Eq (15) is Routh-Hurwitz on eq (14), derived for the second-order critically damped filter
    ``wf^2 / (s + wf)^2``: true for ``filter_kind == 'critical'`` of order 2 only.
    """
    return design.filter_order == 2 and design.filter_kind == 'critical'


def routh_array(coefficients: Sequence[float]) -> np.ndarray:
    """Routh array of a polynomial (highest power first), one row per power of s.

    Raises
    ------
    ValueError
        If a first-column entry becomes zero (the regular array does not exist: the polynomial
        has roots on or symmetric about the imaginary axis).
    """
    a = np.asarray(coefficients, dtype=float)
    if a.ndim != 1 or len(a) < 2 or a[0] == 0.0:
        raise ValueError(f'need a polynomial of degree >= 1, got {coefficients!r}')
    n = len(a)
    width = (n + 1) // 2
    table = np.zeros((n, width))
    table[0, :len(a[0::2])] = a[0::2]
    table[1, :len(a[1::2])] = a[1::2]
    for i in range(2, n):
        pivot = table[i - 1, 0]
        if pivot == 0.0:
            raise ValueError('zero in the first column of the Routh array: marginal polynomial')
        for j in range(width - 1):
            table[i, j] = (pivot * table[i - 2, j + 1] - table[i - 2, 0] * table[i - 1, j + 1]) \
                / pivot
    return table


def routh_hurwitz_stable(coefficients: Sequence[float]) -> bool:
    """Tell whether every root has a negative real part (Routh-Hurwitz: first column > 0)."""
    try:
        first = routh_array(coefficients)[:, 0]
    except ValueError:
        return False
    return bool(np.all(first * np.sign(first[0]) > 0.0))


# ----------------------------------------------------------------------- the discrete loop
def _filter_state_space(design: LoopDesign, sample_time: float
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    sos = design_lowpass_sos(design.filter_order, design.filter_corner, sample_time,
                             design.filter_kind)
    if len(sos) == 0:
        return np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), np.ones((1, 1))
    a, b, c, d = signal.tf2ss(*signal.sos2tf(sos))
    return a, b, c, d


def discrete_loop_matrix(design: LoopDesign, sample_time: float, delay_periods: int = 0,
                         inertia_ratio: float = 1.0) -> np.ndarray:
    """State matrix of the sampled closed loop on the rigid model.

    Parameters
    ----------
    design : LoopDesign
        Gains, acceleration feedback and filter of the loop.
    sample_time : float
        Control period T [s].
    delay_periods : {0, 1}
        0: the command computed from the state at t_k acts from t_k (sim-time lock-step);
        1: it acts one period later (a real-time plant applying the command it has).
    inertia_ratio : float
        ``r = I_model / I_true``: the true acceleration is ``r`` times the commanded one.

    Returns
    -------
    ndarray, square
        ``A`` of ``X[k+1] = A X[k]`` with ``X = [theta, omega, z, m, x_f..., (d)]``: angle,
        velocity, integral of the error, measured acceleration, filter states, and the delayed
        command when ``delay_periods = 1``.

    Notes
    -----
    With ``theta_r = 0`` the command is
    ``v = -kp theta - kd omega + ki (z + T e) - Ka m`` (the integral is updated before use,
    as :class:`walker_control.core.pid.Pid` does); it goes through the filter ``F(z)`` to ``y``;
    the zero-order-held ``u`` drives the double integrator,
    ``theta' = theta + T omega + r T^2 u / 2``, ``omega' = omega + r T u``, and the plant
    reports as acceleration at the next sample the mean acceleration of the period, ``r u``.
    """
    if delay_periods not in (0, 1):
        raise ValueError(f'delay_periods must be 0 or 1, got {delay_periods!r}')
    T = float(sample_time)
    af, bf, cf, df = _filter_state_space(design, T)
    nf = af.shape[0]
    n = 4 + nf + delay_periods
    kp, kd, ki, ka = design.kp, design.kd, design.ki, design.acceleration_feedback
    # v = K X (row vector over the states)
    k_row = np.zeros(n)
    k_row[0] = -kp - ki * T
    k_row[1] = -kd
    k_row[2] = ki
    k_row[3] = -ka
    # filter output y = C_y X
    c_y = np.zeros(n)
    c_y[4:4 + nf] = cf.ravel() if nf else []
    c_y += float(df.ravel()[0]) * k_row
    # applied command u = C_u X
    if delay_periods:
        c_u = np.zeros(n)
        c_u[-1] = 1.0
    else:
        c_u = c_y
    a = np.zeros((n, n))
    a[0, 0], a[0, 1] = 1.0, T
    a[0] += 0.5 * inertia_ratio * T ** 2 * c_u
    a[1, 1] = 1.0
    a[1] += inertia_ratio * T * c_u
    a[2, 2], a[2, 0] = 1.0, -T
    a[3] = inertia_ratio * c_u
    if nf:
        a[4:4 + nf, 4:4 + nf] = af
        a[4:4 + nf] += np.outer(bf.ravel(), k_row)
    if delay_periods:
        a[-1] = c_y
    if design.ki == 0.0:
        # Without integral action the integral state is decoupled (a pole at 1): drop it.
        keep = [i for i in range(n) if i != 2]
        a = a[np.ix_(keep, keep)]
    return a


def discrete_closed_loop_poles(design: LoopDesign, sample_time: float, delay_periods: int = 0,
                               inertia_ratio: float = 1.0) -> np.ndarray:
    """Closed-loop poles (z-plane) of :func:`discrete_loop_matrix`."""
    return np.linalg.eigvals(discrete_loop_matrix(design, sample_time, delay_periods,
                                                  inertia_ratio))


def pole_damping(poles: Iterable[complex], sample_time: float) -> np.ndarray:
    """Equivalent continuous damping ratio ``-Re(s)/|s|`` of z-plane poles, ``s = ln(z)/T``.

    A pole at the origin (a pure delay) counts as damping 1; a pole on the unit circle as 0;
    outside the unit circle the value is negative.
    """
    result = []
    for z in np.asarray(list(poles), dtype=complex):
        if abs(z) < 1e-12:
            result.append(1.0)
            continue
        s = np.log(z) / sample_time
        magnitude = abs(s)
        result.append(0.0 if magnitude < 1e-12 else -s.real / magnitude)
    return np.array(result)


def inertia_ratio_grid(ratio_min: float, ratio_max: float, points: int = 9) -> np.ndarray:
    """Geometric grid of inertia ratios from ``ratio_min`` to ``ratio_max``, including 1."""
    grid = np.geomspace(ratio_min, ratio_max, points)
    return np.unique(np.append(grid, 1.0) if ratio_min <= 1.0 <= ratio_max else grid)


def check_loop(design: LoopDesign, sample_time: float, *, label: str,
               inertia_ratios: Sequence[float] = (1.0,), minimum_damping: float = 0.0,
               delays: Sequence[int] = (0, 1), require_eq15: bool = True) -> LoopReport:
    """Refuse a loop design that is unstable, too poorly damped, or violates eq (15).

    Parameters
    ----------
    design : LoopDesign
        The loop.
    sample_time : float
        Control period [s].
    label : str
        Names the loop in the error (e.g. ``'role J1, mode coarse'``).
    inertia_ratios : sequence of float
        Model-to-true inertia ratios to check (see :func:`discrete_loop_matrix`).
    minimum_damping : float
        Smallest acceptable equivalent damping ratio of any closed-loop pole.
    delays : sequence of {0, 1}
        Transport delays [periods] to check.
    require_eq15 : bool
        Also require eq (15), taking the filter corner as ``wf``, when it applies: a 2nd-order
        critically damped filter (:func:`eq15_applies`). Other filters are judged by the
        sampled poles alone.

    Returns
    -------
    LoopReport
        The worst figures found.

    Raises
    ------
    UnstableLoopError
        Naming the loop, the case and the pole magnitude or damping, or the eq (15) value.
    """
    margin = None
    if not design.filter_order:
        condition = 'sampled poles (no filter: eq (15) does not apply)'
    elif not eq15_applies(design):
        condition = (f'sampled poles (eq (15) does not apply: it is derived for a 2nd-order '
                     f'critically damped filter, this is a {design.filter_kind} filter of order '
                     f'{design.filter_order})')
    else:
        condition = 'sampled poles and eq (15)' if require_eq15 else 'sampled poles'
        margin = eq15_margin(design.bandwidth, design.damping, design.filter_corner,
                             design.acceleration_feedback)
        if require_eq15 and not margin > 0.0:
            ka, zc = design.acceleration_feedback, design.damping
            raise UnstableLoopError(
                f'{label}: violates the stability condition eq (15) of the paper: '
                f'(1 + Ka) zc / (1 + zc^2) = {(1.0 + ka) * zc / (1.0 + zc ** 2):.4g} is not '
                f'above wc / wf = {design.bandwidth / design.filter_corner:.4g} '
                f'(wc = {design.bandwidth:g} rad/s, wf = {design.filter_corner:g} rad/s, '
                f'Ka = {ka:g}, zc = {zc:g})')
    largest, smallest = 0.0, math.inf
    largest_case = smallest_case = ''
    for delay in delays:
        for ratio in inertia_ratios:
            poles = discrete_closed_loop_poles(design, sample_time, delay, ratio)
            magnitude = float(np.max(np.abs(poles)))
            damping = float(np.min(pole_damping(poles, sample_time)))
            case = f'inertia ratio {ratio:.3g}, delay {delay} period(s)'
            if magnitude > largest:
                largest, largest_case = magnitude, case
            if damping < smallest:
                smallest, smallest_case = damping, case
    described = (f'wc = {design.bandwidth:g} rad/s, zc = {design.damping:g}, '
                 f'Ti = {design.integral_time:g} s, Ka = {design.acceleration_feedback:g}, '
                 f'filter order {design.filter_order} at {design.filter_corner:g} rad/s, '
                 f'T = {sample_time:g} s')
    if largest >= 1.0:
        raise UnstableLoopError(
            f'{label}: the discrete closed loop is unstable ({largest_case}): a pole has '
            f'|z| = {largest:.6f} >= 1 ({described})')
    if smallest < minimum_damping:
        raise UnstableLoopError(
            f'{label}: a closed-loop pole is too poorly damped ({smallest_case}): damping '
            f'{smallest:.4f} < the minimum {minimum_damping:g} ({described})')
    return LoopReport(largest_pole_magnitude=largest, smallest_damping=smallest,
                      eq15_margin=margin, worst_case=smallest_case,
                      stability_condition=condition)
