"""Conversions between walker_viz's core and ROS messages (TF, markers); no node here."""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, TransformStamped
from std_msgs.msg import ColorRGBA
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import Marker, MarkerArray

from walker_viz.core.markers import POSED_KINDS, MarkerSpec
from walker_core.rotations import quaternion_from_matrix, rotation_from_quaternion
from walker_viz.core.robot_tree import WORLD_FRAME, JointTransform

__all__ = ['tf_message', 'marker_array', 'deleted_marker', 'pose_matrix']

_KINDS = {'line_list': Marker.LINE_LIST, 'line_strip': Marker.LINE_STRIP,
          'sphere_list': Marker.SPHERE_LIST, 'sphere': Marker.SPHERE,
          'cylinder': Marker.CYLINDER,
          'text': Marker.TEXT_VIEW_FACING}


def _transform_msg(edge: JointTransform, stamp: Time) -> TransformStamped:
    message = TransformStamped()
    message.header.stamp = stamp
    message.header.frame_id = edge.parent
    message.child_frame_id = edge.child
    t, r = message.transform.translation, message.transform.rotation
    t.x, t.y, t.z = (float(v) for v in edge.matrix[:3, 3])
    r.x, r.y, r.z, r.w = (float(v) for v in quaternion_from_matrix(edge.matrix))
    return message


def pose_matrix(pose) -> np.ndarray:
    """Return the 4x4 matrix [m] of a ``geometry_msgs/Pose``."""
    p, q = pose.position, pose.orientation
    matrix = np.eye(4)
    matrix[:3, :3] = rotation_from_quaternion((q.x, q.y, q.z, q.w))
    matrix[:3, 3] = (p.x, p.y, p.z)
    return matrix


def tf_message(edges: Iterable[JointTransform], stamp: Time) -> TFMessage:
    """``tf2_msgs/TFMessage`` of tree edges, all at ``stamp``."""
    return TFMessage(transforms=[_transform_msg(edge, stamp) for edge in edges])


def _marker_msg(spec: MarkerSpec) -> Marker:
    marker = Marker(ns=spec.namespace, id=spec.marker_id, type=_KINDS[spec.kind],
                    action=Marker.ADD, text=spec.text)
    marker.header.frame_id = WORLD_FRAME
    o = marker.pose.orientation
    o.x, o.y, o.z, o.w = (float(v) for v in spec.orientation)
    marker.scale.x, marker.scale.y, marker.scale.z = (float(v) for v in spec.scale)
    marker.color = ColorRGBA(r=spec.color[0], g=spec.color[1], b=spec.color[2],
                             a=spec.color[3])
    points = np.asarray(spec.points, dtype=float)
    if spec.kind in POSED_KINDS:
        marker.pose.position.x, marker.pose.position.y, marker.pose.position.z = (
            float(v) for v in points[0])
    else:
        marker.points = [Point(x=float(x), y=float(y), z=float(z)) for x, y, z in points]
    return marker


def deleted_marker(namespace: str, marker_id: int = 0) -> Marker:
    """Return a marker that removes ``namespace``/``marker_id`` from the display."""
    marker = Marker(ns=namespace, id=marker_id, action=Marker.DELETE)
    marker.header.frame_id = WORLD_FRAME
    return marker


def marker_array(specs: Iterable[MarkerSpec], deleted: Iterable[str] = ()) -> MarkerArray:
    """``visualization_msgs/MarkerArray`` of marker specs, and deletions of namespaces."""
    return MarkerArray(markers=[*(_marker_msg(s) for s in specs),
                                *(deleted_marker(n) for n in deleted)])
