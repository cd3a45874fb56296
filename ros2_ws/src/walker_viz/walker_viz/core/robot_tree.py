"""The walker's TF tree from its URDF and joint angles, as robot_state_publisher computes it.

The tree is the description view of :func:`walker_core.urdf.description_urdf` (what the plant
publishes on ``robot_description``), read from the URDF text itself, so no length is copied:
each joint is ``parent -> child`` with the transform ``origin * rotation(axis, angle)`` (URDF's
convention; a fixed joint has no rotation). Its root link is ``gripper_a``, whichever gripper
holds the truss. What the base changes is only where that root sits in the world frame
``truss`` (:meth:`RobotTree.root_pose`): the robot's own links keep one parent each forever, so
no frame changes its parent or moves between ``/tf_static`` and ``/tf`` when the grippers
swap roles (see :mod:`walker_viz.core.base_anchor`).

Transforms are 4x4 homogeneous matrices (numpy), lengths in m, angles in rad.
"""

from __future__ import annotations

import dataclasses
import math
import xml.etree.ElementTree as ElementTree
from collections.abc import Mapping

import numpy as np

from walker_core.kinematics import invert_transform

__all__ = ['WORLD_FRAME', 'JointTransform', 'UrdfJoint', 'RobotTree', 'rpy_matrix',
           'axis_rotation', 'axis_rotations']

#: The world-fixed frame: the truss face (z up out of it, node n0_0 at the origin).
WORLD_FRAME = 'truss'


def rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Rotation (3x3) of URDF's fixed-axis roll, pitch, yaw: ``Rz(yaw) Ry(pitch) Rx(roll)``."""
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    return np.array([
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr]])


def axis_rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation (3x3) by ``angle`` rad about the unit vector ``axis`` (Rodrigues)."""
    x, y, z = np.asarray(axis, dtype=float).tolist()
    c, s = math.cos(angle), math.sin(angle)
    t = 1.0 - c  # c I + s [axis]x + (1 - c) axis axis^T, element by element
    return np.array([[t * x * x + c, t * x * y - s * z, t * x * z + s * y],
                     [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
                     [t * x * z - s * y, t * y * z + s * x, t * z * z + c]])


def axis_rotations(axis: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Rotations (N, 3, 3) by each of ``angles`` [rad] about the unit vector ``axis``."""
    axis = np.asarray(axis, dtype=float)
    angles = np.asarray(angles, dtype=float)
    x, y, z = axis.tolist()
    skew = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    cos, sin = np.cos(angles)[:, None, None], np.sin(angles)[:, None, None]
    return cos * np.eye(3) + sin * skew + (1.0 - cos) * np.outer(axis, axis)


@dataclasses.dataclass(frozen=True)
class JointTransform:
    """One edge of the TF tree: the pose [4x4] of ``child`` in ``parent``."""

    parent: str
    child: str
    matrix: np.ndarray


@dataclasses.dataclass(frozen=True)
class UrdfJoint:
    """A joint of the URDF: its frames, its fixed origin and, when it moves, its axis."""

    name: str
    kind: str
    parent: str
    child: str
    origin: np.ndarray
    axis: np.ndarray | None

    @property
    def moves(self) -> bool:
        """True for a joint whose angle comes from ``joint_states``."""
        return self.kind in ('revolute', 'continuous')

    def transform(self, angle: float = 0.0) -> np.ndarray:
        """Pose of the child link in the parent link at ``angle`` [rad]."""
        if not self.moves:
            return self.origin
        pose = self.origin.copy()  # origin * rotation(axis, angle): the rotation has no shift
        pose[:3, :3] = self.origin[:3, :3] @ axis_rotation(self.axis, angle)
        return pose


def _vector(element, attribute: str, default: str) -> np.ndarray:
    text = default if element is None else element.get(attribute, default)
    return np.array([float(v) for v in text.split()])


def _parse_joint(element) -> UrdfJoint:
    origin_element = element.find('origin')
    origin = np.eye(4)
    origin[:3, :3] = rpy_matrix(*_vector(origin_element, 'rpy', '0 0 0'))
    origin[:3, 3] = _vector(origin_element, 'xyz', '0 0 0')
    kind = element.get('type')
    axis = None
    if kind in ('revolute', 'continuous'):
        axis = _vector(element.find('axis'), 'xyz', '1 0 0')
        axis = axis / np.linalg.norm(axis)
    return UrdfJoint(element.get('name'), kind, element.find('parent').get('link'),
                     element.find('child').get('link'), origin, axis)


class RobotTree:
    """Forward kinematics of every link of a URDF, rooted at its root link.

    Parameters
    ----------
    urdf : str
        The robot description (the description view of :mod:`walker_core.urdf`).

    Raises
    ------
    ValueError
        If the URDF is not a tree (no single root, a link with two parents) or a joint type
        is one TF cannot express here (prismatic, floating, planar).
    """

    def __init__(self, urdf: str) -> None:
        root = ElementTree.fromstring(urdf)
        self.joints = tuple(_parse_joint(j) for j in root.findall('joint'))
        unsupported = [j.name for j in self.joints
                       if j.kind not in ('fixed', 'revolute', 'continuous')]
        if unsupported:
            raise ValueError(f'joints of unsupported types: {", ".join(unsupported)}')
        links = [link.get('name') for link in root.findall('link')]
        children = [j.child for j in self.joints]
        if len(set(children)) != len(children):
            raise ValueError('the URDF is not a tree: a link has two parent joints')
        roots = [link for link in links if link not in children]
        if len(roots) != 1:
            raise ValueError(f'the URDF needs exactly one root link, found {roots}')
        self.root = roots[0]
        self.links = tuple(links)
        self.moving_joints = tuple(j for j in self.joints if j.moves)
        self._by_child = {j.child: j for j in self.joints}

    @property
    def joint_names(self) -> tuple[str, ...]:
        """Names of the moving joints, in URDF order."""
        return tuple(j.name for j in self.moving_joints)

    def static_transforms(self) -> list[JointTransform]:
        """Return the fixed joints' transforms: what ``/tf_static`` carries for the robot."""
        return [JointTransform(j.parent, j.child, j.transform())
                for j in self.joints if not j.moves]

    def moving_transforms(self, angles: Mapping[str, float]) -> list[JointTransform]:
        """Return the moving joints' transforms at ``angles`` [rad] (joint name -> angle).

        Raises
        ------
        ValueError
            If an angle is missing or not finite.
        """
        return [JointTransform(j.parent, j.child, j.transform(self._angle(angles, j.name)))
                for j in self.moving_joints]

    @staticmethod
    def _angle(angles: Mapping[str, float], name: str) -> float:
        try:
            angle = float(angles[name])
        except KeyError:
            raise ValueError(f'no angle for joint {name!r}') from None
        if not math.isfinite(angle):
            raise ValueError(f'joint {name!r} has a non-finite angle ({angle})')
        return angle

    def _chain(self, link: str) -> list[UrdfJoint]:
        """Return the joints from the root link to ``link``, root first (ValueError: no link)."""
        if link not in self.links:
            raise ValueError(f'unknown link {link!r}')
        chain = []
        while link != self.root:
            joint = self._by_child[link]
            chain.append(joint)
            link = joint.parent
        return chain[::-1]

    def link_in_root(self, link: str, angles: Mapping[str, float]) -> np.ndarray:
        """Pose [4x4] of ``link`` in the root link at ``angles``.

        Raises
        ------
        ValueError
            If ``link`` is not a link of the tree, or an angle on its chain is missing.
        """
        chain = self._chain(link)
        pose = np.eye(4)
        for joint in chain:
            angle = self._angle(angles, joint.name) if joint.moves else 0.0
            pose = pose @ joint.transform(angle)
        return pose

    def links_in_root(self, link: str, angles: Mapping[str, np.ndarray]) -> np.ndarray:
        """Poses (N, 4, 4) of ``link`` in the root link, one per row of joint angles.

        ``angles`` maps each joint on the link's chain to its N angles [rad];
        :meth:`link_in_root` of each row, computed for all rows at once.

        Raises
        ------
        ValueError
            If ``link`` is not a link of the tree, or an angle on its chain is missing or not
            finite.
        """
        chain = self._chain(link)
        rows = {len(np.atleast_1d(np.asarray(v))) for v in angles.values()}
        if len(rows) != 1:
            raise ValueError('joint angle columns of different lengths: '
                             f'{sorted(rows)}' if rows else 'no joint angles given')
        count = rows.pop()
        pose = np.broadcast_to(np.eye(4), (count, 4, 4))
        for joint in chain:
            if not joint.moves:
                pose = pose @ joint.origin
                continue
            if joint.name not in angles:
                raise ValueError(f'no angle for joint {joint.name!r}')
            column = np.asarray(angles[joint.name], dtype=float).reshape(count)
            if not np.all(np.isfinite(column)):
                raise ValueError(f'joint {joint.name!r} has a non-finite angle')
            motion = np.broadcast_to(joint.origin, (count, 4, 4)).copy()
            motion[:, :3, :3] = joint.origin[:3, :3] @ axis_rotations(joint.axis, column)
            pose = pose @ motion
        return pose

    def root_pose(self, holding_link: str, holding_pose: np.ndarray,
                  angles: Mapping[str, float]) -> np.ndarray:
        """Pose [4x4] of the root link in the world, given where ``holding_link`` is held.

        The base gripper's link is where the truss holds the robot; the root link follows
        from it through the joint angles (the identity when the root itself holds).
        """
        return np.asarray(holding_pose, dtype=float) @ invert_transform(
            self.link_in_root(holding_link, angles))
