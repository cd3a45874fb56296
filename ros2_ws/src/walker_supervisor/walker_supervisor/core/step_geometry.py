"""Where a step goes: the base frame in the truss, and the joint targets of each phase.

The walker has no tip position sensing (paper section 2): the supervisor knows where the tip is
only through the joint angles and the forward kinematics. The base frame's position is the base
node's; its heading follows from the other gripper's node when both are screwed in, so no error
accumulates from step to step.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from walker_core.kinematics import KinematicsError, WalkerKinematics
from walker_supervisor.core.route import PlannedStep

__all__ = ['BaseFrame', 'StepTargets', 'plan_step_targets', 'measure_step_targets',
           'recovery_targets', 'probe_targets', 'shifted_targets', 'raised_approach']


@dataclasses.dataclass(frozen=True)
class BaseFrame:
    """Pose of the base gripper's frame in the truss frame: a position and a heading.

    Attributes
    ----------
    origin : ndarray, shape (3,)
        Base node position [m] in the truss frame.
    heading : float
        Rotation of the base frame about z relative to the truss frame [rad].
    """

    origin: np.ndarray
    heading: float

    @classmethod
    def from_stance(cls, kinematics: WalkerKinematics, theta_roles: np.ndarray,
                    base_position: np.ndarray, other_position: np.ndarray) -> 'BaseFrame':
        """Recover the frame from the joint angles with both grippers attached.

        Parameters
        ----------
        theta_roles : ndarray, shape (5,)
            Measured joint angles J1..J5 [rad] for the current base.
        base_position, other_position : ndarray, shape (3,)
            Positions [m] of the nodes of the base and of the other gripper.
        """
        tip = kinematics.forward(theta_roles)[:2]
        world = np.asarray(other_position, dtype=float)[:2] - np.asarray(base_position)[:2]
        if np.linalg.norm(tip) < 1e-6 or np.linalg.norm(world) < 1e-6:
            raise KinematicsError('the base heading is undefined: the other gripper is on the '
                                  'base axis')
        heading = math.atan2(world[1], world[0]) - math.atan2(tip[1], tip[0])
        return cls(np.asarray(base_position, dtype=float), math.remainder(heading, 2 * math.pi))

    def to_base(self, point_truss: np.ndarray) -> np.ndarray:
        """Express a truss-frame point [m] in the base frame."""
        c, s = math.cos(self.heading), math.sin(self.heading)
        d = np.asarray(point_truss, dtype=float) - self.origin
        return np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1], d[2]])

    def to_truss(self, point_base: np.ndarray) -> np.ndarray:
        """Express a base-frame point [m] in the truss frame."""
        c, s = math.cos(self.heading), math.sin(self.heading)
        p = np.asarray(point_base, dtype=float)
        return self.origin + np.array([c * p[0] - s * p[1], s * p[0] + c * p[1], p[2]])


@dataclasses.dataclass(frozen=True)
class StepTargets:
    """Joint-space (role order) and base-frame targets of one step's phases.

    Attributes
    ----------
    frame : BaseFrame
        The base frame during the step.
    sweep : float
        Signed base yaw rotation [rad] of the coarse motion.
    start : ndarray
        Joint angles at the start (moving gripper in its hole) [rad].
    above_from, above_to : ndarray
        Joint angles with the tip at the approach height above the old and the new node [rad].
    at_to : ndarray
        Joint angles with the tip in the new node's hole mouth [rad].
    point_above_from, point_above_to, point_to : ndarray
        The same tip positions [m] in the base frame.
    coarse_to : ndarray or None
        Joint angles where the coarse motion ends, when not ``above_to`` [rad]: the node-to-node
        motion keeps its start's distance from the base yaw axis and its height, so with the
        moving gripper's node or the target off their nominal places it ends on that circle,
        at the target's bearing, and FINE takes the tip the rest of the way (None: at
        ``above_to``).
    point_coarse_to : ndarray or None
        The same tip position [m] in the base frame.
    """

    frame: BaseFrame
    sweep: float
    start: np.ndarray
    above_from: np.ndarray
    above_to: np.ndarray
    at_to: np.ndarray
    point_above_from: np.ndarray
    point_above_to: np.ndarray
    point_to: np.ndarray
    coarse_to: np.ndarray | None = None
    point_coarse_to: np.ndarray | None = None

    @property
    def coarse_goal(self) -> tuple[np.ndarray, np.ndarray]:
        """Return the coarse motion's end: joint angles [rad] and tip point [m]."""
        if self.coarse_to is None:
            return self.above_to, self.point_above_to
        return self.coarse_to, self.point_coarse_to


def plan_step_targets(kinematics: WalkerKinematics, frame: BaseFrame, step: PlannedStep,
                      from_position: np.ndarray, to_position: np.ndarray,
                      theta_roles: np.ndarray, approach_height: float) -> StepTargets:
    """Compute the joint targets of every phase of a step.

    The tip stays vertical (alpha = 0) and keeps its heading in the truss frame: the tip yaw J5
    turns with the base yaw J1 (as the planner's Cartesian motions do), so both turn by the
    step's sweep. The extraction starts where the moving gripper is, the forward kinematics of
    the joints now (both grippers attached), not where the parameter file puts its node: a
    gripper screwed into a node off its nominal place lifts along that node's own axis.

    Parameters
    ----------
    from_position, to_position : ndarray, shape (3,)
        Truss-frame positions [m] of the node the moving gripper leaves (unused: the joints
        say where it is) and of its target (the truss map's estimate).
    theta_roles : ndarray, shape (5,)
        Joint angles J1..J5 now [rad].
    approach_height : float
        Height [m] above a hole where insertion starts and extraction ends.

    Raises
    ------
    KinematicsError
        When a target is out of reach or outside the joint limits.
    """
    theta = np.asarray(theta_roles, dtype=float)
    sweep = step.sweep
    lift = np.array([0.0, 0.0, approach_height])
    point_from = kinematics.forward(theta)[:3]
    point_to = frame.to_base(to_position)
    above_from = kinematics.inverse([*(point_from + lift), 0.0, theta[4]], reference=theta)
    reference = theta.copy()
    reference[0] += sweep
    reference[4] += sweep
    above_to = kinematics.inverse([*(point_to + lift), 0.0, reference[4]], reference=reference)
    at_to = kinematics.inverse([*point_to, 0.0, reference[4]], reference=above_to)
    coarse_to, point_coarse_to = _coarse_end(kinematics, point_from + lift, point_to + lift,
                                             reference, sweep)
    return StepTargets(frame, sweep, theta, above_from, above_to, at_to,
                       point_from + lift, point_to + lift, point_to, coarse_to, point_coarse_to)


#: [m] a coarse motion ends on its target when the start's radius and height are within this
COARSE_END_TOLERANCE = 1e-6


def _coarse_end(kinematics: WalkerKinematics, start: np.ndarray, goal: np.ndarray,
                reference: np.ndarray, sweep: float = 0.0,
                ) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Return where the node-to-node motion from ``start`` towards ``goal`` [m] ends.

    At ``goal``'s bearing about the base yaw axis, at ``start``'s distance from it and height
    (the motion's own geometry); (None, None) when that is ``goal`` itself. A half turn
    (``sweep`` [rad] +-pi) ends exactly opposite its start: with the nodes off their places,
    the target's bearing is a hair short of or past 180 deg, and past it the planner would
    have to turn the other way than the route chose (a sweep is at most 180 deg); FINE takes
    the tip the millimetres left.
    """
    radius, goal_radius = math.hypot(start[0], start[1]), math.hypot(goal[0], goal[1])
    if abs(abs(sweep) - math.pi) < 1e-9:
        point = np.array([-start[0], -start[1], start[2]])
        if np.linalg.norm(point - goal) <= COARSE_END_TOLERANCE:
            return None, None
        return kinematics.inverse([*point, 0.0, reference[4]], reference=reference), point
    if abs(radius - goal_radius) <= COARSE_END_TOLERANCE \
            and abs(start[2] - goal[2]) <= COARSE_END_TOLERANCE:
        return None, None
    point = np.array([goal[0] * radius / goal_radius, goal[1] * radius / goal_radius, start[2]])
    return kinematics.inverse([*point, 0.0, reference[4]], reference=reference), point


def measure_step_targets(kinematics: WalkerKinematics, step: PlannedStep,
                         base_position: np.ndarray, from_position: np.ndarray,
                         to_position: np.ndarray, theta_roles: np.ndarray,
                         approach_height: float) -> StepTargets:
    """Measure the base frame from the stance and compute the step's targets from it.

    :meth:`BaseFrame.from_stance` (both grippers attached, at ``base_position`` and
    ``from_position``), then :func:`plan_step_targets`, from the same joint angles.

    Raises
    ------
    KinematicsError
        When the heading is undefined or a target is out of reach.
    """
    frame = BaseFrame.from_stance(kinematics, theta_roles, base_position, from_position)
    return plan_step_targets(kinematics, frame, step, from_position, to_position, theta_roles,
                             approach_height)


def recovery_targets(kinematics: WalkerKinematics, frame: BaseFrame, step: PlannedStep,
                     from_position: np.ndarray, to_position: np.ndarray,
                     theta_roles: np.ndarray, approach_height: float) -> StepTargets:
    """Targets of a step taken up again from where the arm is now (a restarted supervisor).

    As :func:`plan_step_targets`, but every joint target is the IK solution nearest the joints
    now (the sweep may be partly done): what matters to complete the step are the points.
    """
    theta = np.asarray(theta_roles, dtype=float)
    lift = np.array([0.0, 0.0, approach_height])
    point_from = frame.to_base(from_position)
    point_to = frame.to_base(to_position)
    above_from = kinematics.inverse([*(point_from + lift), 0.0, theta[4]], reference=theta)
    above_to = kinematics.inverse([*(point_to + lift), 0.0, theta[4]], reference=theta)
    at_to = kinematics.inverse([*point_to, 0.0, theta[4]], reference=above_to)
    return StepTargets(frame, step.sweep, theta, above_from, above_to, at_to,
                       point_from + lift, point_to + lift, point_to)


def probe_targets(kinematics: WalkerKinematics, targets: StepTargets,
                  offset: np.ndarray, height_shift: float = 0.0) -> StepTargets:
    """Return the step's targets moved to a search probe ``offset`` [m] (x, y, truss frame).

    The points above the hole and at its mouth move by the offset (turned into the base frame)
    and up by ``height_shift`` [m] (a node's height felt on its face since the step began);
    the joint targets there are the IK solutions nearest the step's own
    (:mod:`~walker_supervisor.core.hole_search`).

    Raises
    ------
    KinematicsError
        When a moved target is out of reach or outside the joint limits.
    """
    c, s = math.cos(targets.frame.heading), math.sin(targets.frame.heading)
    dx, dy = float(offset[0]), float(offset[1])
    return shifted_targets(kinematics, targets,
                           np.array([c * dx + s * dy, -s * dx + c * dy, float(height_shift)]))


def shifted_targets(kinematics: WalkerKinematics, targets: StepTargets,
                    shift: np.ndarray) -> StepTargets:
    """Return the step's targets with the hole moved by ``shift`` [m] (x, y, z, base frame).

    The points above the hole and at its mouth move by it; the joint targets there are the IK
    solutions nearest the step's own, the tip's yaw kept.

    Raises
    ------
    KinematicsError
        When a moved target is out of reach or outside the joint limits.
    """
    shift = np.asarray(shift, dtype=float)
    point_above_to = targets.point_above_to + shift
    point_to = targets.point_to + shift
    yaw = float(kinematics.forward(targets.above_to)[4])
    above_to = kinematics.inverse([*point_above_to, 0.0, yaw], reference=targets.above_to)
    at_to = kinematics.inverse([*point_to, 0.0, yaw], reference=above_to)
    return dataclasses.replace(targets, above_to=above_to, at_to=at_to,
                               point_above_to=point_above_to, point_to=point_to)


def raised_approach(kinematics: WalkerKinematics, targets: StepTargets,
                    height: float) -> StepTargets:
    """Return the step's targets with the point above the hole ``height`` [m] over its mouth.

    The descent starts there; the joints there are the IK solution nearest the step's own.

    Raises
    ------
    KinematicsError
        When the point is out of reach or outside the joint limits.
    """
    point_above_to = targets.point_to + np.array([0.0, 0.0, float(height)])
    yaw = float(kinematics.forward(targets.above_to)[4])
    above_to = kinematics.inverse([*point_above_to, 0.0, yaw], reference=targets.above_to)
    return dataclasses.replace(targets, above_to=above_to, point_above_to=point_above_to)
