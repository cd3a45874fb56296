"""What the walker's markers draw: the truss, the step's target node, the planned tip path.

Plain data (:class:`MarkerSpec`), converted to ``visualization_msgs/Marker`` by the node. The
truss comes from the parameters (:class:`walker_core.truss.Truss`, ``truss.hole_depth``): its
members join neighbouring nodes, a sphere marks each node and a dark cylinder as deep as the
thread each hole, with the node's name above it. The planned tip path is where the free
gripper's contact point goes along ``planned_trajectory``, by the forward kinematics of the
robot's tree from the base that holds it; the target is the node the step goes to
(``phase.to_node``). Everything is in the truss frame, in m.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence

import numpy as np

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES, other_gripper
from walker_core.truss import Truss
from walker_core.urdf import GRIPPER_LINKS
from walker_viz.core.base_anchor import BaseAnchor
from walker_viz.core.robot_tree import RobotTree

__all__ = ['MarkerSpec', 'POSED_KINDS', 'TRUSS_NAMESPACES', 'truss_markers', 'target_marker',
           'tip_path_marker', 'tip_path', 'MAX_PATH_POINTS']

#: Most points of a drawn tip path: a trajectory of many samples is thinned evenly.
MAX_PATH_POINTS = 200
#: Marker kinds placed by their pose (one point: the centre), not by their points.
POSED_KINDS = ('sphere', 'cylinder', 'text')
#: Marker namespaces of the truss.
TRUSS_NAMESPACES = ('truss_members', 'truss_nodes', 'truss_holes', 'truss_labels')

# Cosmetic sizes [m] and colours (r, g, b, a).
_MEMBER_WIDTH = 0.01
_NODE_DIAMETER = 0.03
_HOLE_DIAMETER = 0.016
_LABEL_HEIGHT = 0.025
_LABEL_LIFT = 0.04
_TARGET_DIAMETER = 0.05
_TARGET_HEIGHT = 0.004
_PATH_WIDTH = 0.006
_MEMBER_COLOR = (0.55, 0.6, 0.65, 1.0)
_NODE_COLOR = (0.35, 0.4, 0.45, 1.0)
_HOLE_COLOR = (0.05, 0.05, 0.05, 1.0)
_LABEL_COLOR = (0.9, 0.9, 0.9, 0.8)
_TARGET_COLOR = (0.1, 0.8, 0.3, 0.8)
_PATH_COLOR = (0.2, 0.5, 1.0, 1.0)


@dataclasses.dataclass(frozen=True)
class MarkerSpec:
    """One marker, as ``visualization_msgs/Marker`` has it.

    Attributes
    ----------
    namespace : str
        ``ns``.
    marker_id : int
        ``id`` within the namespace.
    kind : str
        ``'line_list'``, ``'line_strip'``, ``'sphere_list'``, ``'sphere'`` (an ellipsoid),
        ``'cylinder'`` or ``'text'``.
    points : ndarray, shape (N, 3)
        The points of a list or strip [m]; for a kind of :data:`POSED_KINDS`, one point: its
        centre.
    scale : tuple of 3 float
        Line width in x for lines; diameters for spheres (an ellipsoid's along its own axes);
        diameters and height for a cylinder; the text height in z [m].
    color : tuple of 4 float
        r, g, b, a in [0, 1].
    text : str
        The text of a ``'text'`` marker.
    orientation : tuple of 4 float
        Quaternion ``(x, y, z, w)`` of a posed marker's axes in the truss frame.
    """

    namespace: str
    marker_id: int
    kind: str
    points: np.ndarray
    scale: tuple[float, float, float]
    color: tuple[float, float, float, float]
    text: str = ''
    orientation: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)


def truss_markers(truss: Truss, hole_depth: float) -> list[MarkerSpec]:
    """Members, nodes, holes and labels of the truss."""
    names = truss.node_names
    positions = {name: truss.position(name) for name in names}
    segments = []
    for name in names:
        for neighbour in truss.neighbors(name):
            if name < neighbour:
                segments += [positions[name], positions[neighbour]]
    nodes = np.array([positions[n] for n in names])
    markers = [
        MarkerSpec('truss_members', 0, 'line_list', np.array(segments).reshape(-1, 3),
                   (_MEMBER_WIDTH, 0.0, 0.0), _MEMBER_COLOR),
        MarkerSpec('truss_nodes', 0, 'sphere_list', nodes,
                   (_NODE_DIAMETER,) * 3, _NODE_COLOR),
    ]
    for index, name in enumerate(names):
        hole = positions[name] - [0.0, 0.0, 0.5 * hole_depth]
        markers.append(MarkerSpec('truss_holes', index, 'cylinder', hole[None, :],
                                  (_HOLE_DIAMETER, _HOLE_DIAMETER, hole_depth), _HOLE_COLOR))
        label = positions[name] + [0.0, 0.0, _LABEL_LIFT]
        markers.append(MarkerSpec('truss_labels', index, 'text', label[None, :],
                                  (0.0, 0.0, _LABEL_HEIGHT), _LABEL_COLOR, name))
    return markers


def target_marker(truss: Truss, node: str) -> MarkerSpec:
    """Mark the node a step goes to with a flat disc.

    Raises
    ------
    walker_core.truss.UnknownNodeError
        If ``node`` is not on the truss.
    """
    centre = truss.position(node) + [0.0, 0.0, 0.5 * _TARGET_HEIGHT]
    return MarkerSpec('target', 0, 'cylinder', centre[None, :],
                      (_TARGET_DIAMETER, _TARGET_DIAMETER, _TARGET_HEIGHT), _TARGET_COLOR,
                      node)


def tip_path(tree: RobotTree, anchor: BaseAnchor, joint_names: Sequence[str],
             positions: np.ndarray, max_points: int = MAX_PATH_POINTS) -> np.ndarray:
    """Where the free gripper's contact point goes along a joint trajectory [m], (N, 3).

    Parameters
    ----------
    tree : RobotTree
    anchor : BaseAnchor
        The base that holds the robot while the trajectory runs.
    joint_names : sequence of str
        The trajectory's joint names: the five actuated joints. The tree's other moving
        joints (the links' bends, in a flexible tree) are taken straight: a plan is the
        rigid model's.
    positions : array_like, shape (M, len(joint_names))
        Its joint angles [rad], one row per point.
    max_points : int
        Most points returned: evenly thinned, the first and last kept.

    Raises
    ------
    ValueError
        If an actuated joint is missing from ``joint_names`` or a row is malformed.
    """
    positions = np.asarray(positions, dtype=float)
    if positions.ndim != 2 or positions.shape[1] != len(joint_names):
        raise ValueError(f'trajectory positions of shape {positions.shape} do not match '
                         f'{len(joint_names)} joint names')
    missing = set(PHYSICAL_JOINT_NAMES) - set(joint_names)
    if missing:
        raise ValueError(f'the trajectory has no {", ".join(sorted(missing))}')
    if len(positions) > max_points:
        positions = positions[np.unique(np.linspace(0, len(positions) - 1,
                                                    max_points).round().astype(int))]
    straight = np.zeros(len(positions))
    angles: Mapping[str, np.ndarray] = {
        **{name: straight for name in tree.joint_names if name not in joint_names},
        **{name: positions[:, index] for index, name in enumerate(joint_names)}}
    base_link = GRIPPER_LINKS[anchor.gripper]
    tip_link = GRIPPER_LINKS[other_gripper(anchor.gripper)]
    in_base = np.linalg.inv(tree.links_in_root(base_link, angles)) \
        @ tree.links_in_root(tip_link, angles)
    return (anchor.matrix() @ in_base)[:, :3, 3]


def tip_path_marker(points: np.ndarray) -> MarkerSpec:
    """Draw the planned tip path as a line strip."""
    return MarkerSpec('planned_tip_path', 0, 'line_strip', np.asarray(points, dtype=float),
                      (_PATH_WIDTH, 0.0, 0.0), _PATH_COLOR)
