"""The minimum-time node-to-node move found by a direct method, and its re-integration.

:func:`solve_minimum_time` transcribes the problem of :mod:`walker_planner.core.minimum_time`
by multiple shooting: ``N`` intervals of equal length ``T / N``, the torques constant on each
(zero-order hold, as a controller applies them), the state ``(u, u', Theta, Theta')`` a
variable at every node, each interval integrated by ``M`` classical Runge-Kutta steps whose
end must meet the next node. The torque limits bound the controls; the radius and rate limits
bound the state at every node and every Runge-Kutta step. IPOPT (through CasADi, with exact
derivatives) minimises ``T`` from several starting guesses; the shortest move that
re-integrates feasibly is returned.

Every returned move is re-integrated with ``scipy.integrate.solve_ivp`` (DOP853) under its
piecewise-constant torques, independently of the transcription, and carries how far it ends
from the goal and how far it strays over a limit between the nodes
(:class:`Reintegration`). Its duration is a duration some feasible move achieves: an upper
estimate of the true minimum, never a bound from below (a nonconvex problem has no
certificate of global optimality); :func:`walker_planner.core.minimum_time.lower_bound` is the
bound from below, and both are reported.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import time as _time

import numpy as np
from scipy.integrate import solve_ivp

from walker_planner.core.errors import NoSolutionError
from walker_planner.core.minimum_time import MoveProblem, lower_bound

__all__ = ['MinimumTimeMove', 'Reintegration', 'solve_minimum_time', 'reintegrate',
           'INTERVALS', 'RUNGE_KUTTA_STEPS', 'FEASIBILITY_TOLERANCE']

#: Intervals of constant torque (the move's control resolution).
INTERVALS = 60
#: Runge-Kutta steps per interval in the transcription.
RUNGE_KUTTA_STEPS = 4
#: A returned move ends within this of the goal (m, rad, m/s, rad/s) and exceeds a rate or
#: radius limit by at most this fraction of it, when re-integrated.
FEASIBILITY_TOLERANCE = 1e-5
#: The transcription keeps this fraction inside the rate and radius limits, so that what
#: happens between its Runge-Kutta points stays within them.
_LIMIT_MARGIN = 1e-4
_STARTS = (('constant radius', 0.0), ('half-way in', 0.5), ('in to r_min', 1.0))


@dataclasses.dataclass(frozen=True)
class Reintegration:
    """A move's torques driven through the model by ``solve_ivp`` (DOP853, rtol 1e-11).

    Attributes
    ----------
    end_error : float
        Largest miss at the end: radius [m], angle [rad], radial and tip speeds [m/s].
    radius_excess, rate_excess : float
        Largest excess over a radius limit, and over a rate limit, along the move, as a
        fraction of that limit (0 or negative: within the limits).
    """

    end_error: float
    radius_excess: float
    rate_excess: float

    @property
    def limit_excess(self) -> float:
        """Largest excess over any limit, as a fraction of it."""
        return max(self.radius_excess, self.rate_excess)

    def feasible(self, tolerance: float = FEASIBILITY_TOLERANCE) -> bool:
        """Tell whether the move reaches the goal at rest within every limit, to ``tolerance``."""
        return self.end_error <= tolerance and self.limit_excess <= tolerance


@dataclasses.dataclass(frozen=True)
class MinimumTimeMove:
    """The fastest move the direct method found, its re-integration and the lower bound.

    Attributes
    ----------
    problem : MoveProblem
        What was solved.
    duration : float
        ``T_found`` [s]: the duration of this feasible move, an upper estimate of the true
        minimum time.
    lower_bound : float
        The provable lower bound [s] of :func:`walker_planner.core.minimum_time.lower_bound`.
    times : ndarray, shape (N + 1,)
        Node times [s].
    states : ndarray, shape (N + 1, 4)
        ``u = th2`` [rad], ``u'`` [rad/s], ``Theta`` [rad], ``Theta'`` [rad/s] at the nodes,
        as the re-integration reaches them.
    torques : ndarray, shape (N, 2)
        J1 torque ``tau1`` and radial torque ``S3 tau3`` (positive pushes the tip outwards;
        the J3 joint torque is its negative) [N*m] on each interval.
    starts : tuple of float
        ``T`` each starting guess converged to [s] (``nan``: no feasible move from it).
    solve_time : float
        Wall-clock time of the solves [s], building the solver excluded.
    reintegration : Reintegration
        The check of this move by ``solve_ivp``.
    """

    problem: MoveProblem
    duration: float
    lower_bound: float
    times: np.ndarray
    states: np.ndarray
    torques: np.ndarray
    starts: tuple
    solve_time: float
    reintegration: Reintegration

    @property
    def radius(self) -> np.ndarray:
        """Tip radius ``r = 2 l sin u`` [m] at the nodes."""
        return 2.0 * self.problem.limits.link_length * np.sin(self.states[:, 0])

    @property
    def optimality_gap(self) -> float:
        """``(T_found - lower_bound) / lower_bound``: how far from optimal the move can be."""
        return self.duration / self.lower_bound - 1.0


@functools.lru_cache(maxsize=4)
def _solver(intervals: int, steps: int):
    """Build the parametric NLP and its IPOPT solver (once per process and size)."""
    import casadi as ca

    state, control = ca.SX.sym('x', 4), ca.SX.sym('c', 2)
    length, params = ca.SX.sym('h'), ca.SX.sym('p', 8)
    link, tip, vertex, yaw_inertia, pitch_inertia, centrifugal, tau1, tau3 = ca.vertsplit(
        params)

    def derivative(x):
        """Eqs (19)-(20) in ``u = th2`` (PlanarDynamics.accelerations, as expressions)."""
        s, c = ca.sin(x[0]), ca.cos(x[0])
        swing = (vertex + 4.0 * tip) * link ** 2
        a, a_u = swing * s * s + yaw_inertia, 2.0 * swing * s * c
        b = vertex * link ** 2 + 4.0 * tip * link ** 2 * c * c + pitch_inertia
        b_u = -8.0 * tip * link ** 2 * s * c
        u_dd = (2.0 * control[1] * tau3 - 0.5 * b_u * x[1] ** 2
                + centrifugal * 0.5 * a_u * x[3] ** 2) / b
        return ca.vertcat(x[1], u_dd, x[3], (control[0] * tau1 - a_u * x[1] * x[3]) / a)

    x, inner = state, []
    sub = length / steps
    for step in range(steps):
        k1 = derivative(x)
        k2 = derivative(x + 0.5 * sub * k1)
        k3 = derivative(x + 0.5 * sub * k2)
        k4 = derivative(x + sub * k3)
        x = x + sub / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        if step < steps - 1:
            inner.append(ca.vertcat(x[0], x[1], x[3]))
    interval = ca.Function('interval', [state, control, length, params],
                           [x, ca.vertcat(*inner) if inner else ca.SX(0, 1)])
    mapped = interval.map(intervals)
    duration = ca.MX.sym('T')
    nodes, controls = ca.MX.sym('X', 4, intervals + 1), ca.MX.sym('U', 2, intervals)
    p = ca.MX.sym('p', 8)
    ends, path = mapped(nodes[:, :-1], controls, duration / intervals, p)
    variables = ca.vertcat(duration, ca.vec(nodes), ca.vec(controls))
    constraints = ca.vertcat(ca.vec(ends - nodes[:, 1:]), ca.vec(path))
    problem = {'x': variables, 'p': p, 'f': duration, 'g': constraints}
    options = {'print_time': False, 'ipopt.print_level': 0, 'ipopt.sb': 'yes',
               'ipopt.tol': 1e-10, 'ipopt.max_iter': 1000}
    return ca.nlpsol('minimum_time', 'ipopt', problem, options)


def _parameters(problem: MoveProblem) -> list[float]:
    d, limits = problem.dynamics, problem.limits
    return [d.link_length, d.tip_mass, d.vertex_mass, d.yaw_inertia, d.pitch_inertia,
            1.0 if d.centrifugal else 0.0, limits.circular_torque, limits.radial_torque]


def _bounds(problem: MoveProblem, intervals: int, steps: int):
    """Variable and constraint bounds: the ends fixed, the limits on every node and step.

    The limits are tightened by ``_LIMIT_MARGIN``, except ``r_max`` within the first and last
    intervals: the move starts and ends there, at rest (no centrifugal bulge to guard against).
    """
    u0 = problem.angle(problem.start_radius)
    u_min = problem.angle(min(problem.min_radius * (1.0 + _LIMIT_MARGIN), problem.start_radius))
    u_max = max(problem.angle(problem.max_radius * (1.0 - _LIMIT_MARGIN)), u_min)
    radial, yaw = (problem.radial_rate * (1.0 - _LIMIT_MARGIN),
                   problem.limits.yaw_rate * (1.0 - _LIMIT_MARGIN))
    low = np.tile([u_min, -radial, -np.inf, -yaw], (intervals + 1, 1))
    high = np.tile([u_max, radial, np.inf, yaw], (intervals + 1, 1))
    low[0] = high[0] = [u0, 0.0, 0.0, 0.0]
    low[-1] = high[-1] = [u0, 0.0, problem.sweep, 0.0]
    lbx = np.concatenate([[0.0], low.ravel(), -np.ones(2 * intervals)])
    ubx = np.concatenate([[60.0], high.ravel(), np.ones(2 * intervals)])
    path_low = np.tile([u_min, -radial, -yaw], (intervals, steps - 1))
    path_high = np.tile([u_max, radial, yaw], (intervals, steps - 1))
    path_high[[0, -1], 0::3] = problem.angle(problem.max_radius)
    lbg = np.concatenate([np.zeros(4 * intervals), path_low.ravel()])
    ubg = np.concatenate([np.zeros(4 * intervals), path_high.ravel()])
    return lbx, ubx, lbg, ubg


def _guess(problem: MoveProblem, depth: float, duration: float, intervals: int) -> np.ndarray:
    """Guess a smooth sweep of ``duration``, the radius dipping ``depth`` of the way in."""
    t = np.linspace(0.0, 1.0, intervals + 1)
    u0, u_min = problem.angle(problem.start_radius), problem.angle(problem.min_radius)
    u = u0 - depth * (u0 - u_min) * np.sin(math.pi * t) ** 2
    u_d = -depth * (u0 - u_min) * math.pi * np.sin(2.0 * math.pi * t) / duration
    theta = problem.sweep * (3.0 * t ** 2 - 2.0 * t ** 3)
    theta_d = problem.sweep * 6.0 * (t - t * t) / duration
    nodes = np.column_stack([u, u_d, theta, theta_d])
    return np.concatenate([[duration], nodes.ravel(), np.zeros(2 * intervals)])


def reintegrate(problem: MoveProblem, duration: float, torques: np.ndarray,
                samples_per_interval: int = 16) -> tuple[Reintegration, np.ndarray]:
    """Drive the model with piecewise-constant torques from rest and check the move.

    Parameters
    ----------
    problem : MoveProblem
        The move and its limits.
    duration : float
        Move duration [s]; the torques are held on equal intervals.
    torques : ndarray, shape (N, 2)
        ``tau1`` and ``S3 tau3`` [N*m] per interval.
    samples_per_interval : int
        Points per interval where the limits are checked.

    Returns
    -------
    (Reintegration, ndarray)
        The check, and the states ``(u, u', Theta, Theta')`` at the interval ends (N + 1, 4).
    """
    torques = np.asarray(torques, dtype=float)
    edges = np.linspace(0.0, duration, len(torques) + 1)
    dynamics = problem.dynamics
    state = np.array([problem.angle(problem.start_radius), 0.0, 0.0, 0.0])
    ends, samples = [state], []

    def rates(_, y, circular, radial):
        u_dd, theta_dd = dynamics.accelerations(y, circular, radial)
        return [y[1], u_dd, y[3], theta_dd]

    for start, stop, (circular, radial) in zip(edges[:-1], edges[1:], torques, strict=True):
        solution = solve_ivp(rates, (start, stop), state, method='DOP853', rtol=1e-11,
                             atol=1e-13, args=(circular, radial), dense_output=True)
        samples.append(solution.sol(np.linspace(start, stop, samples_per_interval)).T)
        state = solution.y[:, -1]
        ends.append(state)
    samples = np.concatenate(samples)
    link = problem.limits.link_length
    radius = 2.0 * link * np.sin(samples[:, 0])
    radius_excess = max(np.max((problem.min_radius - radius) / problem.min_radius),
                        np.max((radius - problem.max_radius) / problem.max_radius))
    rate_excess = max(np.max(np.abs(samples[:, 1])) / problem.radial_rate,
                      np.max(np.abs(samples[:, 3])) / problem.limits.yaw_rate) - 1.0
    u, u_d, theta, theta_d = state
    r_end = 2.0 * link * math.sin(u)
    miss = max(abs(r_end - problem.start_radius), abs(theta - problem.sweep),
               abs(2.0 * link * math.cos(u) * u_d), abs(r_end * theta_d))
    return (Reintegration(float(miss), float(radius_excess), float(rate_excess)),
            np.array(ends))


def _within_rates(problem: MoveProblem, duration: float, torques: np.ndarray):
    """Re-integrate a move; if it exceeds a rate limit, follow its path that much slower.

    Following the same path ``k`` times slower takes ``1 / k^2`` of the torques and divides
    every rate by ``k`` (each term of eqs (19)-(20) is quadratic in the time scale), so a
    rate excess ``e`` between the transcription's points is removed by ``k = 1 + e``.
    """
    check, states = reintegrate(problem, duration, torques)
    if check.rate_excess > 0.0 and check.radius_excess <= FEASIBILITY_TOLERANCE:
        scale = 1.0 + 1.01 * check.rate_excess + 1e-12
        duration, torques = duration * scale, torques / scale ** 2
        check, states = reintegrate(problem, duration, torques)
    return duration, torques, check, states


def solve_minimum_time(problem: MoveProblem, intervals: int = INTERVALS,
                       steps: int = RUNGE_KUTTA_STEPS) -> MinimumTimeMove:
    """Find the fastest feasible move by multiple shooting from several starting guesses.

    Parameters
    ----------
    problem : MoveProblem
        The move and its limits.
    intervals : int
        Intervals of constant torque.
    steps : int
        Runge-Kutta steps per interval.

    Returns
    -------
    MinimumTimeMove
        The shortest move whose re-integration is feasible (:class:`Reintegration`).

    Raises
    ------
    NoSolutionError
        When no starting guess gives a feasible move.

    Notes
    -----
    The starts are a sweep at constant radius, one dipping half-way to ``r_min`` and one
    dipping to it, each of 1.3 times the lower bound.
    """
    solver = _solver(intervals, steps)
    bound = lower_bound(problem)
    lbx, ubx, lbg, ubg = _bounds(problem, intervals, steps)
    lbx[0] = 0.5 * bound  # no move is faster than the bound; leave the solver room
    parameters = _parameters(problem)
    limits = np.repeat([[problem.limits.circular_torque, problem.limits.radial_torque]],
                       intervals, axis=0)
    best, durations, clock = None, [], _time.perf_counter()
    for _, depth in _STARTS:
        guess = _guess(problem, depth, 1.3 * bound, intervals)
        result = solver(x0=guess, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg, p=parameters)
        found = np.asarray(result['x']).ravel()
        if not solver.stats()['success']:
            durations.append(math.nan)
            continue
        controls = np.clip(found[1 + 4 * (intervals + 1):], -1.0, 1.0)  # IPOPT relaxes bounds
        duration, torques, check, states = _within_rates(
            problem, float(found[0]), controls.reshape(intervals, 2) * limits)
        durations.append(duration if check.feasible() else math.nan)
        if check.feasible() and (best is None or duration < best[0]):
            best = (duration, states, torques, check)
    elapsed = _time.perf_counter() - clock
    if best is None:
        raise NoSolutionError(
            f'no feasible minimum-time move found for a {math.degrees(problem.sweep):.4g} deg '
            f'sweep at r = {problem.start_radius:.4g} m (r_min = {problem.min_radius:.4g} m) '
            f'from any of {len(_STARTS)} starting guesses')
    duration, states, torques, check = best
    return MinimumTimeMove(problem, duration, bound, np.linspace(0.0, duration, intervals + 1),
                           states, torques, tuple(durations), elapsed, check)
