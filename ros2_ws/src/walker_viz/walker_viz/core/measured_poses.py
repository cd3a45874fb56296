"""The grippers' poses a simulator measures, kept by their stamps for the joint states.

The plant publishes ``gripper_a_pose`` and ``gripper_b_pose`` with ``flexible_joint_states``,
all stamped with the same instant. :class:`MeasuredPoses` keeps the newest of them by stamp, so
the joint state of an instant is drawn with the poses of that instant
(:meth:`walker_viz.core.scene.WalkerScene.transforms`); a state whose poses were not heard (a
real robot, a lost sample) is drawn from the model alone.
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np

from walker_core.joint_roles import validate_gripper

__all__ = ['MeasuredPoses']


class MeasuredPoses:
    """Gripper poses [4x4, m, truss frame] by stamp [ns], the newest ``capacity`` stamps.

    Parameters
    ----------
    capacity : int
        Stamps kept (older ones are dropped first).
    """

    def __init__(self, capacity: int = 256) -> None:
        if capacity < 1:
            raise ValueError(f'capacity must be at least 1, got {capacity}')
        self.capacity = capacity
        self._poses: OrderedDict[int, dict[str, np.ndarray]] = OrderedDict()

    def add(self, gripper: str, stamp: int, pose: np.ndarray) -> None:
        """Keep ``gripper``'s pose at ``stamp`` [ns]; a non-finite pose is ignored.

        Raises
        ------
        ValueError
            ``gripper`` is no gripper.
        """
        validate_gripper(gripper)
        pose = np.asarray(pose, dtype=float)
        if pose.shape != (4, 4) or not np.all(np.isfinite(pose)):
            return
        self._poses.setdefault(int(stamp), {})[gripper] = pose
        self._poses.move_to_end(int(stamp))
        while len(self._poses) > self.capacity:
            self._poses.popitem(last=False)

    def at(self, stamp: int) -> dict[str, np.ndarray]:
        """Return the poses heard at ``stamp`` [ns] (gripper -> pose; empty if none)."""
        return dict(self._poses.get(int(stamp), {}))
