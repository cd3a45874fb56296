"""The planar bang-bang node-to-node trajectory of paper section 5, dimensionless, eqs (23)-(27).

Model (paper section 5, Figure 7)
---------------------------------
The tip, carrying the mass ``m``, moves in the horizontal plane in polar coordinates
``(r, Theta)`` about the base yaw axis. With the gripper vertical and the tip at the base's
height the arm is a symmetric inverted V: ``r = 2 l sin(th2)``, ``th3 = pi - 2 th2``, with
``l = l2``. Joint 1 drives ``Theta`` with ``tau1``, joint 3 drives ``r`` with ``tau3``:

* (17) ``F_r = S3 tau3 / (l cos th2)`` (virtual work: ``dr/dth3 = -l cos th2``);
* (18) ``F_Theta = S1 tau1 / (2 l sin th2) = S1 tau1 / r``;
* (19) ``F_r = m (r'' - r Theta'^2)``, (20) ``F_Theta = m (r Theta'' + 2 r' Theta')``;
* (21) ``r'' = S3 tau3 / (m l cos th2)`` (centrifugal term neglected);
* (22) ``Theta'' = S1 tau1 / (2 m l r sin th2) - 2 r' Theta' / r``. **Misprint corrected**: the
  paper prints ``S1 tau1 / (2 m r sin th2)``, which lacks the ``l`` of (18) and has the units
  of m/s^2, not rad/s^2; only the corrected form reduces to (27) under (23);
* (23) ``phi = sqrt(tau3 / (m l^2)) t``; (24), (25) the chain rule;
* (26) ``rho'' = S3 / (2 cos th2)``, (27) ``Theta'' = (1/rho) (S1 tau / (4 sin th2) -
  2 rho' Theta')``, with ``rho = r / 2l = sin th2`` and ``tau = tau1 / tau3``.

The torques are bang-bang: ``S1 = +1`` for ``phi < phi2`` and ``-1`` after; ``S3 = -1`` (inwards)
until the switch ``phi1``, then ``+1`` so that ``rho' = 0`` at the midpoint ``phi2``, where
``rho`` is smallest; the second half mirrors the first (Figure 8).

Exact solution
--------------
Nothing here needs trial and error (the paper iterated on ``tau``):

* (26) has the energy integral ``rho'^2 = S3 asin(rho) + c``, so with ``u = th2 = asin(rho)``
  the switch is at ``u1 = (u(0) + u(phi2)) / 2`` and, with ``s^2 = u(0) - u``, ``rho' = -s`` and
  ``phi(s) = 2 int_0^s cos(u(0) - x^2) dx``: Fresnel integrals (``scipy.special.fresnel``).
* (27) is the angular momentum balance ``(rho^2 Theta')' = S1 tau / 4``, so ``Theta' = tau phi /
  (4 rho^2)`` in the first half and ``Theta(phi2) = (tau / 4) int_0^phi2 phi / rho^2 dphi``
  is *linear* in ``tau``: the torque ratio that reaches half the sweep is one quadrature.

:func:`integrate_dimensionless` integrates (26)-(27) with ``scipy.integrate.solve_ivp``
independently of all this, and :func:`torque_ratio_by_root_finding` finds ``tau`` with
``scipy.optimize.brentq`` on it; the tests check that both agree with the exact solution.
"""

from __future__ import annotations

import dataclasses
import math
from typing import NamedTuple

import numpy as np
from numpy.polynomial import chebyshev, legendre
from scipy.integrate import solve_ivp
from scipy.optimize import brentq
from scipy.special import fresnel

from walker_planner.core.errors import NoSolutionError

__all__ = [
    'PlanarSamples', 'ProfileSummary', 'PlanarProfile', 'summarize_profile',
    'integrate_dimensionless', 'torque_ratio_by_root_finding', 'RADIAL_MOTION_FLOOR',
]

#: Below this difference of rho between start and midpoint the profile is a pure rotation
#: (no radial torque); 1e-4 is 0.12 mm of radius for l2 = 0.6 m.
RADIAL_MOTION_FLOOR = 1e-4
_SQRT_HALF_PI = math.sqrt(0.5 * math.pi)
_QUADRATURE = legendre.leggauss(24)
_CHEBYSHEV_DEGREE = 48
_NEWTON_ITERATIONS = 40


def _fresnel_pair(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return ``int_0^x cos(s^2) ds`` and ``int_0^x sin(s^2) ds``."""
    sine, cosine = fresnel(np.asarray(x, dtype=float) / _SQRT_HALF_PI)
    return _SQRT_HALF_PI * cosine, _SQRT_HALF_PI * sine


def _phase_time(x: np.ndarray, u_rest: float, sign: float) -> np.ndarray:
    """Dimensionless time from the rest point of a phase: ``2 int_0^x cos(u_rest - sign s^2)``.

    Phase 1 (``sign = +1``) starts at rest at ``u(0)``; phase 2 (``sign = -1``) ends at rest at
    ``u(phi2)`` and is measured backwards from ``phi2``.
    """
    c, s = _fresnel_pair(x)
    return 2.0 * (math.cos(u_rest) * c + sign * math.sin(u_rest) * s)


def _invert_phase_time(target: np.ndarray, u_rest: float, sign: float, x_end: float
                       ) -> np.ndarray:
    """Solve ``_phase_time(x) = target`` for ``x`` in ``[0, x_end]`` (Newton; monotonic)."""
    target = np.asarray(target, dtype=float)
    x = np.clip(target / (2.0 * math.cos(u_rest)), 0.0, x_end)
    tolerance = 4e-16 * max(x_end, 1e-300)
    for _ in range(_NEWTON_ITERATIONS):
        slope = 2.0 * np.cos(u_rest - sign * x * x)
        step = (_phase_time(x, u_rest, sign) - target) / slope
        x = np.clip(x - step, 0.0, x_end)
        if np.all(np.abs(step) <= tolerance):
            break
    return x


class ProfileSummary(NamedTuple):
    """What the limits need of a profile, without building it (see :func:`summarize_profile`).

    Attributes
    ----------
    phi1, phi2 : float
        Radial switch and midpoint (dimensionless time).
    tau : float
        Torque ratio ``tau1 / tau3`` (1 for a pure rotation, whose time scale is then tau1's).
    circular_rate : float
        Largest ``Theta'`` (at the midpoint), the J1 rate per unit of ``dphi/dt``.
    pitch_rate : float
        Largest ``th2' = rho' / cos th2`` (at the switch), the J2 and J4 rate per unit of
        ``dphi/dt``; J3 turns at twice this rate.
    """

    phi1: float
    phi2: float
    tau: float
    circular_rate: float
    pitch_rate: float


def _check_geometry(rho_start: float, rho_mid: float, half_sweep: float) -> None:
    for name, value in (('rho_start', rho_start), ('rho_mid', rho_mid),
                        ('half_sweep', half_sweep)):
        if not math.isfinite(value):
            raise NoSolutionError(f'{name} must be finite, got {value!r}')
    if not 0.0 < rho_start < 1.0:
        raise NoSolutionError(
            f'rho(0) = {rho_start:.6g} is outside (0, 1): the start radius r = 2 l rho must be '
            f'inside the reach 2 l2 and off the yaw axis')
    if not 0.0 < rho_mid <= rho_start:
        raise NoSolutionError(
            f'the midpoint rho = {rho_mid:.6g} must be in (0, rho(0) = {rho_start:.6g}]: the '
            f'node-to-node trajectory moves the tip inwards, rho_min above the start radius '
            f'has no solution')
    if not 0.0 < half_sweep <= 0.5 * math.pi:
        raise NoSolutionError(
            f'Theta(phi2) = {math.degrees(half_sweep):.6g} deg is not reachable: node-to-node '
            f'sweeps are in (0, 180] deg, so half the sweep is in (0, 90] deg')


def summarize_profile(rho_start: float, rho_mid: float, half_sweep: float) -> ProfileSummary:
    """Switch, midpoint, torque ratio and peak rates of a profile (eqs (26), (27)), fast.

    Parameters
    ----------
    rho_start : float
        ``rho(0) = r(0) / 2l``, in (0, 1).
    rho_mid : float
        ``rho(phi2)``, the smallest radius, in (0, rho_start].
    half_sweep : float
        ``Theta(phi2)`` [rad], half the sweep, in (0, pi/2].

    Returns
    -------
    ProfileSummary

    Notes
    -----
    ``tau = 4 Theta(phi2) / int_0^phi2 phi / rho^2 dphi`` by the angular momentum integral of
    eq (27); the integral is taken in the Fresnel variable by 24-point Gauss-Legendre per
    phase, where its integrand is smooth.
    """
    _check_geometry(rho_start, rho_mid, half_sweep)
    if rho_start - rho_mid < RADIAL_MOTION_FLOOR:
        phi2 = math.sqrt(8.0 * rho_start ** 2 * half_sweep)
        return ProfileSummary(0.0, phi2, 1.0, phi2 / (4.0 * rho_start ** 2), 0.0)
    u0, um = math.asin(rho_start), math.asin(rho_mid)
    x_end = math.sqrt(0.5 * (u0 - um))
    phi1 = float(_phase_time(x_end, u0, 1.0))
    phi2 = phi1 + float(_phase_time(x_end, um, -1.0))
    nodes, weights = _QUADRATURE
    x = 0.5 * x_end * (nodes + 1.0)
    w = 0.5 * x_end * weights
    u1, u2 = u0 - x * x, um + x * x
    first = _phase_time(x, u0, 1.0) * 2.0 * np.cos(u1) / np.sin(u1) ** 2
    second = (phi2 - _phase_time(x, um, -1.0)) * 2.0 * np.cos(u2) / np.sin(u2) ** 2
    integral = float(np.dot(w, first) + np.dot(w, second))
    tau = 4.0 * half_sweep / integral
    switch_u = 0.5 * (u0 + um)
    return ProfileSummary(phi1, phi2, tau, tau * phi2 / (4.0 * rho_mid ** 2),
                          x_end / math.cos(switch_u))


class PlanarSamples(NamedTuple):
    """Samples of a profile in dimensionless time: ``rho`` and ``Theta`` and their derivatives.

    Derivatives are with respect to ``phi``; ``theta`` is measured from the start [rad].
    """

    rho: np.ndarray
    rho_d: np.ndarray
    rho_dd: np.ndarray
    theta: np.ndarray
    theta_d: np.ndarray
    theta_dd: np.ndarray


@dataclasses.dataclass(frozen=True)
class PlanarProfile:
    """A solved dimensionless node-to-node profile (eqs (26), (27)), sampled exactly.

    Build it with :meth:`solve`. The circular sweep is positive (counter-clockwise); a
    clockwise sweep is the same profile with ``Theta`` negated.

    Attributes
    ----------
    rho_start, rho_mid : float
        ``rho`` at the ends and at the midpoint.
    half_sweep : float
        ``Theta(phi2)`` [rad].
    summary : ProfileSummary
        ``phi1``, ``phi2``, ``tau`` and the peak rates.
    """

    rho_start: float
    rho_mid: float
    half_sweep: float
    summary: ProfileSummary
    _first: chebyshev.Chebyshev | None = dataclasses.field(repr=False, compare=False)
    _second: chebyshev.Chebyshev | None = dataclasses.field(repr=False, compare=False)

    @classmethod
    def solve(cls, rho_start: float, rho_mid: float, half_sweep: float) -> 'PlanarProfile':
        """Solve for the switch ``phi1``, the midpoint ``phi2`` and the torque ratio ``tau``.

        Parameters
        ----------
        rho_start : float
            ``rho(0)``, in (0, 1).
        rho_mid : float
            ``rho(phi2)`` in (0, rho_start]; equal to ``rho_start`` (within
            :data:`RADIAL_MOTION_FLOOR`) gives a pure rotation.
        half_sweep : float
            ``Theta(phi2)`` [rad], in (0, pi/2]: 45 deg for a 90 deg step, 90 for 180.

        Raises
        ------
        NoSolutionError
            When the data admit no node-to-node solution; the message says which.
        """
        summary = summarize_profile(rho_start, rho_mid, half_sweep)
        if summary.pitch_rate == 0.0:
            return cls(rho_start, rho_start, half_sweep, summary, None, None)
        u0, um = math.asin(rho_start), math.asin(rho_mid)
        x_end = math.sqrt(0.5 * (u0 - um))
        phi2 = summary.phi2

        def first(x):
            u = u0 - x * x
            return _phase_time(x, u0, 1.0) * 2.0 * np.cos(u) / np.sin(u) ** 2

        def second(x):
            u = um + x * x
            return (phi2 - _phase_time(x, um, -1.0)) * 2.0 * np.cos(u) / np.sin(u) ** 2

        domain = [0.0, x_end]
        first_integral = chebyshev.Chebyshev.interpolate(
            first, _CHEBYSHEV_DEGREE, domain).integ(lbnd=0.0)
        second_integral = chebyshev.Chebyshev.interpolate(
            second, _CHEBYSHEV_DEGREE, domain).integ(lbnd=0.0)
        return cls(rho_start, rho_mid, half_sweep, summary, first_integral, second_integral)

    @property
    def tau(self) -> float:
        """Torque ratio ``tau1 / tau3`` that reaches ``Theta(phi2) = half_sweep``."""
        return self.summary.tau

    @property
    def phi1(self) -> float:
        """Radial switch of the first half (0 for a pure rotation)."""
        return self.summary.phi1

    @property
    def phi2(self) -> float:
        """Midpoint, where ``rho' = 0``, ``rho`` is smallest and ``tau1`` changes sign."""
        return self.summary.phi2

    @property
    def phi_end(self) -> float:
        """End of the trajectory, ``2 phi2``."""
        return 2.0 * self.summary.phi2

    @property
    def pure_rotation(self) -> bool:
        """True when the radius stays constant (no radial torque)."""
        return self._first is None

    def radial_sign(self, phi: np.ndarray) -> np.ndarray:
        """``S3`` of eq (26): -1, +1, +1, -1 over the four radial phases (0 when pure rotation)."""
        phi = np.asarray(phi, dtype=float)
        if self.pure_rotation:
            return np.zeros_like(phi)
        folded = np.minimum(phi, self.phi_end - phi)
        return np.where(folded < self.phi1, -1.0, 1.0)

    def circular_sign(self, phi: np.ndarray) -> np.ndarray:
        """``S1`` of eq (27): +1 before the midpoint, -1 after."""
        return np.where(np.asarray(phi, dtype=float) < self.phi2, 1.0, -1.0)

    def sample(self, phi: float | np.ndarray) -> PlanarSamples:
        """Exact ``rho``, ``Theta`` and their first two ``phi``-derivatives at ``phi``.

        Parameters
        ----------
        phi : float or array_like
            Dimensionless time(s), clipped to ``[0, 2 phi2]``.
        """
        phi = np.clip(np.atleast_1d(np.asarray(phi, dtype=float)), 0.0, self.phi_end)
        mirrored = phi > self.phi2
        folded = np.where(mirrored, self.phi_end - phi, phi)
        rho, rho_d, rho_dd, theta = self._first_half(folded)
        theta_d = self.tau * folded / (4.0 * rho * rho)
        theta_dd = self.tau / (4.0 * rho * rho) - 2.0 * rho_d * theta_d / rho  # eq (27)
        sign = np.where(mirrored, -1.0, 1.0)
        return PlanarSamples(
            rho=rho, rho_d=sign * rho_d, rho_dd=rho_dd,
            theta=np.where(mirrored, 2.0 * self.half_sweep - theta, theta),
            theta_d=theta_d, theta_dd=sign * theta_dd)

    def _first_half(self, phi: np.ndarray) -> tuple[np.ndarray, ...]:
        """``rho, rho', rho''`` and ``Theta`` for ``0 <= phi <= phi2``."""
        quarter_tau = 0.25 * self.tau
        if self.pure_rotation:
            rho = np.full_like(phi, self.rho_start)
            zeros = np.zeros_like(phi)
            return rho, zeros, zeros, quarter_tau * phi * phi / (2.0 * self.rho_start ** 2)
        u0, um = math.asin(self.rho_start), math.asin(self.rho_mid)
        x_end = math.sqrt(0.5 * (u0 - um))
        in_first = phi <= self.phi1
        x1 = _invert_phase_time(np.where(in_first, phi, 0.0), u0, 1.0, x_end)
        x2 = _invert_phase_time(np.where(in_first, 0.0, self.phi2 - phi), um, -1.0, x_end)
        x = np.where(in_first, x1, x2)
        u = np.where(in_first, u0 - x * x, um + x * x)
        rho = np.sin(u)
        rho_d = -x  # energy integral of eq (26): rho'^2 = |asin(rho) - asin(rho_rest)|
        rho_dd = np.where(in_first, -1.0, 1.0) / (2.0 * np.cos(u))  # eq (26)
        integral = np.where(
            in_first, self._first(x1),
            self._first(x_end) + self._second(x_end) - self._second(x2))
        return rho, rho_d, rho_dd, quarter_tau * integral


def integrate_dimensionless(rho_start: float, phi1: float, phi2: float, tau: float,
                            phi: np.ndarray | None = None, rtol: float = 1e-11
                            ) -> np.ndarray:
    """Integrate eqs (26)-(27) numerically over the first half, independently of the solution.

    Parameters
    ----------
    rho_start : float
        ``rho(0)``; the tip starts at rest.
    phi1, phi2 : float
        Radial switch and midpoint.
    tau : float
        Torque ratio ``tau1 / tau3``.
    phi : array_like, optional
        Where to report the state (within ``[0, phi2]``); the default is ``[phi2]``.
    rtol : float
        Relative tolerance of ``solve_ivp`` (DOP853); the absolute one is ``rtol * 1e-2``.

    Returns
    -------
    ndarray, shape (N, 4)
        ``rho, rho', Theta, Theta'`` at each ``phi``.
    """
    phi = np.atleast_1d(np.asarray([phi2] if phi is None else phi, dtype=float))

    def rates(_, y, radial_sign):
        rho, rho_d, _, theta_d = y
        return [rho_d, radial_sign / (2.0 * math.sqrt(1.0 - rho * rho)), theta_d,
                (tau / (4.0 * rho) - 2.0 * rho_d * theta_d) / rho]

    out = np.empty((phi.size, 4))
    state = np.array([rho_start, 0.0, 0.0, 0.0])
    for lower, upper, radial_sign in ((0.0, phi1, -1.0), (phi1, phi2, 1.0)):
        if upper <= lower:
            continue
        inside = (phi >= lower) & (phi <= upper)
        solution = solve_ivp(rates, (lower, upper), state, method='DOP853', rtol=rtol,
                             atol=rtol * 1e-2, args=(radial_sign,), dense_output=True)
        if inside.any():
            out[inside] = solution.sol(phi[inside]).T
        state = solution.y[:, -1]
    return out


def torque_ratio_by_root_finding(rho_start: float, rho_mid: float, half_sweep: float) -> float:
    """Find ``tau`` by ``brentq`` on the numerical integration of eqs (26)-(27).

    The automatic version of the paper's trial and error, kept as an independent check of the
    closed form in :func:`summarize_profile` (they agree to the integration tolerance).
    """
    summary = summarize_profile(rho_start, rho_mid, half_sweep)

    def miss(tau):
        return integrate_dimensionless(rho_start, summary.phi1, summary.phi2, tau)[0, 2] \
            - half_sweep

    low, high = 1e-3 * summary.tau, 1e3 * summary.tau
    return brentq(miss, low, high, xtol=1e-14, rtol=1e-12)
