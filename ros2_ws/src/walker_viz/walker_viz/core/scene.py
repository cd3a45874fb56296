"""What the viz node draws, decided from what it hears (free of ROS).

:class:`WalkerScene` keeps the walker's tree, the base and the grippers' nodes
(:class:`~walker_viz.core.base_anchor.BaseTracker`), the step's target node and the planned
tip path, and answers with what to send: the transforms of a joint state (the root placed in
the truss while a gripper holds it), the static transforms, and the markers. The viz node
feeds it its subscriptions; a headless loop feeds it the same topics by calls.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from walker_core.gripper_state import GripperState
from walker_core.robot_parameters import WalkerParameters
from walker_core.truss import Truss, UnknownNodeError
from walker_core.urdf import GRIPPER_LINKS, robot_urdf
from walker_viz.core.base_anchor import BaseTracker
from walker_viz.core.markers import (
    MarkerSpec, target_marker, tip_path, tip_path_marker, truss_markers)
from walker_viz.core.parameters import VizParameters
from walker_viz.core.robot_tree import WORLD_FRAME, JointTransform, RobotTree

__all__ = ['WalkerScene', 'HOLDING']

#: Gripper states in which a gripper is in its hole.
HOLDING = (GripperState.ATTACHED, GripperState.UNSCREWING)


class WalkerScene:
    """The walker's TF and markers, from its joint states, grippers, base, phase and plans.

    Parameters
    ----------
    params : WalkerParameters
    settings : VizParameters
        ``viz.flexible``: the tree has the links' bending joints.
    """

    def __init__(self, params: WalkerParameters, settings: VizParameters) -> None:
        self.truss = Truss.from_parameters(params)
        self.tree = RobotTree(robot_urdf(params, flexible=settings.flexible, rotors=False))
        self.tracker = BaseTracker(self.tree, self.truss)
        self.angles: dict[str, float] | None = None  # [rad] of the newest joint state drawn
        self.target = ''  # the step's target node ('' when none)
        self.path: np.ndarray | None = None  # [m] the planned tip path in the truss
        self._truss_markers = truss_markers(self.truss, params.truss.hole_depth)

    def transforms(self, names: Sequence[str], positions: Sequence[float],
                   measured: Mapping[str, np.ndarray] | None = None) -> list[JointTransform]:
        """Return the moving transforms of a joint state, and the root's pose while held.

        ``measured`` maps a gripper to its pose [4x4, m] in the truss at the state's instant,
        where a simulator measures it (the plant's ``gripper_<x>_pose``). With the base
        gripper's, the tree is placed at it: a gripper screwed in sits in its seat up to the
        seat's compliance (a tilt of a fraction of a milliradian under the arm's weight), which
        the joint angles cannot tell and which, over the arm's 0.9 m, is a few tenths of a
        millimetre at the other gripper. Without it (a real robot), the base is placed at its
        node, upright, at the heading of the stance (:mod:`walker_viz.core.base_anchor`).

        Raises
        ------
        ValueError
            The names and positions do not pair up, or a moving joint is missing.
        """
        if len(names) != len(positions):
            raise ValueError(f'{len(names)} names but {len(positions)} positions')
        angles = dict(zip(names, positions, strict=True))
        edges = self.tree.moving_transforms(angles)
        self.angles = angles
        root = self.tracker.root_pose(angles)  # the stance's heading kept up to date
        base = self.tracker.base
        if measured and base in measured:
            root = self.tree.root_pose(GRIPPER_LINKS[base], measured[base], angles)
        if root is not None:
            edges.append(JointTransform(WORLD_FRAME, self.tree.root, root))
        return edges

    def grippers(self, states: Mapping[str, tuple[str, str]]) -> None:
        """Take the gripper states: gripper -> (state name, node)."""
        self.tracker.set_attached({gripper: node for gripper, (state, node) in states.items()
                                   if state in HOLDING})

    def base(self, gripper: str) -> bool:
        """Take the supervisor's base gripper; return True when the markers change.

        A new base drops the planned path (it was planned from the other).

        Raises
        ------
        ValueError
            ``gripper`` is no gripper.
        """
        if self.tracker.set_base(gripper) and self.path is not None:
            self.path = None
            return True
        return False

    def set_target(self, node: str) -> bool:
        """Take the step's target node ('' when none); return True when it changed."""
        if node == self.target:
            return False
        self.target = node
        return True

    def plan(self, names: Sequence[str], positions) -> bool:
        """Draw the tip path of a planned trajectory; return True when it is drawn.

        Nothing is drawn before a joint state, or while no gripper holds the base.

        Raises
        ------
        ValueError
            The trajectory's joints are not the walker's.
        """
        if self.angles is None or not len(positions):
            return False
        anchor = self.tracker.anchor(self.angles)
        if anchor is None:
            return False
        self.path = tip_path(self.tree, anchor, list(names), np.asarray(positions))
        return True

    def markers(self) -> tuple[list[MarkerSpec], list[str]]:
        """Return the markers to show (truss, target, path) and the namespaces to delete."""
        specs = list(self._truss_markers)
        deleted = []
        try:
            specs.append(target_marker(self.truss, self.target))
        except UnknownNodeError:
            deleted.append('target')
        if self.path is not None and len(self.path) > 1:
            specs.append(tip_path_marker(self.path))
        else:
            deleted.append('planned_tip_path')
        return specs, deleted
