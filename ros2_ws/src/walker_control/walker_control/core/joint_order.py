"""Where each joint is in a message's name list (ROS-free).

``joint_states`` and ``joint_accelerations`` name their joints; a controller node reads its own
joints, and the five physical joints for the model, by index. The indices are found again
only when a message's names change (as a publisher that reorders its joints would).
"""

from __future__ import annotations

from collections.abc import Sequence

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES

__all__ = ['JointOrder', 'check_joint_names', 'default_node_name']


class JointOrder:
    """The indices of the physical joints and of a node's own joints in received messages.

    Parameters
    ----------
    own_joints : sequence of str
        The joints a controller node controls (physical joint names).

    Attributes
    ----------
    physical : list of int
        Index in the last accepted state of each physical joint, in physical order.
    own : list of int
        Index in the last accepted state of each of ``own_joints``.
    """

    def __init__(self, own_joints: Sequence[str]) -> None:
        self._own_joints = tuple(own_joints)
        self._state_names: tuple[str, ...] = ()
        self._acceleration_names: tuple[str, ...] = ()
        self._acceleration_indices: list[int] = []
        self.physical: list[int] = []
        self.own: list[int] = []

    def check_state(self, names: Sequence[str], positions: int, velocities: int) -> str:
        """Take a state's joint names and its numbers of positions and velocities.

        Returns
        -------
        str
            Why the state cannot be used ('' when it can): a physical joint missing, or not a
            position and a velocity per joint. A refused state leaves the indices as they were.
        """
        names = tuple(names)
        if names != self._state_names:
            missing = [j for j in PHYSICAL_JOINT_NAMES if j not in names]
            if missing:
                return f'joint_states lacks {", ".join(missing)}; state ignored'
            self._state_names = names
            self.physical = [names.index(j) for j in PHYSICAL_JOINT_NAMES]
            self.own = [names.index(j) for j in self._own_joints]
        if positions != len(names) or velocities != len(names):
            return 'joint_states needs a position and a velocity per joint; state ignored'
        return ''

    def acceleration_indices(self, names: Sequence[str]) -> list[int]:
        """Return the index of each own joint in an acceleration message's names (-1: absent)."""
        names = tuple(names)
        if names != self._acceleration_names:
            self._acceleration_names = names
            self._acceleration_indices = [names.index(j) if j in names else -1
                                          for j in self._own_joints]
        return self._acceleration_indices


def default_node_name(argv: list[str]) -> str:
    """Name the node ``controller_<joint>`` from a ``-p joint_name:=...`` argument, if any."""
    for flag, value in zip(argv, argv[1:], strict=False):
        if flag in ('-p', '--param') and value.startswith('joint_name:='):
            joint = value.split(':=', 1)[1]
            if joint in PHYSICAL_JOINT_NAMES:
                return 'controller_' + joint.removesuffix('_joint')
    return 'joint_controller'


def check_joint_names(joints: Sequence[str], parameter: str) -> None:
    """Refuse a controller node's joints unless they are distinct physical joints.

    ``parameter`` is the parameter that named them: ``joint_name`` (one joint) or a list.

    Raises
    ------
    ValueError
        Naming the parameter, its value and the joints expected.
    """
    unknown = [j for j in joints if j not in PHYSICAL_JOINT_NAMES]
    if unknown or not joints or len(set(joints)) != len(joints):
        single = parameter == 'joint_name'
        shown = joints[0] if single and joints else list(joints)
        raise ValueError(
            f'parameter {parameter} = {shown!r} is not '
            + ('a joint of the walker' if single
               else 'a list of distinct joints of the walker')
            + f': expected {"one" if single else "some"} of ' + ', '.join(PHYSICAL_JOINT_NAMES))
