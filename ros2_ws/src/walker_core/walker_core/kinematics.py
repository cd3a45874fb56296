"""Forward and inverse kinematics of the walker (paper eqs (1)-(7)), corrected where misprinted.

Frames and conventions
----------------------
The *base frame* has its origin at the base gripper's contact point on the node (the mouth of
the hole), z along the gripper axis pointing away from the truss, x and y in the truss plane.
Joint angles ``theta`` are in role order J1..J5 (base yaw, base pitch, vertex, tip pitch, tip
yaw), in rad. The chain is::

    Rz(th1) Tz(l1) Rx(-th2) Tz(l2) Rx(-th3) Tz(l2) Rx(-th4) Tz(l1) Rz(th5) Ry(pi)

so that positive pitch tilts the arm towards +y at th1 = 0 and the tip position is exactly eq (1).
The final ``Ry(pi)`` turns the tip gripper's frame so that its z axis also points away from the
truss when the gripper is vertical. With this choice the chain seen from the tip gripper is the
same chain with the joint vector reversed: ``T(reversed(theta)) == inv(T(theta))``, which is what
lets either gripper be the base (:mod:`walker_core.joint_roles`).

The task coordinates of eq (1) are ``(X, Y, Z, alpha, beta)``: the tip position in m, ``alpha``
the gripper's tilt from vertical in the arm plane, ``alpha = pi - (th2 + th3 + th4)``, and
``beta = th5``. Normal walking keeps ``alpha = 0`` (gripper vertical).

Misprints corrected
-------------------
Eq (5) is printed as ``th2 = asin(r / [sqrt(X^2+Y^2) - l1 sin(alpha)]^(1/2)) - th3/2``. The
ratio is inverted and the square root spurious: the chord from J2 to J4 has length ``r`` and
makes the angle ``th2 + th3/2`` with the vertical, so
``sin(th2 + th3/2) = (sqrt(X^2+Y^2) - l1 sin alpha) / r``.
We use ``atan2`` of the chord's horizontal and vertical components, which also covers
targets below the base height (where ``asin`` returns the wrong branch). Eq (3) is printed with
``atan(-X/Y)``; ``atan2(-X, Y)`` is the form valid in all four quadrants.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

__all__ = [
    'KinematicsError', 'UnreachableError', 'SingularConfigurationError', 'JointLimitError',
    'WalkerKinematics', 'rot_x', 'rot_y', 'rot_z', 'translate_z', 'invert_transform',
]

_TWO_PI = 2.0 * math.pi
_SINGULAR_DISTANCE = 1e-9  # [m] below this a direction is undefined
ELBOWS = ('up', 'down')
REACHES = ('forward', 'backward')


class KinematicsError(ValueError):
    """A kinematics request that has no valid answer."""


class UnreachableError(KinematicsError):
    """The target is outside the workspace."""


class SingularConfigurationError(KinematicsError):
    """The target is at a singular configuration where a joint angle is undefined."""


class JointLimitError(KinematicsError):
    """A joint angle lies outside its limits."""


def rot_x(angle: float) -> np.ndarray:
    """Homogeneous rotation about x by ``angle`` rad."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])


def rot_y(angle: float) -> np.ndarray:
    """Homogeneous rotation about y by ``angle`` rad."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, 0, s, 0], [0, 1, 0, 0], [-s, 0, c, 0], [0, 0, 0, 1.0]])


def rot_z(angle: float) -> np.ndarray:
    """Homogeneous rotation about z by ``angle`` rad."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])


def translate_z(distance: float) -> np.ndarray:
    """Homogeneous translation along z by ``distance`` m."""
    t = np.eye(4)
    t[2, 3] = distance
    return t


def invert_transform(transform: np.ndarray) -> np.ndarray:
    """Inverse of a rigid homogeneous transform."""
    rotation = transform[:3, :3]
    inverse = np.eye(4)
    inverse[:3, :3] = rotation.T
    inverse[:3, 3] = -rotation.T @ transform[:3, 3]
    return inverse


def _as_vector(values: Sequence[float], length: int, what: str) -> np.ndarray:
    array = np.asarray(values, dtype=float)
    if array.shape != (length,):
        raise KinematicsError(f'{what} must have {length} values, got shape {array.shape}')
    if not np.all(np.isfinite(array)):
        raise KinematicsError(f'{what} must be finite, got {array.tolist()}')
    return array


def _wrap(angle: float, reference: float | None) -> float:
    """Equivalent of ``angle`` (mod 2 pi) nearest ``reference``, or in (-pi, pi] without one."""
    if reference is None:
        wrapped = math.remainder(angle, _TWO_PI)
        return math.pi if wrapped == -math.pi else wrapped
    return angle + _TWO_PI * round((reference - angle) / _TWO_PI)


@dataclasses.dataclass(frozen=True)
class WalkerKinematics:
    """Kinematics of the 5-DOF walker in role order J1..J5.

    Parameters
    ----------
    l1 : float
        Wrist offset, pitch axis to gripper contact point [m].
    l2 : float
        Length of each link [m].
    lower, upper : sequence of 5 float, optional
        Joint limits of roles J1..J5 [rad]; unlimited when omitted.
    """

    l1: float
    l2: float
    lower: tuple[float, ...] = (-math.inf,) * 5
    upper: tuple[float, ...] = (math.inf,) * 5

    def __post_init__(self) -> None:
        if not (math.isfinite(self.l1) and math.isfinite(self.l2) and 0 < self.l1 < self.l2):
            raise ValueError(f'need 0 < l1 < l2, got l1={self.l1} m, l2={self.l2} m')
        if len(self.lower) != 5 or len(self.upper) != 5:
            raise ValueError('joint limits need 5 values each')
        if any(lo >= hi for lo, hi in zip(self.lower, self.upper, strict=True)):
            raise ValueError(f'lower limits {self.lower} must be below upper {self.upper}')

    @classmethod
    def from_parameters(cls, params) -> 'WalkerKinematics':
        """Build from :class:`walker_core.robot_parameters.WalkerParameters`."""
        drive = params.robot.drive
        return cls(l1=params.robot.geometry.l1, l2=params.robot.geometry.l2,
                   lower=tuple(drive.role_array('position_min')),
                   upper=tuple(drive.role_array('position_max')))

    @property
    def max_reach(self) -> float:
        """Largest J2-J4 distance, 2*l2 [m] (links stretched, th3 = 0)."""
        return 2.0 * self.l2

    # ----------------------------------------------------------------------------- forward
    def forward(self, theta: Sequence[float]) -> np.ndarray:
        """Task coordinates ``[X, Y, Z, alpha, beta]`` of the tip (paper eq (1)).

        Parameters
        ----------
        theta : sequence of 5 float
            Joint angles J1..J5 [rad].

        Returns
        -------
        ndarray, shape (5,)
            Tip position [m] in the base frame and the angles alpha, beta [rad]; alpha is
            wrapped to (-pi, pi], beta is th5 as given.
        """
        t1, t2, t3, t4, t5 = _as_vector(theta, 5, 'joint angles')
        l1, l2 = self.l1, self.l2
        reach = l2 * math.sin(t2) + l2 * math.sin(t2 + t3) + l1 * math.sin(t2 + t3 + t4)
        height = l1 + l2 * math.cos(t2) + l2 * math.cos(t2 + t3) + l1 * math.cos(t2 + t3 + t4)
        return np.array([-math.sin(t1) * reach, math.cos(t1) * reach, height,
                         _wrap(math.pi - (t2 + t3 + t4), None), t5])

    def forward_transform(self, theta: Sequence[float]) -> np.ndarray:
        """Homogeneous transform of the tip gripper frame in the base frame (4x4)."""
        t1, t2, t3, t4, t5 = _as_vector(theta, 5, 'joint angles')
        return (rot_z(t1) @ translate_z(self.l1) @ rot_x(-t2) @ translate_z(self.l2)
                @ rot_x(-t3) @ translate_z(self.l2) @ rot_x(-t4) @ translate_z(self.l1)
                @ rot_z(t5) @ rot_y(math.pi))

    def joint_positions(self, theta: Sequence[float]) -> np.ndarray:
        """Positions [m] of the J2, J3, J4 axes and of the tip in the base frame, shape (4, 3)."""
        t1, t2, t3, t4, _ = _as_vector(theta, 5, 'joint angles')
        l1, l2 = self.l1, self.l2
        in_plane = np.array([
            [0.0, l1],
            [l2 * math.sin(t2), l1 + l2 * math.cos(t2)],
            [l2 * (math.sin(t2) + math.sin(t2 + t3)),
             l1 + l2 * (math.cos(t2) + math.cos(t2 + t3))],
        ])
        tip = in_plane[2] + l1 * np.array([math.sin(t2 + t3 + t4), math.cos(t2 + t3 + t4)])
        points = np.vstack([in_plane, tip])
        return np.column_stack([-math.sin(t1) * points[:, 0], math.cos(t1) * points[:, 0],
                                points[:, 1]])

    def jacobian(self, theta: Sequence[float]) -> np.ndarray:
        """Analytic Jacobian d[X, Y, Z, alpha, beta]/d theta of eq (1), shape (5, 5)."""
        t1, t2, t3, t4, _ = _as_vector(theta, 5, 'joint angles')
        l1, l2 = self.l1, self.l2
        s2, s23, s234 = math.sin(t2), math.sin(t2 + t3), math.sin(t2 + t3 + t4)
        c2, c23, c234 = math.cos(t2), math.cos(t2 + t3), math.cos(t2 + t3 + t4)
        reach = l2 * s2 + l2 * s23 + l1 * s234
        d_reach = np.array([l2 * c2 + l2 * c23 + l1 * c234, l2 * c23 + l1 * c234, l1 * c234])
        d_height = -np.array([reach, l2 * s23 + l1 * s234, l1 * s234])
        s1, c1 = math.sin(t1), math.cos(t1)
        jac = np.zeros((5, 5))
        jac[0, 0], jac[1, 0] = -c1 * reach, -s1 * reach
        jac[0, 1:4], jac[1, 1:4], jac[2, 1:4] = -s1 * d_reach, c1 * d_reach, d_height
        jac[3, 1:4] = -1.0
        jac[4, 4] = 1.0
        return jac

    # ----------------------------------------------------------------------------- inverse
    def inverse(self, pose: Sequence[float], elbow: str = 'up', reach: str = 'forward',
                reference: Sequence[float] | None = None, check_limits: bool = True
                ) -> np.ndarray:
        """Joint angles J1..J5 that put the tip at ``pose`` (paper eqs (2)-(7), corrected).

        Parameters
        ----------
        pose : sequence of 5 float
            ``[X, Y, Z, alpha, beta]``: tip position [m] in the base frame, angles [rad].
        elbow : {'up', 'down'}
            ``'up'``: th3 >= 0, the vertex above the J2-J4 chord for a forward reach (the
            inverted V of normal walking); ``'down'``: th3 <= 0.
        reach : {'forward', 'backward'}
            ``'forward'``: the arm plane faces the tip (th1 = atan2(-X, Y), eq (3));
            ``'backward'``: th1 + pi with the arm leaning back over the base.
        reference : sequence of 5 float, optional
            Angles [rad] to stay near: each result is the 2 pi-equivalent closest to it. Also
            resolves th1 when the tip is on the base yaw axis.
        check_limits : bool
            Raise :class:`JointLimitError` when the result is outside the joint limits.

        Returns
        -------
        ndarray, shape (5,)
            Joint angles [rad].

        Raises
        ------
        UnreachableError
            The wrist is farther than 2*l2 from J2.
        SingularConfigurationError
            The wrist coincides with J2 (links folded), or the tip is on the yaw axis and no
            ``reference`` gives th1.
        JointLimitError
            The solution violates a joint limit (when ``check_limits``).
        KinematicsError
            Malformed input (wrong length, NaN or infinity, unknown branch name).
        """
        x, y, z, alpha, beta = _as_vector(pose, 5, 'tip pose')
        if elbow not in ELBOWS:
            raise KinematicsError(f'elbow must be one of {ELBOWS}, got {elbow!r}')
        if reach not in REACHES:
            raise KinematicsError(f'reach must be one of {REACHES}, got {reach!r}')
        ref = None if reference is None else _as_vector(reference, 5, 'reference angles')
        horizontal = math.hypot(x, y)
        if horizontal < _SINGULAR_DISTANCE:
            if ref is None:
                raise SingularConfigurationError(
                    'the tip is on the base yaw axis (X = Y = 0): joint 1 is undefined; '
                    'give reference angles to choose it')
            theta1 = ref[0]
        else:
            theta1 = math.atan2(-x, y)  # eq (3), valid in all quadrants
        if reach == 'backward':
            theta1 += math.pi
            horizontal = -horizontal
        # Chord from J2 to J4 in the arm plane (eq (2)): J4 = tip - l1 * (sin a, -cos a).
        chord_h = horizontal - self.l1 * math.sin(alpha)
        chord_v = z - self.l1 * (1.0 - math.cos(alpha))
        chord = math.hypot(chord_h, chord_v)
        if chord > self.max_reach * (1.0 + 1e-12):
            raise UnreachableError(
                f'tip pose {np.round(pose, 6).tolist()} is out of reach: the wrist is '
                f'{chord:.4f} m from J2, more than 2*l2 = {self.max_reach:.4f} m')
        if chord < _SINGULAR_DISTANCE:
            raise SingularConfigurationError(
                'the wrist coincides with J2 (links folded onto each other): joint 2 is '
                'undefined')
        cos3 = (chord * chord - 2.0 * self.l2 ** 2) / (2.0 * self.l2 ** 2)  # eq (4)
        theta3 = math.acos(min(1.0, max(-1.0, cos3)))
        if elbow == 'down':
            theta3 = -theta3
        theta2 = math.atan2(chord_h, chord_v) - 0.5 * theta3  # eq (5), corrected
        theta4 = math.pi - alpha - theta2 - theta3  # eq (6)
        theta5 = beta  # eq (7)
        raw = (theta1, theta2, theta3, theta4, theta5)
        theta = np.array([_wrap(a, None if ref is None else ref[i]) for i, a in enumerate(raw)])
        if check_limits:
            self.check_joint_limits(theta)
        return theta

    def inverse_many(self, poses: np.ndarray, elbow: str = 'up', reach: str = 'forward',
                     references: np.ndarray | None = None) -> np.ndarray:
        """:meth:`inverse` of many poses at once (paper eqs (2)-(7), corrected), unchecked.

        The same solution, row by row, as :meth:`inverse` with ``check_limits=False``, in one
        pass of array arithmetic: a path of a thousand samples costs about what ten single
        solutions do. What :meth:`inverse` would raise for is a row of NaN instead; the joint
        limits are not checked (:meth:`within_limits_many`).

        Parameters
        ----------
        poses : array_like, shape (N, 5)
            ``[X, Y, Z, alpha, beta]`` per row: tip position [m], angles [rad].
        elbow, reach : str
            The branch, as for :meth:`inverse`.
        references : array_like, shape (N, 5), optional
            Angles [rad] to stay near, per row, as ``reference`` for :meth:`inverse`.

        Returns
        -------
        ndarray, shape (N, 5)
            Joint angles [rad]; NaN rows where the pose is out of reach, the wrist is on J2,
            or the tip is on the yaw axis without a reference.

        Raises
        ------
        KinematicsError
            Malformed input (shape, NaN or infinity, unknown branch name).
        """
        poses = np.asarray(poses, dtype=float)
        if poses.ndim != 2 or poses.shape[1] != 5:
            raise KinematicsError(f'tip poses must have shape (N, 5), got {poses.shape}')
        if not np.all(np.isfinite(poses)):
            raise KinematicsError('tip poses must be finite')
        if elbow not in ELBOWS:
            raise KinematicsError(f'elbow must be one of {ELBOWS}, got {elbow!r}')
        if reach not in REACHES:
            raise KinematicsError(f'reach must be one of {REACHES}, got {reach!r}')
        ref = None
        if references is not None:
            ref = np.asarray(references, dtype=float)
            if ref.shape != poses.shape or not np.all(np.isfinite(ref)):
                raise KinematicsError(f'reference angles must be finite, shape {poses.shape}, '
                                      f'got shape {ref.shape}')
        x, y, z, alpha, beta = poses.T
        horizontal = np.hypot(x, y)
        on_axis = horizontal < _SINGULAR_DISTANCE
        theta1 = np.arctan2(-x, y)  # eq (3)
        if ref is not None:
            theta1 = np.where(on_axis, ref[:, 0], theta1)
        if reach == 'backward':
            theta1 = theta1 + math.pi
            horizontal = -horizontal
        chord_h = horizontal - self.l1 * np.sin(alpha)  # eq (2)
        chord_v = z - self.l1 * (1.0 - np.cos(alpha))
        chord = np.hypot(chord_h, chord_v)
        solvable = (chord <= self.max_reach * (1.0 + 1e-12)) & (chord >= _SINGULAR_DISTANCE)
        if ref is None:
            solvable &= ~on_axis
        cos3 = (chord * chord - 2.0 * self.l2 ** 2) / (2.0 * self.l2 ** 2)  # eq (4)
        theta3 = np.arccos(np.clip(cos3, -1.0, 1.0))
        if elbow == 'down':
            theta3 = -theta3
        theta2 = np.arctan2(chord_h, chord_v) - 0.5 * theta3  # eq (5), corrected
        theta4 = math.pi - alpha - theta2 - theta3  # eq (6)
        raw = np.column_stack([theta1, theta2, theta3, theta4, beta])  # eq (7): th5 = beta
        if ref is None:
            theta = raw - _TWO_PI * np.round(raw / _TWO_PI)
            theta[theta == -math.pi] = math.pi
        else:
            theta = raw + _TWO_PI * np.round((ref - raw) / _TWO_PI)
        theta[~solvable] = np.nan
        return theta

    def within_limits_many(self, thetas: np.ndarray) -> np.ndarray:
        """:meth:`within_limits` of many joint vectors at once.

        Parameters
        ----------
        thetas : array_like, shape (N, 5)
            Joint angles J1..J5 [rad] per row.

        Returns
        -------
        ndarray of bool, shape (N,)
            True where every angle of the row is within its limits; False for a row with NaN
            (what :meth:`inverse_many` gives where there is no solution).

        Raises
        ------
        KinematicsError
            If ``thetas`` is not of shape (N, 5).
        """
        thetas = np.asarray(thetas, dtype=float)
        if thetas.ndim != 2 or thetas.shape[1] != 5:
            raise KinematicsError(f'joint angles must have shape (N, 5), got {thetas.shape}')
        return np.all((thetas >= np.asarray(self.lower))
                      & (thetas <= np.asarray(self.upper)), axis=1)

    def inverse_all(self, pose: Sequence[float], reference: Sequence[float] | None = None
                    ) -> list[np.ndarray]:
        """Every distinct branch solution of :meth:`inverse` within the joint limits.

        Returns
        -------
        list of ndarray
            Up to four solutions (elbow up/down, reach forward/backward); one when the links
            are stretched (both elbows coincide). Empty when every branch breaks a limit.
        """
        solutions: list[np.ndarray] = []
        for reach in REACHES:
            for elbow in ELBOWS:
                try:
                    theta = self.inverse(pose, elbow, reach, reference)
                except JointLimitError:
                    continue
                if not any(np.allclose(theta, s, atol=1e-9) for s in solutions):
                    solutions.append(theta)
        return solutions

    def check_joint_limits(self, theta: Sequence[float]) -> None:
        """Raise :class:`JointLimitError` naming the first joint outside its limits."""
        theta = _as_vector(theta, 5, 'joint angles')
        for i, (value, lo, hi) in enumerate(zip(theta, self.lower, self.upper, strict=True)):
            if not lo <= value <= hi:
                raise JointLimitError(
                    f'J{i + 1} = {value:.4f} rad is outside its limits [{lo:.4f}, {hi:.4f}] rad')

    def within_limits(self, theta: Sequence[float]) -> bool:
        """Return True when every joint angle is within its limits."""
        try:
            self.check_joint_limits(theta)
        except JointLimitError:
            return False
        return True
