"""Cartesian trajectories of the tip mapped to joint space through the inverse kinematics.

The tip position comes from a Cartesian trajectory in the base-gripper frame with the gripper
vertical (alpha = 0). Each sample's joint angles are those of
:meth:`walker_core.kinematics.WalkerKinematics.inverse` (eqs (2)-(7), corrected) on the branch of
the start configuration, so a path that leaves the workspace or a joint's limits is refused with
the kinematics' error and the time at which it happens.

Rates follow from the Jacobian of eq (1) at alpha = 0, where the arm decomposes into the base
yaw (polar coordinates of the tip about the yaw axis) and a planar two-link arm of equal links
``l2`` from J2 to J4 holding the tip's reach ``R`` and height ``Z``::

    R = l2 (sin th2 + sin(th2 + th3)),  Z = l2 (cos th2 + cos(th2 + th3)),
    th4 = pi - th2 - th3 (gripper vertical).

The gripper yaw J5 follows J1 (``th5 - th1`` constant), so the tip gripper keeps its heading in
the base frame: the tip frame's heading is ``pi + th1 - th5`` (:mod:`walker_core.kinematics`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from walker_core.kinematics import KinematicsError, WalkerKinematics
from walker_planner.core.errors import WorkspaceError
from walker_planner.core.trajectory import JOINT, Samples, Trajectory

__all__ = ['Branch', 'CartesianInJointSpace', 'branch_of', 'reference_grid_points']

#: Samples of the path checked against the workspace and used to unwrap J1 when mapping.
reference_grid_points = 257
_SINGULAR_SINE = 1e-9


@dataclasses.dataclass(frozen=True)
class Branch:
    """IK branch and gripper yaw of a Cartesian motion.

    Attributes
    ----------
    elbow : str
        ``'up'`` (th3 >= 0, the inverted V of normal walking) or ``'down'``.
    reach : str
        ``'forward'`` or ``'backward'`` (see :meth:`WalkerKinematics.inverse`).
    yaw_offset : float
        ``th5 - th1`` [rad], held through the motion.
    """

    elbow: str = 'up'
    reach: str = 'forward'
    yaw_offset: float = 0.0


def branch_of(kinematics: WalkerKinematics, joints: np.ndarray) -> Branch:
    """Branch and yaw offset of a joint configuration (role order J1..J5) [rad]."""
    l1, l2 = kinematics.l1, kinematics.l2
    t2, t3, t4 = joints[1], joints[2], joints[3]
    reach = l2 * math.sin(t2) + l2 * math.sin(t2 + t3) + l1 * math.sin(t2 + t3 + t4)
    return Branch('up' if t3 >= 0.0 else 'down', 'forward' if reach >= 0.0 else 'backward',
                  float(joints[4] - joints[0]))


class CartesianInJointSpace(Trajectory):
    """A Cartesian tip trajectory seen in joint space (role order J1..J5).

    Parameters
    ----------
    path : Trajectory
        Cartesian trajectory of the tip, positions (X, Y, Z) [m] in the base frame.
    kinematics : WalkerKinematics
        The robot's kinematics with its joint limits.
    branch : Branch
        IK branch and gripper yaw offset.
    start_joints : array_like of 5 float
        Joint angles at the start [rad]; each sample is the 2 pi-equivalent nearest to the
        path's continuous J1 and to these for the other joints.

    Raises
    ------
    WorkspaceError
        If the path leaves the workspace, meets a singularity or breaks a joint limit at any of
        257 evenly spaced times (and at every time later sampled); the message gives the time.
    """

    space = JOINT

    def __init__(self, path: Trajectory, kinematics: WalkerKinematics, branch: Branch,
                 start_joints: np.ndarray) -> None:
        self.path = path
        self.kinematics = kinematics
        self.branch = branch
        self.type_name = path.type_name
        self._start_joints = np.asarray(start_joints, dtype=float)
        grid = np.linspace(0.0, path.duration, reference_grid_points)
        positions = path.sample(grid).position
        yaw = np.unwrap(np.arctan2(-positions[:, 0], positions[:, 1]))
        self._grid = grid
        self._yaw_reference = yaw + (self._start_joints[0] - yaw[0])
        self._positions(grid, positions)  # validate the whole path once

    @property
    def duration(self) -> float:
        """Duration of the Cartesian path [s]."""
        return self.path.duration

    def _positions(self, t: np.ndarray, tip: np.ndarray) -> np.ndarray:
        yaw_reference = np.interp(t, self._grid, self._yaw_reference)
        yaw = yaw_reference + self.branch.yaw_offset
        references = np.tile(self._start_joints, (len(t), 1))
        references[:, 0], references[:, 4] = yaw_reference, yaw
        poses = np.column_stack([tip, np.zeros(len(t)), yaw])
        try:
            joints = self.kinematics.inverse_many(poses, self.branch.elbow, self.branch.reach,
                                                  references)
        except KinematicsError:  # a non-finite sample: named below, with its time
            return self._positions_one_by_one(t, tip, yaw_reference)
        joints[:, 4] = joints[:, 0] + self.branch.yaw_offset
        if np.all(self.kinematics.within_limits_many(joints)):  # NaN rows are not
            return joints
        return self._positions_one_by_one(t, tip, yaw_reference)

    def _positions_one_by_one(self, t: np.ndarray, tip: np.ndarray,
                              yaw_reference: np.ndarray) -> np.ndarray:
        """Sample by sample: the first that leaves the workspace raises, with its time."""
        joints = np.empty((len(t), 5))
        reference = self._start_joints.copy()
        for i, (time, point) in enumerate(zip(t, tip, strict=True)):
            reference[0] = yaw_reference[i]
            reference[4] = yaw_reference[i] + self.branch.yaw_offset
            try:
                joints[i] = self.kinematics.inverse(
                    [point[0], point[1], point[2], 0.0, reference[4]], self.branch.elbow,
                    self.branch.reach, reference=reference, check_limits=False)
                joints[i, 4] = joints[i, 0] + self.branch.yaw_offset
                self.kinematics.check_joint_limits(joints[i])
            except KinematicsError as error:
                raise WorkspaceError(
                    f'{self.type_name}: the path leaves the workspace at t = {time:.4g} s, tip '
                    f'at ({point[0]:.4f}, {point[1]:.4f}, {point[2]:.4f}) m: {error}') from None
        return joints

    def _sample(self, t: np.ndarray) -> Samples:
        tip = self.path.sample(t)
        q = self._positions(t, tip.position)
        qd, qdd = joint_rates(self.kinematics.l2, q, tip.velocity, tip.acceleration)
        return Samples(q, qd, qdd)


def joint_rates(l2: float, q: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """Joint velocities and accelerations of tip motions with the gripper vertical.

    Parameters
    ----------
    l2 : float
        Link length [m].
    q : ndarray, shape (N, 5)
        Joint angles J1..J5 [rad] with ``th2 + th3 + th4 = pi``.
    velocity, acceleration : ndarray, shape (N, 3)
        Tip velocity [m/s] and acceleration [m/s^2] in the base frame.

    Returns
    -------
    tuple of ndarray, shape (N, 5)
        Joint velocities [rad/s] and accelerations [rad/s^2]; J5 follows J1.

    Raises
    ------
    WorkspaceError
        At the yaw axis (R = 0) or with the links stretched or folded (sin th3 = 0).
    """
    t1, t2, t3 = q[:, 0], q[:, 1], q[:, 2]
    radial = np.column_stack([-np.sin(t1), np.cos(t1)])
    circular = np.column_stack([-np.cos(t1), -np.sin(t1)])
    s2, s23, c2, c23 = np.sin(t2), np.sin(t2 + t3), np.cos(t2), np.cos(t2 + t3)
    reach = l2 * (s2 + s23)
    sin3 = np.sin(t3)
    if np.any(np.abs(reach) < _SINGULAR_SINE) or np.any(np.abs(sin3) < _SINGULAR_SINE):
        raise WorkspaceError('the tip path crosses the yaw axis or a stretched/folded '
                             'configuration, where the joint rates are undefined')
    v_h, a_h = velocity[:, :2], acceleration[:, :2]
    # polar coordinates of the tip about the yaw axis
    reach_d = np.sum(v_h * radial, axis=1)
    yaw_d = np.sum(v_h * circular, axis=1) / reach
    reach_dd = np.sum(a_h * radial, axis=1) + reach * yaw_d ** 2
    yaw_dd = (np.sum(a_h * circular, axis=1) - 2.0 * reach_d * yaw_d) / reach
    # planar two-link arm: [R', Z'] = J [th2', th3'], det J = -l2^2 sin th3
    j11, j12 = l2 * (c2 + c23), l2 * c23
    j21, j22 = -l2 * (s2 + s23), -l2 * s23
    det = j11 * j22 - j12 * j21

    def solve(b1, b2):
        return (j22 * b1 - j12 * b2) / det, (-j21 * b1 + j11 * b2) / det

    t2_d, t3_d = solve(reach_d, velocity[:, 2])
    t23_d = t2_d + t3_d
    bias_r = -l2 * (s2 * t2_d ** 2 + s23 * t23_d ** 2)
    bias_z = -l2 * (c2 * t2_d ** 2 + c23 * t23_d ** 2)
    t2_dd, t3_dd = solve(reach_dd - bias_r, acceleration[:, 2] - bias_z)
    qd = np.column_stack([yaw_d, t2_d, t3_d, -t23_d, yaw_d])
    qdd = np.column_stack([yaw_dd, t2_dd, t3_dd, -(t2_dd + t3_dd), yaw_dd])
    return qd, qdd
