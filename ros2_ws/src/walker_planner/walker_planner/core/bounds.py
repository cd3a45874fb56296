"""The time-optimal bound of a node-to-node move: the fastest bang-bang motion the torques allow.

The bound is the duration of the bang-bang node-to-node solution (paper section 5) at the full
available torque of J1 and J3 (torque limit minus Coulomb friction), with the midpoint radius
chosen to minimise it (``rho_min <= rho(phi2) <= rho(0)``) and no rate limits: the honest
physical bound of the paper's model. Any plan's duration can be reported against it, so a step
can be said to have taken, e.g., 2.3 times the bound.

It is the minimum over the paper's family of bang-bang profiles (each axis switching as in
Figure 8, one of the two torques at its limit), not a proof of global time optimality; and the
joint velocity limits, which it ignores, can make real steps much slower (see docs/planner.md).

:func:`sweep_rate_bound` is the other lower bound of a sweep: the base yaw cannot turn faster
than its velocity limit, nor speed up faster than its available torque over the smallest yaw
inertia the sweep can have. The larger of the two bounds a node-to-node move from below
(:func:`coarse_move_bound`); :func:`line_bound` bounds a straight tip move under the planner's
Cartesian acceleration limit. A step's bound adds these to its screw times (the supervisor).
"""

from __future__ import annotations

import math

import numpy as np

from walker_core.truss import Truss
from walker_planner.core.errors import NoSolutionError
from walker_planner.core.node_to_node import (
    NodeToNodeSolution, PlanarModel, solve_node_to_node)

__all__ = ['bound_solution', 'time_optimal_bound', 'step_time_optimal_bound',
           'tip_move_bound', 'sweep_rate_bound', 'coarse_move_bound', 'line_bound',
           'NODE_RADIUS_TOLERANCE', 'MIN_SWEEP']

#: Start and end of a node-to-node move must be this close in radius and height [m].
NODE_RADIUS_TOLERANCE = 1e-3
#: Smallest sweep [rad] that is a move at all.
MIN_SWEEP = 1e-3


def bound_solution(params, sweep: float, rho_start: float, rho_end: float | None = None,
                   rho_min: float | None = None) -> NodeToNodeSolution:
    """Bang-bang solution at the full available torque for a sweep.

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
            f'the node-to-node bound needs equal start and end radii (the symmetric solution of '
            f'section 5), got rho = {rho_start:.6g} and {rho_end:.6g}')
    sweep = abs(float(sweep))
    if not MIN_SWEEP <= sweep <= math.pi + 1e-12:
        raise NoSolutionError(f'sweep {math.degrees(sweep):.6g} deg is not a node-to-node move: '
                              f'it must be in (0, 180] deg')
    model = PlanarModel.from_parameters(params, torque_fraction=1.0, velocity_fraction=None)
    floor = 1e-3 if rho_min is None else rho_min
    return solve_node_to_node(model, rho_start, 0.5 * min(sweep, math.pi),
                              min(floor, rho_start))


def time_optimal_bound(params, sweep: float, rho_start: float, rho_end: float | None = None,
                       rho_min: float | None = None) -> float:
    """Shortest node-to-node duration [s] under the torque limits (see :func:`bound_solution`)."""
    return bound_solution(params, sweep, rho_start, rho_end, rho_min).duration


def step_time_optimal_bound(params, base_node: str, from_node: str, to_node: str,
                            min_radius: float | None = None) -> float:
    """Time-optimal bound [s] of a step: the tip swings about ``base_node`` between two nodes.

    Parameters
    ----------
    params : WalkerParameters
        The robot and the truss.
    base_node, from_node, to_node : str
        Truss node names (``n<column>_<row>``).
    min_radius : float, optional
        Smallest tip distance from the base yaw axis at the midpoint [m].

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
    return tip_move_bound(params, start, goal, min_radius, strict=True)


def tip_move_bound(params, start, goal, min_radius: float | None = None,
                   strict: bool = False) -> float | None:
    """Time-optimal bound [s] of a tip move between two points in the base frame, if it is a sweep.

    Returns ``None`` (or raises :class:`NoSolutionError` when ``strict``) when the two points are
    not at the same distance from the base yaw axis and height, or do not differ in angle.
    """
    start, goal = np.asarray(start, dtype=float), np.asarray(goal, dtype=float)
    r_start, r_goal = math.hypot(start[0], start[1]), math.hypot(goal[0], goal[1])
    sweep = abs(math.remainder(math.atan2(-goal[0], goal[1])
                               - math.atan2(-start[0], start[1]), 2.0 * math.pi))
    problem = None
    if abs(r_start - r_goal) > NODE_RADIUS_TOLERANCE:
        problem = (f'start and goal are {r_start:.4f} m and {r_goal:.4f} m from the base yaw '
                   f'axis: a node-to-node sweep keeps the radius')
    elif abs(start[2] - goal[2]) > NODE_RADIUS_TOLERANCE:
        problem = f'start and goal heights differ ({start[2]:.4f} m, {goal[2]:.4f} m)'
    elif sweep < MIN_SWEEP or r_start <= 0.0:
        problem = 'start and goal are at the same angle about the base: no sweep'
    if problem is not None:
        if strict:
            raise NoSolutionError(problem)
        return None
    l2 = params.robot.geometry.l2
    rho_min = None if min_radius is None else min_radius / (2.0 * l2)
    try:
        return time_optimal_bound(params, sweep, r_start / (2.0 * l2), rho_min=rho_min)
    except NoSolutionError:
        if strict:
            raise
        return None


def _rest_to_rest_time(distance: float, speed: float, acceleration: float) -> float:
    """Fastest rest-to-rest move [s] of ``distance`` under a speed and an acceleration limit."""
    if distance * acceleration <= speed * speed:  # never reaches the speed limit
        return 2.0 * math.sqrt(distance / acceleration)
    return distance / speed + speed / acceleration


def sweep_rate_bound(params, sweep: float, min_radius: float, height: float = 0.0) -> float:
    """Lower bound [s] of a sweep from the base yaw's velocity limit and available torque.

    The yaw J1 must turn through ``sweep`` from rest to rest at no more than its velocity limit,
    accelerating at no more than its available torque (limit minus Coulomb friction) over the
    smallest yaw inertia the tip can give it (the tip at ``min_radius`` from the axis; eq (9),
    corrected, which includes the rotor inertia).

    Parameters
    ----------
    params : WalkerParameters
    sweep : float
        Sweep angle [rad], sign ignored.
    min_radius : float
        Smallest distance [m] of the tip from the yaw axis during the sweep.
    height : float
        Tip height [m] above the base during the sweep.
    """
    from walker_core.dynamics import RigidModel, diagonal_inertia
    from walker_core.kinematics import WalkerKinematics

    drive = params.robot.drive.yaw
    kinematics = WalkerKinematics(params.robot.geometry.l1, params.robot.geometry.l2)
    joints = kinematics.inverse([0.0, float(min_radius), float(height), 0.0, 0.0])
    inertia = diagonal_inertia(joints, RigidModel.from_parameters(params))[0]
    acceleration = (drive.torque_limit - drive.friction_torque) / inertia
    return _rest_to_rest_time(abs(float(sweep)), drive.velocity_limit, acceleration)


def coarse_move_bound(params, start, goal, min_radius: float) -> float | None:
    """Lower bound [s] of a node-to-node move: the larger of the torque and the rate bounds.

    ``None`` when the move is not a sweep about the base at one radius and height
    (:func:`tip_move_bound`).
    """
    torque = tip_move_bound(params, start, goal, min_radius)
    if torque is None:
        return None
    start, goal = np.asarray(start, dtype=float), np.asarray(goal, dtype=float)
    sweep = abs(math.remainder(math.atan2(-goal[0], goal[1])
                               - math.atan2(-start[0], start[1]), 2.0 * math.pi))
    rate = sweep_rate_bound(params, sweep, min_radius, float(start[2]))
    return max(torque, rate)


def line_bound(length: float, acceleration_limit: float) -> float:
    """Fastest rest-to-rest straight move [s] of ``length`` [m] at ``acceleration_limit``."""
    if not acceleration_limit > 0:
        raise ValueError(f'the acceleration limit must be positive, got {acceleration_limit}')
    return 2.0 * math.sqrt(abs(float(length)) / acceleration_limit)
