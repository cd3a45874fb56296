"""Where the walker is held: which gripper is the base, the node it sits on, its heading.

The supervisor decides which gripper is the base (``phase.base_gripper``, the same as
``control_mode.base_gripper``); the plant reports which gripper is screwed into which node
(``gripper_states``). The base gripper's frame sits at its node's hole mouth, z up (it is
screwed in vertically), turned about z by a *heading*. Like the supervisor's base frame, the
heading follows from the other gripper's node whenever both are screwed in: the direction from
the base to the other node in the truss, against the direction of the other gripper in the
base frame by the forward kinematics. It is measured again at every sample while both hold,
and kept while the other gripper is free. No error thus accumulates from step to step, and
each gripper that is screwed in is drawn exactly at its node.

When the base changes (both grippers screwed in), the new base is placed at its node with the
heading measured from the same joint angles: every link stays where it was, but for the part
of the loop the rigid model does not close (the links' bending, the seat), which moves from
one gripper to the other. With a stance the model closes exactly, nothing moves at all.

The pose of the tree's root (``gripper_a``) in the truss follows from the base's pose and the
joint angles (:meth:`walker_viz.core.robot_tree.RobotTree.root_pose`). It is published with the
joint transforms, on ``/tf``, at the same stamp: a static transform holds for all time in a TF
buffer (tf2 keeps one value of each static frame, Foxglove and RViz likewise), so a base sent
again on ``/tf_static`` at each step would move the robot in the past too (a bag scrubbed back
would show every step's robot at the last base), and a ``/tf_static`` message and the ``/tf``
samples of another stamp would meet at the wrong instants.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

import numpy as np

from walker_core.joint_roles import GRIPPERS, other_gripper, validate_gripper
from walker_core.truss import Truss, UnknownNodeError
from walker_core.urdf import GRIPPER_LINKS
from walker_viz.core.robot_tree import RobotTree

__all__ = ['BaseAnchor', 'BaseTracker', 'heading_from_stance']

_DIRECTION_EPSILON = 1e-6  # [m] below this a horizontal direction is undefined


@dataclasses.dataclass(frozen=True)
class BaseAnchor:
    """The base gripper's frame in the truss.

    Attributes
    ----------
    gripper : str
        ``'a'`` or ``'b'``.
    node : str
        The truss node it is screwed into.
    position : ndarray, shape (3,)
        The node's hole mouth [m] in the truss frame.
    heading : float
        Rotation [rad] of the gripper's frame about the truss z axis.
    """

    gripper: str
    node: str
    position: np.ndarray
    heading: float

    def matrix(self) -> np.ndarray:
        """Pose [4x4] of the base gripper's frame in the truss frame."""
        c, s = math.cos(self.heading), math.sin(self.heading)
        pose = np.eye(4)
        pose[:2, :2] = [[c, -s], [s, c]]
        pose[:3, 3] = self.position
        return pose


def heading_from_stance(tree: RobotTree, base: str, angles: Mapping[str, float],
                        base_position: np.ndarray, other_position: np.ndarray) -> float:
    """Heading [rad] of the base frame with both grippers screwed in.

    The angle that turns the other gripper's direction in the base frame (forward kinematics
    of ``angles``) onto the direction of its node from the base's node in the truss.

    Raises
    ------
    ValueError
        If either direction is undefined (the other gripper above the base's axis).
    """
    base_link, other_link = GRIPPER_LINKS[base], GRIPPER_LINKS[other_gripper(base)]
    in_base = (np.linalg.inv(tree.link_in_root(base_link, angles))
               @ tree.link_in_root(other_link, angles))[:2, 3]
    in_truss = (np.asarray(other_position, dtype=float) - np.asarray(base_position))[:2]
    if np.linalg.norm(in_base) < _DIRECTION_EPSILON or \
            np.linalg.norm(in_truss) < _DIRECTION_EPSILON:
        raise ValueError('the base heading is undefined: the other gripper is on the base '
                         'gripper axis')
    heading = math.atan2(in_truss[1], in_truss[0]) - math.atan2(in_base[1], in_base[0])
    return math.remainder(heading, 2.0 * math.pi)


class BaseTracker:
    """Follows the base and the grippers' nodes; places the robot's root in the truss.

    Parameters
    ----------
    tree : RobotTree
        The robot's tree (its root, its gripper links).
    truss : Truss
        The truss the nodes belong to.
    default_base : str
        The base assumed until the supervisor has said which it is (the plant's start).
    """

    def __init__(self, tree: RobotTree, truss: Truss, default_base: str = 'a') -> None:
        self.tree = tree
        self.truss = truss
        self._decided: str | None = None
        self._default = validate_gripper(default_base)
        self._attached: dict[str, str] = {}
        self._heading = 0.0

    @property
    def base(self) -> str:
        """The base gripper: the supervisor's decision, else the only one screwed in."""
        if self._decided is not None:
            return self._decided
        if len(self._attached) == 1:
            return next(iter(self._attached))
        return self._default

    def set_base(self, gripper: str) -> bool:
        """Take the supervisor's base; an empty name (no decision yet) is ignored.

        Returns whether the base changed. Raises ValueError for a name that is no gripper.
        """
        if not gripper:
            return False
        before = self.base
        self._decided = validate_gripper(gripper)
        return self.base != before

    def set_attached(self, nodes: Mapping[str, str]) -> None:
        """Take which gripper is screwed into which node (the others free).

        Unknown nodes are left out: a gripper screwed into no node of this truss cannot
        anchor it.
        """
        attached = {}
        for gripper, node in nodes.items():
            try:
                self.truss.index(node)
            except UnknownNodeError:
                continue
            if gripper in GRIPPERS:
                attached[gripper] = node
        self._attached = attached

    def anchor(self, angles: Mapping[str, float]) -> BaseAnchor | None:
        """Return the base's frame in the truss at ``angles`` (None while the base is not held).

        With both grippers screwed in, the heading is measured again from ``angles``.
        """
        base = self.base
        node = self._attached.get(base)
        if node is None:
            return None
        position = self.truss.position(node)
        other = self._attached.get(other_gripper(base))
        if other is not None:
            try:
                self._heading = heading_from_stance(self.tree, base, angles, position,
                                                    self.truss.position(other))
            except ValueError:
                pass  # keep the last heading
        return BaseAnchor(base, node, position, self._heading)

    def root_pose(self, angles: Mapping[str, float]) -> np.ndarray | None:
        """Pose [4x4] of the tree's root link in the truss, or None while nothing holds."""
        anchor = self.anchor(angles)
        if anchor is None:
            return None
        return self.tree.root_pose(GRIPPER_LINKS[anchor.gripper], anchor.matrix(), angles)
