"""Which number bounds a node-to-node move, and which is only the paper's family minimum.

Three numbers describe how fast a node-to-node sweep (the coarse motion of a step) can be; only
the first is a bound:

* :func:`time_optimal_bound`: a **provable lower bound** of the duration of every move of the
  planar model with the centrifugal and Coriolis terms (eqs (19)-(20)) under the torque limits
  (limit minus Coulomb friction), the joint rate limits and ``r_min <= r <= r(0)``
  (:func:`walker_planner.core.minimum_time.lower_bound`, by relaxation). It is what the
  planner reports in ``time_optimal_bound`` and what a step's figures are divided by.
* :func:`minimum_time_found`: the **minimum time found by direct optimisation** of the same
  problem (:mod:`walker_planner.core.direct_method`): a feasible move, re-integrated, so an
  *upper* estimate of the true minimum, which lies between the two. Seconds to compute, so it
  is for reports and benchmarks, not for every plan.
* :func:`family_minimum_time`: the **paper's family minimum**, the fastest bang-bang profile
  of section 5 (eqs (21)-(27), centrifugal term neglected) under the torque limits alone. It
  is neither a lower bound (other profiles beat it in its own model) nor feasible on eqs
  (19)-(20); the planner's nominal plans are members of that family.

:func:`line_bound` is the fastest straight tip move under the planner's Cartesian acceleration
limit (a limit the planner sets, not the robot). A step's bound adds its extraction, coarse
motion and insertion bounds to its screw times (the supervisor sums the planner's answers).
"""

from __future__ import annotations

import math

import numpy as np
from walker_core.truss import Truss

from walker_planner.core.errors import NoSolutionError
from walker_planner.core.minimum_time import MoveProblem, lower_bound
from walker_planner.core.node_to_node import NodeToNodeSolution, PlanarModel, solve_node_to_node

__all__ = ['family_minimum_solution', 'family_minimum_time', 'move_problem',
           'time_optimal_bound', 'minimum_time_found', 'step_move_problem',
           'step_time_optimal_bound', 'sweep_of', 'coarse_move_bound', 'line_bound',
           'NODE_RADIUS_TOLERANCE', 'MIN_SWEEP']

#: Start and end of a node-to-node move must be this close in radius and height [m].
NODE_RADIUS_TOLERANCE = 1e-3
#: Smallest sweep [rad] that is a move at all.
MIN_SWEEP = 1e-3


def family_minimum_solution(params, sweep: float, rho_start: float,
                            rho_end: float | None = None,
                            rho_min: float | None = None) -> NodeToNodeSolution:
    """Find the fastest member of the paper's bang-bang family under the torque limits alone.

    The bang-bang node-to-node solution of section 5 at the full available torque of J1 and
    J3 (torque limit minus Coulomb friction), no rate limits, with the midpoint radius chosen
    to minimise the duration (``rho_min <= rho(phi2) <= rho(0)``), in the paper's model (eqs
    (21)-(22): centrifugal term neglected). Not a lower bound: see the module notes.

    Parameters
    ----------
    params : WalkerParameters
        The robot (lengths, masses, torque limits and friction).
    sweep : float
        Sweep angle [rad], sign ignored, in (0, pi].
    rho_start : float
        ``rho(0) = r / 2 l2`` at the start.
    rho_end : float, optional
        ``rho`` at the end; the paper's symmetric solution needs it equal to ``rho_start``.
    rho_min : float, optional
        Smallest ``rho`` at the midpoint; the default leaves the tip free to come as close
        to the yaw axis as the solution likes (``1e-3``).

    Raises
    ------
    NoSolutionError
        Unequal start and end radii, a sweep outside (0, 180] deg, a start out of reach.
    """
    if rho_end is not None and abs(rho_end - rho_start) * 2.0 * params.robot.geometry.l2 \
            > NODE_RADIUS_TOLERANCE:
        raise NoSolutionError(
            f'the node-to-node move needs equal start and end radii (the symmetric solution '
            f'of section 5), got rho = {rho_start:.6g} and {rho_end:.6g}')
    sweep = _checked_sweep(sweep)
    model = PlanarModel.from_parameters(params, torque_fraction=1.0, velocity_fraction=None)
    floor = 1e-3 if rho_min is None else rho_min
    return solve_node_to_node(model, rho_start, 0.5 * min(sweep, math.pi),
                              min(floor, rho_start))


def family_minimum_time(params, sweep: float, rho_start: float, rho_end: float | None = None,
                        rho_min: float | None = None) -> float:
    """Duration [s] of :func:`family_minimum_solution`: the paper's family minimum."""
    return family_minimum_solution(params, sweep, rho_start, rho_end, rho_min).duration


def _checked_sweep(sweep: float) -> float:
    sweep = abs(float(sweep))
    if not MIN_SWEEP <= sweep <= math.pi + 1e-12:
        raise NoSolutionError(f'sweep {math.degrees(sweep):.6g} deg is not a node-to-node move: '
                              f'it must be in (0, 180] deg')
    return min(sweep, math.pi)


def move_problem(params, sweep: float, radius: float, min_radius: float,
                 rate_limits: bool = True) -> MoveProblem:
    """Pose the minimum-time problem of a sweep at the robot's full limits.

    Parameters
    ----------
    params : WalkerParameters
        The robot: link length, tip mass ``m4 + m5``, torque limits minus Coulomb friction
        (J1, J3) and velocity limits (J1/J5, J2/J4, J3).
    sweep : float
        Sweep angle [rad], sign ignored, in (0, pi].
    radius : float
        Horizontal distance of the tip from the base yaw axis at both ends [m].
    min_radius : float
        Smallest distance of the tip from the yaw axis during the move [m] (the planner's
        ``planner.bang_bang.min_radius``); capped at ``radius``.
    rate_limits : bool
        False leaves the joint rates unlimited (the torque limits alone, as the paper's
        family minimum).
    """
    limits = PlanarModel.from_parameters(params, torque_fraction=1.0,
                                         velocity_fraction=1.0 if rate_limits else None)
    return MoveProblem(limits, float(radius), _checked_sweep(sweep),
                       min(float(min_radius), float(radius)))


def time_optimal_bound(params, sweep: float, radius: float, min_radius: float) -> float:
    """Provable lower bound [s] of a sweep's duration at the robot's torque and rate limits.

    No move of the planar model with the centrifugal and Coriolis terms (eqs (19)-(20)) that
    respects the torque limits (limit minus Coulomb friction), the joint rate limits and
    ``min_radius <= r <= radius`` is faster (:func:`walker_planner.core.minimum_time.
    lower_bound`). Parameters as :func:`move_problem`.
    """
    return lower_bound(move_problem(params, sweep, radius, min_radius))


def minimum_time_found(params, sweep: float, radius: float, min_radius: float,
                       rate_limits: bool = True):
    """Fastest feasible move found by direct optimisation of the problem of :func:`move_problem`.

    Returns a :class:`walker_planner.core.direct_method.MinimumTimeMove`: its ``duration`` is
    an upper estimate of the true minimum time, its ``lower_bound`` the bound below it. Takes
    seconds (CasADi and IPOPT are imported on first use).
    """
    from walker_planner.core.direct_method import solve_minimum_time

    return solve_minimum_time(move_problem(params, sweep, radius, min_radius, rate_limits))


def step_move_problem(params, base_node: str, from_node: str, to_node: str, *,
                      min_radius: float, rate_limits: bool = True) -> MoveProblem:
    """Pose the minimum-time problem of a step's coarse motion: the tip swings about the base.

    Parameters
    ----------
    params : WalkerParameters
        The robot and the truss.
    base_node, from_node, to_node : str
        Truss node names (``n<column>_<row>``).
    min_radius : float
        Smallest tip distance from the base yaw axis [m] (the planner's
        ``planner.bang_bang.min_radius``, 0.5 m in the parameter file).
    rate_limits : bool
        False: the torque limits alone.

    Raises
    ------
    UnknownNodeError
        A node that is not on the truss.
    NoSolutionError
        Nodes at different distances from the base, or a move that is not a sweep.
    """
    truss = Truss.from_parameters(params)
    base = truss.position(base_node)
    start, goal = truss.position(from_node) - base, truss.position(to_node) - base
    sweep, problem = sweep_of(start, goal)
    if problem is not None:
        raise NoSolutionError(problem)
    return move_problem(params, sweep, math.hypot(start[0], start[1]), min_radius, rate_limits)


def step_time_optimal_bound(params, base_node: str, from_node: str, to_node: str, *,
                            min_radius: float) -> float:
    """Provable lower bound [s] of a step's coarse motion (see :func:`time_optimal_bound`).

    Parameters as :func:`step_move_problem`; ``min_radius`` has no default so that every
    figure says which one it used.
    """
    return lower_bound(step_move_problem(params, base_node, from_node, to_node,
                                         min_radius=min_radius))


def sweep_of(start, goal) -> tuple[float, str | None]:
    """Sweep [rad] of a tip move about the base yaw axis, and why it is not one (or None).

    ``start`` and ``goal`` are tip positions in the base frame [m]; a sweep keeps the radius
    and the height (within :data:`NODE_RADIUS_TOLERANCE`) and changes the angle.
    """
    start, goal = np.asarray(start, dtype=float), np.asarray(goal, dtype=float)
    r_start, r_goal = math.hypot(start[0], start[1]), math.hypot(goal[0], goal[1])
    sweep = abs(math.remainder(math.atan2(-goal[0], goal[1])
                               - math.atan2(-start[0], start[1]), 2.0 * math.pi))
    if abs(r_start - r_goal) > NODE_RADIUS_TOLERANCE:
        return sweep, (f'start and goal are {r_start:.4f} m and {r_goal:.4f} m from the base '
                       f'yaw axis: a node-to-node sweep keeps the radius')
    if abs(start[2] - goal[2]) > NODE_RADIUS_TOLERANCE:
        return sweep, f'start and goal heights differ ({start[2]:.4f} m, {goal[2]:.4f} m)'
    if sweep < MIN_SWEEP or r_start <= 0.0:
        return sweep, 'start and goal are at the same angle about the base: no sweep'
    return sweep, None


def coarse_move_bound(params, start, goal, min_radius: float) -> float | None:
    """:func:`time_optimal_bound` [s] of a tip move, or None when it is not a sweep.

    ``start`` and ``goal`` are tip positions in the base frame [m] (the planar model neglects
    their common height); ``None`` also when the move has no solution (out of reach).
    """
    sweep, problem = sweep_of(start, goal)
    if problem is not None:
        return None
    radius = math.hypot(float(start[0]), float(start[1]))
    try:
        return time_optimal_bound(params, sweep, radius, min(min_radius, radius))
    except NoSolutionError:
        return None


def line_bound(length: float, acceleration_limit: float) -> float:
    """Fastest rest-to-rest straight move [s] of ``length`` [m] at ``acceleration_limit``."""
    if not acceleration_limit > 0:
        raise ValueError(f'the acceleration limit must be positive, got {acceleration_limit}')
    return 2.0 * math.sqrt(abs(float(length)) / acceleration_limit)
