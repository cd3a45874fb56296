"""What walkerctl shows: the walker's state as text, and where a free gripper's hole is.

Plain data in, text out: the client (:mod:`walker_teleop.client`) fills a :class:`StatusView`
from the latched ``phase``, ``control_mode`` and ``gripper_states``, the newest ``joint_states``
and the grippers' poses (``gripper_a_pose``, ``gripper_b_pose``, truss frame).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from walker_core.gripper_state import GripperState
from walker_core.progress import PHASE_NAMES, name_of
from walker_core.rotations import rotation_from_quaternion
from walker_core.text import millimetres
from walker_core.truss import Truss

__all__ = ['PHASE_NAMES', 'MODE_NAMES', 'GRIPPER_STATE_NAMES', 'GripperView', 'StatusView',
           'rotation_from_quaternion', 'hole_offset', 'format_status', 'name_of']

#: Names of the ``walker_msgs/ControlMode`` constants, by value.
MODE_NAMES = ('OFF', 'HOLD', 'COARSE', 'FINE')
#: The gripper states, by their ``walker_msgs/GripperState`` constant.
GRIPPER_STATE_NAMES = tuple(GripperState)


@dataclasses.dataclass(frozen=True)
class GripperView:
    """One gripper as the graph reports it.

    Attributes
    ----------
    name : str
        ``'a'`` or ``'b'``.
    state : str
        One of :data:`GRIPPER_STATE_NAMES`, or ``'unknown (<code>)'``.
    node : str
        Node it is attached to, screwing into or jammed at (``''`` when free).
    position : ndarray, shape (3,), or None
        Its contact point [m] in the truss frame (None when no pose was received).
    orientation : ndarray, shape (4,), or None
        Its frame's orientation in the truss frame, quaternion ``(x, y, z, w)``.
    """

    name: str
    state: str
    node: str = ''
    position: np.ndarray | None = None
    orientation: np.ndarray | None = None


@dataclasses.dataclass(frozen=True)
class StatusView:
    """The walker's state as ``walkerctl status`` prints it.

    Attributes
    ----------
    namespace : str
        The robot's namespace.
    phase : str or None
        Step phase (:data:`PHASE_NAMES`), None when no ``phase`` was received.
    reason : str
        Why the phase was entered (SAFE_HOLD: the fault or the operator's hold).
    base_gripper : str
        The supervisor's base gripper.
    step : str
        The step under way (``'step 1/3: n2_1 -> n0_1'``), ``''`` when none.
    mode : str or None
        The controllers' mode (:data:`MODE_NAMES`), None when no ``control_mode`` was received.
    mode_base : str
        The base gripper the controllers count their roles from.
    grippers : tuple of GripperView
        Both grippers (empty when no ``gripper_states`` was received).
    joints : tuple of (str, float), or None
        Joint names and angles [rad], None when no ``joint_states`` was received.
    """

    namespace: str
    phase: str | None
    reason: str = ''
    base_gripper: str = ''
    step: str = ''
    mode: str | None = None
    mode_base: str = ''
    grippers: tuple[GripperView, ...] = ()
    joints: tuple[tuple[str, float], ...] | None = None


def hole_offset(position: Sequence[float], orientation: Sequence[float],
                hole: Sequence[float]) -> np.ndarray:
    """Where a hole's mouth is [m] in a gripper's own frame.

    With the gripper vertical this is the ``jog_tip`` displacement that brings its contact point
    to the hole: the frame of ``walker_msgs/srv/JogTip`` is the gripper's frame.

    Parameters
    ----------
    position : sequence of 3 float
        The gripper's contact point [m] in the truss frame.
    orientation : sequence of 4 float
        The gripper frame's orientation in the truss frame, quaternion ``(x, y, z, w)``.
    hole : sequence of 3 float
        The hole's mouth [m] in the truss frame.
    """
    rotation = rotation_from_quaternion(orientation)
    return rotation.T @ (np.asarray(hole, dtype=float) - np.asarray(position, dtype=float))


def _gripper_line(gripper: GripperView, truss: Truss | None) -> str:
    text = f'{gripper.state}'
    if gripper.node:
        text += f' at {gripper.node}'
    if gripper.state in (GripperState.FREE, GripperState.JAMMED) and gripper.position is not None \
            and gripper.orientation is not None and truss is not None:
        node, _ = truss.nearest_node(gripper.position)
        offset = hole_offset(gripper.position, gripper.orientation, truss.position(node))
        axis = rotation_from_quaternion(gripper.orientation)[:, 2]
        tilt = math.degrees(math.acos(min(1.0, max(-1.0, float(axis[2])))))
        mm = millimetres(offset, signed=True)
        text += (f'; the hole of {node} is at ({mm}) mm in its frame; tilted {tilt:.1f} deg '
                 f'from vertical')
    return text


def format_status(view: StatusView, truss: Truss | None = None) -> str:
    """Write the text of ``walkerctl status``.

    Parameters
    ----------
    view : StatusView
        What the graph reported.
    truss : Truss, optional
        The truss layout, to say where a free gripper's nearest hole is.
    """
    lines = [f'walker at {view.namespace}']
    if view.phase is None:
        lines.append('phase        (no phase received: is the supervisor running?)')
    else:
        text = f'{view.phase}, base gripper {view.base_gripper or "?"}'
        if view.step:
            text += f', {view.step}'
        if view.reason:
            text += f' ({view.reason})'
        lines.append(f'phase        {text}')
    if view.mode is None:
        lines.append('controllers  HOLD (no mode commanded yet)')
    else:
        lines.append(f'controllers  {view.mode}, roles from gripper {view.mode_base or "?"}')
    if not view.grippers:
        lines.append('grippers     (no gripper_states received: is the plant running?)')
    for gripper in view.grippers:
        lines.append(f'gripper {gripper.name:<4} {_gripper_line(gripper, truss)}')
    if view.joints is None:
        lines.append('joints       (no joint_states received: is the plant running?)')
    else:
        for index, (name, angle) in enumerate(view.joints):
            label = 'joints' if index == 0 else ''
            lines.append(f'{label:<12} {name:<14} {angle:+.4f} rad '
                         f'({math.degrees(angle):+7.2f} deg)')
    return '\n'.join(lines)
