"""The truss map for people: ``truss`` -> ``node_<i>_<j>`` frames on ``/tf_static``.

The supervisor's truss map (:class:`~walker_supervisor.core.truss_map.TrussMap`) is latched as
one static transform per node, the estimate where surveyed, the prediction elsewhere, and
latched again whenever a survey changes it.
"""

from __future__ import annotations

from geometry_msgs.msg import TransformStamped
from tf2_msgs.msg import TFMessage

from walker_runtime.qos import TF_STATIC_QOS
from walker_supervisor.core.truss_map import TRUSS_FRAME, TrussMap

__all__ = ['MapFrames']


class MapFrames:
    """Latches the map's node frames on ``/tf_static`` when it has changed."""

    def __init__(self, node, survey: TrussMap) -> None:
        self._node = node
        self._map = survey
        self._publisher = node.create_publisher(TFMessage, '/tf_static', TF_STATIC_QOS)
        self._version = -1

    def publish_if_changed(self) -> None:
        """Latch the frames again if the map has changed since they were last latched."""
        if self._map.version == self._version:
            return
        self._version = self._map.version
        stamp = self._node.get_clock().now().to_msg()
        transforms = []
        for name, position, _ in self._map.frames():
            message = TransformStamped()
            message.header.stamp = stamp
            message.header.frame_id = TRUSS_FRAME
            message.child_frame_id = name
            message.transform.translation.x = float(position[0])
            message.transform.translation.y = float(position[1])
            message.transform.translation.z = float(position[2])
            message.transform.rotation.w = 1.0
            transforms.append(message)
        self._publisher.publish(TFMessage(transforms=transforms))
