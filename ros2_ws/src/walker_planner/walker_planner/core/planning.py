"""From a planning request to a sampled joint trajectory: validation, building, mapping, checks.

:func:`plan` is everything the planner node's service does, without ROS: it refuses a malformed
or impossible request with a :class:`~walker_planner.core.errors.PlanningError` naming what was
wrong, builds the requested type, maps a Cartesian one to joint space, samples it every control
period, checks the samples against the joint limits and reports the time-optimal bound.
Joint vectors on the wire are in physical order (``a_yaw_joint`` .. ``b_yaw_joint``); inside,
everything is in role order J1..J5 of the given base gripper (:mod:`walker_core.joint_roles`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from walker_core.joint_roles import GRIPPERS, joint_of_role, physical_to_roles, roles_to_physical
from walker_core.kinematics import KinematicsError, WalkerKinematics
from walker_planner.core.bounds import (
    MIN_SWEEP, NODE_RADIUS_TOLERANCE, coarse_move_bound, line_bound)
from walker_planner.core.cartesian import CartesianInJointSpace, branch_of
from walker_planner.core.errors import InvalidRequestError, LimitError, WorkspaceError
from walker_planner.core.registry import TRAJECTORY_TYPES, ValidRequest
from walker_planner.core.trajectory import CARTESIAN, Samples, Trajectory, finite_vector

__all__ = ['PlanRequest', 'PlanningContext', 'Plan', 'plan', 'sample_times',
           'START_MATCH_TOLERANCE']

#: How close the tip of ``start_joints`` must be to ``start`` [m], and how vertical [rad].
START_MATCH_TOLERANCE = 1e-3
_OPTION_UNITS = {'duration': 's', 'max_velocity': 'rad/s or m/s',
                 'max_acceleration': 'rad/s^2 or m/s^2', 'min_radius': 'm'}


@dataclasses.dataclass(frozen=True)
class PlanRequest:
    """A planning request as it arrives (``walker_msgs/srv/PlanTrajectory``), ROS-free.

    Attributes
    ----------
    trajectory_type : str
        One of :data:`walker_planner.core.registry.TRAJECTORY_TYPES`.
    base_gripper : str
        ``'a'`` or ``'b'``.
    start, goal : sequence of float
        5 joint angles in physical order [rad] (joint types) or the tip's X, Y, Z in the
        base-gripper frame [m] (Cartesian types).
    duration, max_velocity, max_acceleration, min_radius : float
        Options (0: unused or the parameter file's default), see each type.
    start_joints : sequence of float
        Empty, or the 5 joint angles in physical order at the start [rad] (Cartesian types:
        they choose the IK branch and the gripper yaw).
    sweep_direction : int
        ``bang_bang_node`` half turns: +1 counterclockwise, -1 clockwise (seen from above),
        0 for the planner's choice.
    """

    trajectory_type: str
    base_gripper: str
    start: tuple = ()
    goal: tuple = ()
    duration: float = 0.0
    max_velocity: float = 0.0
    max_acceleration: float = 0.0
    start_joints: tuple = ()
    min_radius: float = 0.0
    sweep_direction: int = 0


@dataclasses.dataclass(frozen=True)
class PlanningContext:
    """What planning needs besides the request: the robot and the planner's parameters."""

    robot: object  # walker_core.robot_parameters.WalkerParameters
    planner: object  # walker_planner.core.parameters.PlannerParameters
    kinematics: WalkerKinematics
    node_tolerance: float = NODE_RADIUS_TOLERANCE
    min_sweep: float = MIN_SWEEP

    @classmethod
    def from_parameters(cls, robot, planner) -> 'PlanningContext':
        """Build from the shared ``WalkerParameters`` and the ``PlannerParameters``."""
        return cls(robot, planner, WalkerKinematics.from_parameters(robot))

    @property
    def control_period(self) -> float:
        """``1 / timing.control_rate`` [s]."""
        return 1.0 / self.robot.timing.control_rate


@dataclasses.dataclass(frozen=True)
class Plan:
    """A planned trajectory, sampled every control period.

    Attributes
    ----------
    type_name, base_gripper : str
        What was planned, and which gripper is the base.
    trajectory : Trajectory
        The joint-space trajectory in role order J1..J5 (sample it at any time).
    path : Trajectory or None
        The Cartesian tip trajectory of Cartesian types.
    solution : NodeToNodeSolution or None
        The bang-bang solution of ``bang_bang_node`` (when the plan coasts,
        ``planner.bang_bang.coast``, the rate-bound solution it replaced).
    times : ndarray, shape (N,)
        Sample times [s]: every control period, and the end.
    samples : Samples
        Joint positions, velocities, accelerations at ``times``, physical order, (N, 5).
    time_optimal_bound : float or None
        A lower bound of this move's duration [s]: for a sweep about the base at one radius,
        the provable bound of :func:`walker_planner.core.bounds.time_optimal_bound` (the
        torque and rate limits on eqs (19)-(20)); for a straight line, rest to rest at the
        planner's Cartesian acceleration limit; ``None`` otherwise.
    """

    type_name: str
    base_gripper: str
    trajectory: Trajectory
    path: Trajectory | None
    solution: object
    times: np.ndarray
    samples: Samples
    time_optimal_bound: float | None

    @property
    def duration(self) -> float:
        """Duration [s]."""
        return self.trajectory.duration


def sample_times(duration: float, period: float) -> np.ndarray:
    """Every ``period`` from 0, and ``duration`` itself (not repeated) [s]."""
    count = int(math.floor(duration / period * (1.0 + 1e-12)))
    times = np.arange(count + 1) * period
    if duration - times[-1] > 1e-9 * period:
        times = np.append(times, duration)
    else:
        times[-1] = duration
    return times


def _option(request: PlanRequest, name: str, options: frozenset, type_name: str) -> float:
    value = getattr(request, name)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InvalidRequestError(f'{name} must be a finite number, got {value!r}')
    if value < 0.0:
        raise LimitError(f'{name} must not be negative, got {value!r} {_OPTION_UNITS[name]}')
    if value and name not in options:
        raise InvalidRequestError(f'{type_name} does not take {name}; leave it 0')
    return float(value)


def _sweep_direction_option(request: PlanRequest, kind) -> int:
    value = request.sweep_direction
    if isinstance(value, bool) or value not in (-1, 0, 1):
        raise InvalidRequestError(f'sweep_direction must be -1, 0 or +1, got {value!r}')
    if value and 'sweep_direction' not in kind.options:
        raise InvalidRequestError(f'{kind.name} does not take sweep_direction; leave it 0')
    return int(value)


def _validate(request: PlanRequest, context: PlanningContext):
    kind = TRAJECTORY_TYPES.get(request.trajectory_type)
    if kind is None:
        raise InvalidRequestError(
            f'unknown trajectory type {request.trajectory_type!r}; the types are: '
            f'{", ".join(TRAJECTORY_TYPES)}')
    if request.base_gripper not in GRIPPERS:
        raise InvalidRequestError(
            f'unknown base gripper {request.base_gripper!r}: expected "a" or "b"')
    options = {name: _option(request, name, kind.options, kind.name) for name in _OPTION_UNITS}
    options['sweep_direction'] = _sweep_direction_option(request, kind)
    size = 5 if kind.space != CARTESIAN else 3
    unit = 'joint angles in physical order [rad]' if size == 5 else 'tip X, Y, Z [m]'
    start = finite_vector(request.start, size, f'start ({unit})')
    goal = finite_vector(request.goal, size, f'goal ({unit})')
    base = request.base_gripper
    start_joints = np.empty(0)
    if len(request.start_joints):
        if 'start_joints' not in kind.options:
            raise InvalidRequestError(f'{kind.name} does not take start_joints (its start is '
                                      f'already joint angles); leave it empty')
        start_joints = physical_to_roles(finite_vector(
            request.start_joints, 5, 'start_joints (joint angles in physical order [rad])'), base)
    if kind.space == CARTESIAN:
        start_joints = _cartesian_start(start, start_joints, context)
    else:
        start, goal = physical_to_roles(start, base), physical_to_roles(goal, base)
        for what, joints in (('start', start), ('goal', goal)):
            try:
                context.kinematics.check_joint_limits(joints)
            except KinematicsError as error:
                raise WorkspaceError(f'{what}: {_named(error, base)}') from None
        start_joints = start
    return kind, ValidRequest(start, goal, start_joints, **options)


def _cartesian_start(start: np.ndarray, start_joints: np.ndarray, context: PlanningContext
                     ) -> np.ndarray:
    """Start configuration of a Cartesian motion: the given one (checked), or IK of ``start``."""
    kinematics = context.kinematics
    if start_joints.size:
        pose = kinematics.forward(start_joints)
        miss = float(np.linalg.norm(pose[:3] - start))
        if miss > START_MATCH_TOLERANCE or abs(pose[3]) > START_MATCH_TOLERANCE:
            raise InvalidRequestError(
                f'start_joints put the tip at {np.round(pose[:3], 4).tolist()} m with the '
                f'gripper tilted {pose[3]:.4f} rad, not at start {np.round(start, 4).tolist()} '
                f'm with the gripper vertical ({miss * 1e3:.1f} mm away)')
        return start_joints
    try:
        joints = kinematics.inverse([*start, 0.0, 0.0], 'up', 'forward')
    except KinematicsError as error:
        raise WorkspaceError(f'start {np.round(start, 4).tolist()} m: {error}') from None
    joints[4] = joints[0]  # the tip gripper's heading mirrors the base's
    return joints


def _named(error: Exception, base: str) -> str:
    """Add the physical joint names to a kinematics message that speaks of roles J1..J5."""
    names = ', '.join(f'J{role} = {joint_of_role(role, base)}' for role in range(1, 6))
    return f'{error} (with gripper {base} as base: {names})'


def _check_rates(plan_times: np.ndarray, samples: Samples, context: PlanningContext,
                 base: str, type_name: str) -> None:
    limits = context.robot.robot.drive.role_array('velocity_limit')
    speeds = np.abs(samples.velocity)
    worst = np.unravel_index(np.argmax(speeds / limits), speeds.shape)
    index, role = int(worst[0]), int(worst[1])
    if speeds[index, role] > limits[role] * (1.0 + 1e-9):
        raise LimitError(
            f'{type_name} needs J{role + 1} ({joint_of_role(role + 1, base)}) to turn at '
            f'{speeds[index, role]:.4g} rad/s at t = {plan_times[index]:.4g} s, above its '
            f'velocity limit {limits[role]:.4g} rad/s: lower the speed or lengthen the motion')
    if not all(np.all(np.isfinite(array)) for array in samples):
        raise WorkspaceError(f'{type_name}: the joint trajectory is not finite')


_LINES = frozenset({'cartesian_line', 'insertion_line', 'extraction_line'})


def _bound(kind, valid: ValidRequest, context: PlanningContext) -> float | None:
    """Bound the move's duration from below [s], or return None when there is no bound.

    A sweep about the base at one radius: the provable bound under the robot's torque and rate
    limits and ``min_radius`` (:func:`walker_planner.core.bounds.coarse_move_bound`); a straight
    line: rest to rest at the planner's Cartesian acceleration limit.
    """
    if kind.name in _LINES:
        return line_bound(float(np.linalg.norm(valid.goal - valid.start)),
                          context.planner.cartesian.acceleration_limit)
    min_radius = valid.min_radius or context.planner.bang_bang.min_radius
    if kind.space == CARTESIAN:
        start, goal = valid.start, valid.goal
    else:
        start, goal = (context.kinematics.forward(valid.start)[:3],
                       context.kinematics.forward(valid.goal)[:3])
    return coarse_move_bound(context.robot, start, goal, min(min_radius, math.hypot(*start[:2])))


def plan(request: PlanRequest, context: PlanningContext) -> Plan:
    """Plan a trajectory of a named type and sample it every control period.

    Parameters
    ----------
    request : PlanRequest
        Type, base gripper, start, goal and options.
    context : PlanningContext
        Robot and planner parameters.

    Returns
    -------
    Plan

    Raises
    ------
    InvalidRequestError
        Unknown type or gripper, wrong lengths, NaN or infinity, options the type does not
        take, a goal equal to the start, an insertion off the hole axis.
    WorkspaceError
        A start, goal or path outside the workspace or the joint limits (with the time).
    LimitError
        Limits out of range, or a trajectory that would exceed a joint's velocity limit.
    NoSolutionError
        A bang-bang node-to-node move with no solution (radii, sweep, rho_min).
    """
    kind, valid = _validate(request, context)
    built = kind.build(valid, context)
    trajectory = built.trajectory
    path = None
    if kind.space == CARTESIAN:
        path = trajectory
        start_joints = valid.start_joints
        branch = branch_of(context.kinematics, start_joints)
        try:
            trajectory = CartesianInJointSpace(path, context.kinematics, branch, start_joints)
        except WorkspaceError as error:
            raise WorkspaceError(_named(error, request.base_gripper)) from None
    times = sample_times(trajectory.duration, context.control_period)
    samples = trajectory.sample(times)
    _check_rates(times, samples, context, request.base_gripper, kind.name)
    base = request.base_gripper
    physical = Samples(*(roles_to_physical(array, base) for array in samples))
    return Plan(kind.name, base, trajectory, path, built.solution, times, physical,
                _bound(kind, valid, context))
