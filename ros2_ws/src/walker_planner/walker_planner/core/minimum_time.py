"""The minimum-time node-to-node move and a provable lower bound of its duration.

The problem
-----------
The tip (planar model of section 5, Figure 7) moves from rest at radius ``r0`` to rest at the
same radius, ``sweep`` further round the base yaw axis, under

* the torque limits ``|tau1| <= tau1_max`` (J1, drives ``Theta``) and ``|tau3| <= tau3_max``
  (J3, drives ``r``), each the drive's torque limit minus its Coulomb friction, in both
  directions;
* the joint rate limits ``|Theta'| <= w_yaw`` (J1 and J5), ``|th2'| <= w_pitch`` (J2 and J4)
  and ``|th3'| = 2 |th2'| <= w_vertex`` (J3);
* ``r_min <= r <= r_max``, ``r_max`` the start radius unless given: the tip comes no closer
  to the yaw axis than ``r_min`` (the planner's ``min_radius``) and goes no farther out than
  it starts.

The dynamics are eqs (17)-(20) with the centrifugal term ``r Theta'^2`` that eqs (21)-(22)
drop, in the coordinates ``u = th2`` (``r = 2 l sin u``) of
:class:`walker_planner.core.simplification.PlanarDynamics` (its ``full`` model: the tip mass
only). Its minimum time ``T_opt`` is what the step figures compare against.

What this module can claim
--------------------------
The problem is nonconvex, so a direct method (:mod:`walker_planner.core.direct_method`) finds
a feasible move whose duration ``T_found`` is an *upper* estimate of ``T_opt``. A lower bound
needs a proof; :func:`lower_bound` gives one by relaxation:

1. The angular momentum ``h = A(u) Theta'`` obeys ``h' = tau1`` exactly (eq (20) times
   ``r``), so at rest at both ends ``|h(t)| <= tau1_max min(t, T - t)``.
2. Inward, ``u'' >= -2 tau3_max / B(u)``: the centrifugal and the ``u'^2`` terms of the
   radial equation only push outwards (``A_u >= 0 >= B_u`` on ``0 < u < pi/2``). With
   ``u <= u_max`` and ``|u'| <= min(w_pitch, w_vertex / 2)``, ``u(t) >= u_low(s)``, ``s =
   min(t, T - t)``: the fastest dive from rest, floored at ``u_min``.
3. Hence ``Theta'(t) <= f(s) = min(w_yaw, tau1_max s / A(u_low(s)))``, and a move of duration
   ``T`` sweeps at most ``S(T) = 2 int_0^{T/2} f(s) ds``. ``f`` is nondecreasing, so ``S`` is
   nondecreasing in ``T`` and its right Riemann sum over-estimates it; the smallest ``T``
   whose sum reaches the sweep is at most the duration of *every* feasible move.

So ``lower_bound <= T_opt <= T_found``, and the gap ``T_found - lower_bound`` says how far
from optimal the move found can be. The bound holds on the paper's own model too (eqs (21),
(22) keep 1 and 2), so it is also below the paper's bang-bang family minimum
(:func:`walker_planner.core.bounds.family_minimum_time`), which is only a minimum over that
family, in a model without the centrifugal term.

Every claim is about this model. On the robot the rotors and the vertex mass add inertia about
the yaw axis (slower), but Coulomb friction, which the available torque subtracts in both
directions, helps a joint brake: the bound is not a proof about the plant.
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np
from scipy.optimize import brentq

from walker_planner.core.errors import NoSolutionError
from walker_planner.core.node_to_node import PlanarModel
from walker_planner.core.simplification import PlanarDynamics

__all__ = ['MoveProblem', 'lower_bound', 'sweep_reachable', 'RIEMANN_PANELS']

#: Panels of the right Riemann sum of :func:`sweep_reachable` (an over-estimate of the sweep).
RIEMANN_PANELS = 4000
#: The tip must stay this far [rad of u = th2] from the stretched V (u = pi/2).
_STRETCH_MARGIN = 1e-3


@dataclasses.dataclass(frozen=True)
class MoveProblem:
    """A rest-to-rest node-to-node move and its limits (see the module notes).

    Attributes
    ----------
    limits : PlanarModel
        Link length, tip mass, the torque limits ``circular_torque`` (J1) and
        ``radial_torque`` (J3) [N*m] and the rate limits ``yaw_rate``, ``pitch_rate``,
        ``vertex_rate`` [rad/s] (``inf`` for none).
    start_radius : float
        ``r0`` [m], the tip's horizontal distance from the base yaw axis at both ends.
    sweep : float
        Angle [rad] the tip turns about the yaw axis, in (0, pi].
    min_radius : float
        ``r_min`` [m], in (0, r0].
    max_radius : float, optional
        ``r_max`` [m], at least ``r0`` and short of the stretched V ``2 l``; the default is
        ``r0``.
    dynamics : PlanarDynamics, optional
        The model; the default is eqs (19)-(20) with the tip mass only (``full``).

    Raises
    ------
    NoSolutionError
        A radius, sweep or model out of range, naming it.
    """

    limits: PlanarModel
    start_radius: float
    sweep: float
    min_radius: float
    max_radius: float | None = None
    dynamics: PlanarDynamics | None = None

    def __post_init__(self) -> None:
        reach = 2.0 * self.limits.link_length
        if self.max_radius is None:
            object.__setattr__(self, 'max_radius', float(self.start_radius))
        if self.dynamics is None:
            object.__setattr__(self, 'dynamics', PlanarDynamics(self.limits.link_length,
                                                                self.limits.tip_mass))
        for name in ('start_radius', 'sweep', 'min_radius', 'max_radius'):
            if not math.isfinite(getattr(self, name)):
                raise NoSolutionError(f'{name} must be finite, got {getattr(self, name)!r}')
        if not 0.0 < self.min_radius <= self.start_radius:
            raise NoSolutionError(
                f'min_radius {self.min_radius:.6g} m must be in (0, start radius '
                f'{self.start_radius:.6g} m]')
        if not self.start_radius <= self.max_radius < reach * math.sin(0.5 * math.pi
                                                                        - _STRETCH_MARGIN):
            raise NoSolutionError(
                f'max_radius {self.max_radius:.6g} m must be at least the start radius '
                f'{self.start_radius:.6g} m and short of the stretched V (2 l2 = {reach:.6g} m)')
        if not 0.0 < self.sweep <= math.pi + 1e-12:
            raise NoSolutionError(f'sweep {math.degrees(self.sweep):.6g} deg is not a '
                                  f'node-to-node move: it must be in (0, 180] deg')
        if self.dynamics.link_length != self.limits.link_length:
            raise NoSolutionError('the dynamics and the limits must have the same link length')

    def angle(self, radius: float) -> float:
        """``u = th2 = asin(r / 2l)`` [rad] of a radius [m]."""
        return math.asin(radius / (2.0 * self.limits.link_length))

    @property
    def radial_rate(self) -> float:
        """Largest ``|u'| = |th2'|`` [rad/s]: J2 and J4 turn at it, J3 at twice it."""
        return min(self.limits.pitch_rate, 0.5 * self.limits.vertex_rate)

    @property
    def inward_acceleration(self) -> float:
        """Largest inward ``-u''`` [rad/s^2] anywhere in the problem: ``2 tau3_max / B(u_max)``."""
        _, _, b, _ = self.dynamics.coefficients(self.angle(self.max_radius))
        return 2.0 * self.limits.radial_torque / float(b)


def _inward_reach(problem: MoveProblem, s: np.ndarray) -> np.ndarray:
    """Largest decrease of ``u`` [rad] in time ``s`` from rest (acceleration and rate capped)."""
    acceleration, rate = problem.inward_acceleration, problem.radial_rate
    free = 0.5 * acceleration * s * s
    if math.isinf(rate):
        return free
    knee = rate / acceleration
    return np.where(s <= knee, free, rate * s - 0.5 * rate * knee)


def sweep_reachable(problem: MoveProblem, duration: float,
                    panels: int = RIEMANN_PANELS) -> float:
    """Over-estimate of the largest sweep [rad] any feasible move of ``duration`` [s] makes.

    The right Riemann sum of ``S(T) = 2 int_0^{T/2} f(s) ds`` (module notes, step 3); ``f``
    is nondecreasing, so the sum is at least the integral.
    """
    half = 0.5 * float(duration)
    s = half * np.arange(1, panels + 1) / panels
    u0, u_min = problem.angle(problem.start_radius), problem.angle(problem.min_radius)
    u_low = np.maximum(u_min, u0 - _inward_reach(problem, s))
    inertia, _, _, _ = problem.dynamics.coefficients(u_low)
    rate = np.minimum(problem.limits.yaw_rate, problem.limits.circular_torque * s / inertia)
    return float(2.0 * half / panels * np.sum(rate))


@functools.lru_cache(maxsize=256)
def lower_bound(problem: MoveProblem, panels: int = RIEMANN_PANELS) -> float:
    """Bound from below [s] the duration of every feasible move of the problem (provably).

    Parameters
    ----------
    problem : MoveProblem
        The move and its limits.
    panels : int
        Panels of the Riemann sum (more: a tighter bound, never an invalid one).

    Returns
    -------
    float
        The smallest ``T`` with :func:`sweep_reachable` ``>= sweep`` (to 1e-12 s, rounded
        down): no move under the problem's torque, rate and radius limits is faster.
        Remembered per problem (a few milliseconds to compute).

    Notes
    -----
    The relaxation of the module notes: the angular momentum balance of eq (20), the inward
    bound of the radial eq (19), the rate limits. It holds with or without the centrifugal
    term and for every :class:`PlanarDynamics`.
    """
    def shortfall(duration):
        return sweep_reachable(problem, duration, panels) - problem.sweep

    high = 1.0
    while shortfall(high) < 0.0:
        high *= 2.0
    low = high / 2.0 if high > 1.0 else 0.0
    bound = brentq(shortfall, low, high, xtol=1e-13, rtol=4 * np.finfo(float).eps)
    while bound > 0.0 and shortfall(bound) >= 0.0:  # brentq may land just above the root
        bound = math.nextafter(bound, 0.0) - 1e-12
    return max(bound, 0.0)
