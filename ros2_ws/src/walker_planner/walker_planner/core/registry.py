"""The nine trajectory types of the planner (paper section 5), by name.

One list, shared by the planner node (which accepts exactly these names) and docs/planner.md
(a test checks they agree). Each entry says what it takes and which phase of a step it serves,
and builds its trajectory from a validated request; Cartesian ones are mapped to joint space by
:mod:`walker_planner.core.planning`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np

from walker_planner.core.errors import InvalidRequestError, LimitError, NoSolutionError
from walker_planner.core.coasting import coasting_sweep
from walker_planner.core.node_to_node import (
    SWEEP_TYPE_NAME, NodeToNodeTrajectory, PlanarModel, solve_node_to_node)
from walker_planner.core.profiles import (
    BlendProfile, ConstantVelocityProfile, MinJerkProfile, check_limit)
from walker_planner.core.segments import CartesianSegment, JointSegment
from walker_planner.core.trajectory import CARTESIAN, JOINT, Trajectory

__all__ = ['TrajectoryType', 'TRAJECTORY_TYPES', 'type_names', 'ValidRequest', 'Built']

_NO_MOTION = 1e-9  # [rad or m] a displacement below this is no motion


@dataclasses.dataclass(frozen=True)
class ValidRequest:
    """A request checked for shape and finiteness, in role order and the base frame.

    ``start``/``goal`` are 5 joint angles J1..J5 [rad] or 3 tip coordinates [m];
    ``start_joints`` is the start configuration in role order [rad] (for Cartesian types: the
    given one or the normal-walking IK solution of ``start``). Zero limits mean "default".
    """

    start: np.ndarray
    goal: np.ndarray
    start_joints: np.ndarray
    duration: float
    max_velocity: float
    max_acceleration: float
    min_radius: float
    sweep_direction: int = 0


class Built:
    """What a type's builder returns: the trajectory and, for bang-bang, its solution."""

    def __init__(self, trajectory: Trajectory, solution=None) -> None:
        self.trajectory = trajectory
        self.solution = solution


@dataclasses.dataclass(frozen=True)
class TrajectoryType:
    """One named trajectory type.

    Attributes
    ----------
    name : str
        Registry name, the ``trajectory_type`` of ``walker_msgs/srv/PlanTrajectory``.
    space : str
        ``'joint'`` (start/goal: 5 joint angles, rad) or ``'cartesian'`` (tip X, Y, Z, m).
    phase : str
        The phase of a step it serves.
    parameters : str
        The request fields it uses, for the docs and error messages.
    options : frozenset of str
        Optional request fields it accepts (others must be 0 / empty).
    build : callable
        ``build(request: ValidRequest, context) -> Built``.
    """

    name: str
    space: str
    phase: str
    parameters: str
    options: frozenset
    build: Callable


def _moving(request: ValidRequest) -> np.ndarray:
    delta = request.goal - request.start
    if np.max(np.abs(delta)) < _NO_MOTION:
        raise InvalidRequestError('goal equals start: there is nothing to move')
    return delta


def _limit(requested: float, default: float, hard: float, what: str, unit: str) -> float:
    if requested == 0.0:
        return default
    check_limit(requested, hard, f'requested {what}', unit)
    return requested


def _joint_scaling_limits(request: ValidRequest, context) -> tuple[float, float]:
    """Limits on ds/dt and d2s/dt2 of a joint-space segment (the slowest joint sets them)."""
    delta = np.abs(_moving(request))
    moving = delta > _NO_MOTION
    hard = context.robot.robot.drive.role_array('velocity_limit')
    planning = context.planner.joint
    if request.max_velocity:
        for role in np.flatnonzero(moving):
            check_limit(request.max_velocity, hard[role],
                        f'requested max_velocity (J{role + 1} limit)', 'rad/s')
        velocity = np.full(5, request.max_velocity)
    else:
        velocity = planning.velocity_fraction * hard
    acceleration = _limit(request.max_acceleration, planning.max_acceleration,
                          planning.acceleration_limit, 'max_acceleration', 'rad/s^2')
    return (float(np.min(velocity[moving] / delta[moving])),
            float(acceleration / np.max(delta[moving])))


def _cartesian_scaling_limits(request: ValidRequest, context) -> tuple[float, float]:
    length = float(np.linalg.norm(_moving(request)))
    planning = context.planner.cartesian
    speed = request.max_velocity or planning.max_velocity
    acceleration = _limit(request.max_acceleration, planning.max_acceleration,
                          planning.acceleration_limit, 'max_acceleration', 'm/s^2')
    return speed / length, acceleration / length


def _needs_duration(request: ValidRequest, name: str) -> float:
    if request.duration <= 0.0:
        raise InvalidRequestError(f'{name} is specified by its settling time: give duration > 0')
    return request.duration


def _joint_parabolic_time(request, context):
    rate, accel = _joint_scaling_limits(request, context)
    profile = BlendProfile.by_time(_needs_duration(request, 'joint_parabolic_time'), rate, accel)
    return Built(JointSegment('joint_parabolic_time', request.start, request.goal, profile))


def _joint_parabolic_accel(request, context):
    rate, accel = _joint_scaling_limits(request, context)
    profile = BlendProfile.by_acceleration(rate, accel)
    return Built(JointSegment('joint_parabolic_accel', request.start, request.goal, profile))


def _joint_min_jerk(request, context):
    rate, accel = _joint_scaling_limits(request, context)
    shortest = MinJerkProfile.by_limits(rate, accel)
    if request.duration:
        if request.duration < shortest.duration * (1.0 - 1e-12):
            raise LimitError(f'duration {request.duration:.4g} s is too short for the limits: '
                             f'the shortest minimum-jerk move takes {shortest.duration:.4g} s')
        shortest = MinJerkProfile(request.duration)
    return Built(JointSegment('joint_min_jerk', request.start, request.goal, shortest))


def _cartesian_parabolic_time(request, context):
    rate, accel = _cartesian_scaling_limits(request, context)
    profile = BlendProfile.by_time(_needs_duration(request, 'cartesian_parabolic_time'),
                                   rate, accel)
    return Built(CartesianSegment('cartesian_parabolic_time', request.start, request.goal,
                                  profile))


def _cartesian_parabolic_accel(request, context):
    rate, accel = _cartesian_scaling_limits(request, context)
    return Built(CartesianSegment('cartesian_parabolic_accel', request.start, request.goal,
                                  BlendProfile.by_acceleration(rate, accel)))


def _constant_velocity(name: str, request: ValidRequest, default_speed: float) -> Built:
    length = float(np.linalg.norm(_moving(request)))
    speed = request.max_velocity or default_speed
    return Built(CartesianSegment(name, request.start, request.goal,
                                  ConstantVelocityProfile(length / speed)))


def _cartesian_line(request, context):
    return _constant_velocity('cartesian_line', request, context.planner.cartesian.fine_speed)


def _vertical_line(name: str, downwards: bool, request: ValidRequest, context) -> Built:
    """Build a straight line along the hole axis, rest to rest with minimum jerk.

    The shortest quintic whose peak tip speed is the request's ``max_velocity`` (0: the
    ``insertion_speed``) and whose peak acceleration is within the Cartesian
    ``acceleration_limit``. Unlike a constant-velocity line, it starts and stops without a step
    of the velocity, which the joints' stiction turns into a lag at the start and an overshoot
    at the end (joint 2 ran 6 mrad past the end of a 0.3 s descent and took 0.3 s to come
    back before the mouth could settle).
    """
    delta = _moving(request)
    offset = math.hypot(delta[0], delta[1])
    tolerance = context.robot.gripper.insertion_position_tolerance
    if offset > tolerance:
        raise InvalidRequestError(
            f'{name} moves along the hole axis: start and goal must be vertically aligned, '
            f'but they are {offset * 1e3:.2f} mm apart horizontally (tolerance '
            f'{tolerance * 1e3:.2f} mm)')
    if (delta[2] < 0.0) != downwards:
        raise InvalidRequestError(
            f'{name} moves {"down into" if downwards else "up out of"} the hole: the goal must '
            f'be {"below" if downwards else "above"} the start')
    length = float(np.linalg.norm(delta))
    speed = request.max_velocity or context.planner.cartesian.insertion_speed
    acceleration = context.planner.cartesian.acceleration_limit
    return Built(CartesianSegment(name, request.start, request.goal, MinJerkProfile.by_limits(
        speed / length, acceleration / length)))


def _insertion_line(request, context):
    return _vertical_line('insertion_line', True, request, context)


def _extraction_line(request, context):
    return _vertical_line('extraction_line', False, request, context)


def _bang_bang_node(request, context):
    start, goal = request.start, request.goal
    l2 = context.robot.robot.geometry.l2
    radius = math.hypot(start[0], start[1])
    goal_radius = math.hypot(goal[0], goal[1])
    if abs(radius - goal_radius) > context.node_tolerance:
        raise NoSolutionError(
            f'bang_bang_node moves between points at the same distance from the base yaw axis '
            f'(node to node); start is {radius:.4f} m away, goal {goal_radius:.4f} m')
    if abs(start[2] - goal[2]) > context.node_tolerance:
        raise NoSolutionError(f'bang_bang_node moves in a horizontal plane: start and goal '
                              f'heights differ ({start[2]:.4f} m, {goal[2]:.4f} m)')
    theta_start = math.atan2(-start[0], start[1])
    sweep = math.remainder(math.atan2(-goal[0], goal[1]) - theta_start, 2.0 * math.pi)
    if abs(sweep) < context.min_sweep:
        raise NoSolutionError('start and goal are at the same angle about the base: no sweep')
    rho_start = radius / (2.0 * l2)
    if request.min_radius:
        rho_min = request.min_radius / (2.0 * l2)
    else:
        rho_min = min(context.planner.bang_bang.min_radius / (2.0 * l2), rho_start)
    planning = context.planner.bang_bang
    model = PlanarModel.from_parameters(context.robot, planning.torque_fraction,
                                        planning.velocity_fraction)
    solution = solve_node_to_node(model, rho_start, 0.5 * abs(sweep), rho_min,
                                  request.duration or None)
    direction = _sweep_direction(sweep, request.start_joints, context, request.sweep_direction)
    # Theta of the start, continuous with the start's J1 (forward reach: J1 = Theta)
    yaw = request.start_joints[0]
    theta_start = theta_start + 2.0 * math.pi * round((yaw - theta_start) / (2.0 * math.pi))
    if planning.coast and not request.duration and solution.profile.pure_rotation \
            and solution.binding_limit == 'the J1/J5 rate limit':
        trajectory = coasting_sweep(model, radius, float(start[2]), theta_start, direction,
                                    abs(sweep), context.robot.robot.flexibility.joint1_mode)
        return Built(trajectory, solution)
    return Built(NodeToNodeTrajectory(solution, theta_start, direction, float(start[2])),
                 solution)


def _sweep_direction(sweep: float, start_joints: np.ndarray, context, wanted: int = 0) -> int:
    """Direction of the sweep; a half turn goes ``wanted`` way, or the way within the limits."""
    if abs(abs(sweep) - math.pi) > context.min_sweep:
        direction = 1 if sweep >= 0.0 else -1
        if wanted and wanted != direction:
            raise NoSolutionError(
                f'a {math.degrees(abs(sweep)):.0f} deg sweep goes one way only '
                f'({"counterclockwise" if direction > 0 else "clockwise"}); sweep_direction '
                f'{wanted:+d} asks for the other')
        return direction
    if wanted:
        ends = start_joints[[0, 4]] + wanted * math.pi
        kinematics = context.kinematics
        for i, value in zip((0, 4), ends, strict=True):
            if not kinematics.lower[i] <= value <= kinematics.upper[i]:
                raise NoSolutionError(
                    f'a half turn {"counterclockwise" if wanted > 0 else "clockwise"} takes '
                    f'J{i + 1} to {value:.3f} rad, outside its limits [{kinematics.lower[i]:.3f}, '
                    f'{kinematics.upper[i]:.3f}] rad')
        return wanted
    preferred = 1  # a half turn: counter-clockwise unless a limit is in the way
    kinematics = context.kinematics
    for direction in (preferred, -preferred):
        ends = start_joints[[0, 4]] + direction * math.pi
        if all(kinematics.lower[i] <= value <= kinematics.upper[i]
               for i, value in zip((0, 4), ends, strict=True)):
            return direction
    return preferred


_LIMITS = frozenset({'max_velocity', 'max_acceleration'})
_TYPES = (
    TrajectoryType(
        'joint_parabolic_time', JOINT, 'coarse motion in joint space; moves between stances',
        'start, goal (5 joint angles); duration = settling time; max_velocity, '
        'max_acceleration (limits, 0 = defaults)',
        frozenset({'duration'}) | _LIMITS, _joint_parabolic_time),
    TrajectoryType(
        'joint_parabolic_accel', JOINT,
        'coarse motion in joint space, as fast as the limits allow',
        'start, goal (5 joint angles); max_acceleration = blend acceleration, max_velocity '
        '(0 = defaults)', _LIMITS, _joint_parabolic_accel),
    TrajectoryType(
        'joint_min_jerk', JOINT,
        'coarse motion that excites the flexible links least (continuous acceleration)',
        'start, goal (5 joint angles); duration (0 = shortest within the limits); '
        'max_velocity, max_acceleration', frozenset({'duration'}) | _LIMITS, _joint_min_jerk),
    TrajectoryType(
        'cartesian_parabolic_time', CARTESIAN, 'coarse motion of the tip along a straight line',
        'start, goal (tip X, Y, Z); duration = settling time; max_velocity, max_acceleration '
        '(tip, 0 = defaults); start_joints', frozenset({'duration', 'start_joints'}) | _LIMITS,
        _cartesian_parabolic_time),
    TrajectoryType(
        'cartesian_parabolic_accel', CARTESIAN,
        'coarse motion of the tip along a straight line, as fast as the limits allow',
        'start, goal (tip X, Y, Z); max_acceleration, max_velocity (tip, 0 = defaults); '
        'start_joints', frozenset({'start_joints'}) | _LIMITS, _cartesian_parabolic_accel),
    TrajectoryType(
        'cartesian_line', CARTESIAN, 'fine motion to the top of the hole (constant velocity)',
        'start, goal (tip X, Y, Z); max_velocity = speed (0 = planner.cartesian.fine_speed); '
        'start_joints', frozenset({'max_velocity', 'start_joints'}), _cartesian_line),
    TrajectoryType(
        'insertion_line', CARTESIAN, 'insertion: straight down the hole axis (minimum jerk)',
        'start (above the hole), goal (straight below); max_velocity = peak speed '
        '(0 = planner.cartesian.insertion_speed); start_joints',
        frozenset({'max_velocity', 'start_joints'}), _insertion_line),
    TrajectoryType(
        'extraction_line', CARTESIAN, 'extraction: straight up the hole axis (minimum jerk)',
        'start (in the hole), goal (straight above); max_velocity = peak speed '
        '(0 = planner.cartesian.insertion_speed); start_joints',
        frozenset({'max_velocity', 'start_joints'}), _extraction_line),
    TrajectoryType(
        SWEEP_TYPE_NAME, CARTESIAN,
        'coarse node-to-node motion (paper section 5, eqs (17)-(27))',
        'start, goal (tip X, Y, Z at the same radius and height); duration (0 = fastest '
        'within the torque and rate limits); min_radius (0 = planner.bang_bang.min_radius); '
        "start_joints; sweep_direction (half turns: +1 / -1, 0 = the planner's choice)",
        frozenset({'duration', 'min_radius', 'start_joints', 'sweep_direction'}),
        _bang_bang_node),
)

#: The nine types by name, in the order of docs/planner.md.
TRAJECTORY_TYPES: dict[str, TrajectoryType] = {t.name: t for t in _TYPES}


def type_names() -> list[str]:
    """Names of the nine types."""
    return list(TRAJECTORY_TYPES)
