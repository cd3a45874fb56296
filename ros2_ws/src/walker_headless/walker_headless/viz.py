"""The viz node's TF and markers in the headless bag, drawn by the same core scene.

In the graph the viz node (``walker_viz viz_node``) hears ``joint_states`` or, with
``viz.flexible``, the plant's ``flexible_joint_states`` (the five joints and the links'
bending joints, at ``sim.pose_rate``), ``gripper_states``, ``control_mode``, ``phase`` and
``planned_trajectory``, and sends ``/tf`` every ``1 / viz.tf_rate`` of the simulated clock
(every flexible state since, or the newest joint state), ``/tf_static`` once and ``markers``
when they change; the supervisor node latches its truss map's markers on
``truss_map_markers`` when the map changes (:meth:`HeadlessViz.truss_map`).
:class:`HeadlessViz` takes the same topics from the loop by calls, lets the same
:class:`~walker_viz.core.scene.WalkerScene` decide, and writes what the node would send
into the bag (:class:`~walker_headless.recording.WalkRecording`), as rosbags messages of the
same types (``walker_viz.messages`` builds the rclpy ones).
"""

from __future__ import annotations

import numpy as np

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_core.rotations import quaternion_from_matrix
from walker_core.urdf import flex_joints
from walker_viz.core.map_markers import truss_map_markers
from walker_viz.core.markers import POSED_KINDS
from walker_viz.core.robot_tree import WORLD_FRAME
from walker_viz.core.scene import WalkerScene

__all__ = ['HeadlessViz']

_MARKER = 'visualization_msgs/msg/Marker'
_KINDS = {'line_list': 'LINE_LIST', 'line_strip': 'LINE_STRIP', 'sphere_list': 'SPHERE_LIST',
          'sphere': 'SPHERE', 'cylinder': 'CYLINDER', 'text': 'TEXT_VIEW_FACING'}


class HeadlessViz:
    """The viz node, composed: the scene fed by calls, its TF and markers into the bag.

    Parameters
    ----------
    configuration : WalkerConfiguration
        The walker's configuration (``walker``, ``viz``).
    recording : WalkRecording
        The bag.
    """

    def __init__(self, configuration, recording) -> None:
        self.scene = WalkerScene(configuration.walker, configuration.viz)
        self.flexible = configuration.viz.flexible
        self._recording = recording
        self._types = recording.types
        bends = [joint.name for joint in
                 flex_joints(configuration.walker.robot.flexibility.segments_per_link)]
        self._names = [*PHYSICAL_JOINT_NAMES, *bends] if self.flexible \
            else list(PHYSICAL_JOINT_NAMES)
        self._period = round(1e9 / configuration.viz.tf_rate)  # [ns]
        self._next = 0  # [ns] the TF timer's next time
        self._states: list[tuple] = []  # (stamp, angles, poses) not yet drawn
        self._tf('/tf_static', self.scene.tree.static_transforms(), 0)
        self._send_markers(0)

    # ------------------------------------------------------------------ inputs
    def joint_state(self, stamp: int, angles: list[float], poses=None) -> None:
        """Take a state the node hears (:attr:`flexible`: the bends follow the five).

        ``poses``: gripper -> its pose [4x4, m] in the truss at ``stamp`` (the plant's
        ``gripper_<x>_pose``), where the node hears them with the state.
        """
        if self.flexible:
            self._states.append((stamp, angles, poses))
        else:
            self._states[:] = [(stamp, angles, poses)]

    def tick(self, stamp: int) -> None:
        """Run the TF timer at ``stamp`` [ns]: send the transforms of the states heard since."""
        if stamp < self._next:
            return
        while self._next <= stamp:
            self._next += self._period
        for state_stamp, angles, poses in self._states:
            self._tf('/tf', self.scene.transforms(self._names, angles, poses), state_stamp)
        self._states.clear()

    def grippers(self, readings: dict[str, tuple[str, str]]) -> None:
        """Take the gripper states: gripper -> (state, node)."""
        self.scene.grippers(readings)

    def base(self, stamp: int, gripper: str) -> None:
        """Take the supervisor's base (``control_mode``)."""
        if self.scene.base(gripper):
            self._send_markers(stamp)

    def phase(self, stamp: int, base_gripper: str, to_node: str) -> None:
        """Take the supervisor's phase: its base and the step's target node."""
        changed = self.scene.base(base_gripper)
        if self.scene.set_target(to_node) or changed:
            self._send_markers(stamp)

    def plan(self, stamp: int, positions) -> None:
        """Take a trajectory on ``planned_trajectory`` (joint positions [rad], physical order)."""
        if self.scene.plan(PHYSICAL_JOINT_NAMES, np.asarray(positions)):
            self._send_markers(stamp)

    # ------------------------------------------------------------------ messages
    def _tf(self, topic: str, edges, stamp: int) -> None:
        """Write the transforms of ``edges`` on ``topic`` (``/tf``, ``/tf_static``), packed."""
        frames, values = [], []
        for edge in edges:
            frames.append((edge.parent, edge.child))
            values += edge.matrix[:3, 3].tolist()
            values += quaternion_from_matrix(edge.matrix).tolist()
        self._recording.transforms(topic, stamp, tuple(frames), values)

    def truss_map(self, stamp: int, estimates) -> None:
        """Take the supervisor's truss map, changed: its markers on ``truss_map_markers``.

        ``estimates``: every node with its estimate (``TrussMap.estimates()``), as the
        supervisor node latches them (``walker_supervisor.map_frames``).
        """
        self._write_markers('truss_map_markers', truss_map_markers(estimates), (), stamp)

    def _send_markers(self, stamp: int) -> None:
        self._write_markers('markers', *self.scene.markers(), stamp)

    def _write_markers(self, topic: str, specs, deleted, stamp: int) -> None:
        """Write a ``MarkerArray`` of ``specs`` and of deletions of ``deleted`` on ``topic``."""
        markers = [self._marker(spec) for spec in specs]
        markers += [self._marker(None, namespace) for namespace in deleted]
        self._recording.serialize(topic, self._types['visualization_msgs/msg/MarkerArray'](
            markers=markers), stamp)

    def _marker(self, spec, deleted: str = ''):
        """Return a ``Marker`` of a spec, or (``spec`` None) one deleting namespace ``deleted``."""
        t = self._types
        kind = t[_MARKER]
        point = t['geometry_msgs/msg/Point']
        position, points, fields = point(x=0.0, y=0.0, z=0.0), [], {}
        orientation = (0.0, 0.0, 0.0, 1.0)
        if spec is not None:
            orientation = spec.orientation
            coordinates = np.asarray(spec.points, dtype=float)
            if spec.kind in POSED_KINDS:
                position = point(*(float(v) for v in coordinates[0]))
            else:
                points = [point(x=float(x), y=float(y), z=float(z)) for x, y, z in coordinates]
            fields = {'ns': spec.namespace, 'id': spec.marker_id,
                      'type': getattr(kind, _KINDS[spec.kind]), 'action': kind.ADD,
                      'scale': t['geometry_msgs/msg/Vector3'](*(float(v) for v in spec.scale)),
                      'color': t['std_msgs/msg/ColorRGBA'](*(float(v) for v in spec.color)),
                      'text': spec.text}
        empty = np.zeros(0, dtype=np.uint8)
        values = {
            'header': self._recording.header(0, WORLD_FRAME), 'ns': deleted, 'id': 0,
            'type': 0, 'action': kind.DELETE,
            'pose': t['geometry_msgs/msg/Pose'](
                position=position,
                orientation=t['geometry_msgs/msg/Quaternion'](*(float(v) for v in orientation))),
            'scale': t['geometry_msgs/msg/Vector3'](x=0.0, y=0.0, z=0.0),
            'color': t['std_msgs/msg/ColorRGBA'](r=0.0, g=0.0, b=0.0, a=0.0),
            'lifetime': t['builtin_interfaces/msg/Duration'](sec=0, nanosec=0),
            'frame_locked': False, 'points': points, 'colors': [], 'texture_resource': '',
            'texture': t['sensor_msgs/msg/CompressedImage'](
                header=self._recording.header(0), format='', data=empty),
            'uv_coordinates': [], 'text': '', 'mesh_resource': '',
            'mesh_file': t['visualization_msgs/msg/MeshFile'](filename='', data=empty),
            'mesh_use_embedded_materials': False}
        values.update(fields)
        return kind(**values)
