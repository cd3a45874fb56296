"""The truss map for people: node frames on ``/tf_static``, markers on ``truss_map_markers``.

The supervisor's truss map (:class:`~walker_supervisor.core.truss_map.TrussMap`) is latched as
one static transform ``truss`` -> ``node_<i>_<j>`` per node, the estimate where surveyed, the
prediction elsewhere, and as markers (``visualization_msgs/MarkerArray``: each node's status
and uncertainty ellipsoid, :func:`walker_viz.core.map_markers.truss_map_markers`), both latched
again whenever a survey or a felt height changes the map.
"""

from __future__ import annotations

from geometry_msgs.msg import TransformStamped
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import MarkerArray

from walker_runtime.qos import LATCHED_QOS, TF_STATIC_QOS
from walker_supervisor.core.truss_map import TRUSS_FRAME, TrussMap
from walker_viz.core.map_markers import truss_map_markers
from walker_viz.messages import marker_array

#: The topic of the map's markers (relative: in the walker's namespace).
MAP_MARKERS_TOPIC = 'truss_map_markers'

__all__ = ['MapFrames', 'MAP_MARKERS_TOPIC']


class MapFrames:
    """Latches the map's node frames and markers when it has changed."""

    def __init__(self, node, survey: TrussMap) -> None:
        self._node = node
        self._map = survey
        self._publisher = node.create_publisher(TFMessage, '/tf_static', TF_STATIC_QOS)
        self._markers = node.create_publisher(MarkerArray, MAP_MARKERS_TOPIC, LATCHED_QOS)
        self._version = -1

    def publish_if_changed(self) -> None:
        """Latch the frames and markers again if the map has changed since they were last."""
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
        self._markers.publish(marker_array(truss_map_markers(self._map.estimates())))
