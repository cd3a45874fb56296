"""The way back to the point above a step's target, from wherever the arm stopped.

A fine correction and the resume of an interrupted step move the tip from where the joints
are to the point above the target hole. A straight Cartesian line is the natural path, but
from where a coarse motion stopped mid-sweep (the arm folded near the base) that line may
leave the workspace: the planner refuses it, and every resume would fail the same way. Then a
straight line in joint space is the way back, if it keeps the tip above the truss. A line keeps
the gripper vertical from its first point on: where the arm stopped with the gripper tilted (a
fault at the hole's mouth), the gripper is first turned vertical where it is
(:func:`vertical_configuration`), or the planner would refuse a line that does not start where
the joints are.
"""

from __future__ import annotations

import math

import numpy as np

from walker_core.kinematics import KinematicsError, WalkerKinematics

__all__ = ['ik_branch', 'vertical_ik', 'vertical_configuration', 'line_is_followable',
           'lowest_tip_height', 'PATH_SAMPLES']

#: Points checked along a path.
PATH_SAMPLES = 60


def ik_branch(kinematics: WalkerKinematics, theta: np.ndarray) -> tuple[str, str]:
    """Return the (elbow, reach) branch of :meth:`WalkerKinematics.inverse` joints are on.

    Parameters
    ----------
    theta : ndarray, shape (5,)
        Joint angles, role order [rad].
    """
    t2, t3, t4 = np.asarray(theta, dtype=float)[1:4]
    l1, l2 = kinematics.l1, kinematics.l2
    reach = l2 * math.sin(t2) + l2 * math.sin(t2 + t3) + l1 * math.sin(t2 + t3 + t4)
    return ('up' if t3 >= 0 else 'down'), ('forward' if reach >= 0 else 'backward')


def vertical_ik(kinematics: WalkerKinematics, point, near, check_limits: bool = True
                ) -> np.ndarray:
    """Joint angles (role order) with the tip at ``point`` and the gripper vertical, near ``near``.

    On the IK branch and with the tip yaw of ``near``.

    Parameters
    ----------
    point : array_like, shape (3,)
        Tip position, base frame [m].
    near : array_like, shape (5,)
        Joint angles whose branch and tip yaw to keep, role order [rad].
    check_limits : bool
        Refuse a configuration outside the joint limits.

    Raises
    ------
    KinematicsError
        No such configuration (out of reach, or outside the limits when checked).
    """
    near = np.asarray(near, dtype=float)
    elbow, reach = ik_branch(kinematics, near)
    return kinematics.inverse([*point, 0.0, near[4]], elbow, reach, reference=near,
                              check_limits=check_limits)


def vertical_configuration(kinematics: WalkerKinematics, point, near) -> np.ndarray:
    """:func:`vertical_ik` without the joint limits, or ``near`` itself where there is none.

    Where no such configuration exists, a planner refuses what starts at ``near``, with the
    reason.
    """
    try:
        return vertical_ik(kinematics, point, near, check_limits=False)
    except KinematicsError:
        return np.asarray(near, dtype=float)


def line_is_followable(kinematics: WalkerKinematics, theta: np.ndarray, goal_point: np.ndarray,
                       samples: int = PATH_SAMPLES) -> bool:
    """Return True when the tip can go straight from where ``theta`` puts it to ``goal_point``.

    The gripper vertical all along, on the branch of ``theta``, within the joint limits (as the
    planner maps a Cartesian line through the inverse kinematics).

    Parameters
    ----------
    theta : ndarray, shape (5,)
        Joint angles now, role order [rad].
    goal_point : ndarray, shape (3,)
        Tip position to reach, base frame [m].
    """
    theta = np.asarray(theta, dtype=float)
    start = kinematics.forward(theta)[:3]
    goal_point = np.asarray(goal_point, dtype=float)
    elbow, reach = ik_branch(kinematics, theta)
    reference = theta
    for fraction in np.linspace(0.0, 1.0, samples)[1:]:
        point = start + fraction * (goal_point - start)
        try:
            reference = kinematics.inverse([*point, 0.0, theta[4]], elbow, reach,
                                           reference=reference)
        except KinematicsError:
            return False
    return True


def lowest_tip_height(kinematics: WalkerKinematics, start: np.ndarray, goal: np.ndarray,
                      samples: int = PATH_SAMPLES) -> float:
    """Return the lowest tip height [m] (base frame) along the joint-space line start -> goal.

    Any time scaling of the line (minimum jerk, parabolic blends) follows the same path.
    """
    start, goal = np.asarray(start, dtype=float), np.asarray(goal, dtype=float)
    return min(float(kinematics.forward(start + f * (goal - start))[2])
               for f in np.linspace(0.0, 1.0, samples))
