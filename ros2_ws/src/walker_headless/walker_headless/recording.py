"""The headless walk's bag: the topics, types and QoS a graph's recorder writes, without DDS.

The graph's recorder (``walker_bag recorder_node``) writes what the nodes publish on the
walk's topics (``walker_bringup.graph.RECORDED_TOPICS``); :class:`WalkRecording` writes the
same topics with the same types, offered QoS, definitions and type hashes through the same
writer core (:class:`~walker_bag.core.bag_writer.BagWriter`), from the loop's calls. The
messages of every period are packed by :mod:`walker_headless.cdr`, the others serialized by
rosbags from the installed definitions (:func:`~walker_bag.core.bag_reader.walker_typestore`),
so no message package and no rclpy is loaded. A message's log time and publish time are its
simulated time [ns], as the recorder's receive time under ``use_sim_time`` would be.
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np

from walker_bag.core.bag_metadata import TopicMetadata
from walker_bag.core.bag_reader import walker_typestore
from walker_bag.core.bag_writer import BagWriter
from walker_bag.core.message_definitions import message_definition, type_description_hash
from walker_bag.core.qos import QosProfile
from walker_core.joint_roles import GRIPPERS, PHYSICAL_JOINT_NAMES

from walker_headless.cdr import (
    ControllerStateEncoder, JointStateEncoder, PoseEncoder, TransformsEncoder, clock_cdr)

__all__ = ['WalkRecording', 'TOPICS', 'CHUNK_SIZE']

# What the graph's recorder stores of each publisher's QoS: its reliability and durability as
# discovered (a remote publisher's history and depth are not discovered: unknown, 0)
_SENSOR = QosProfile('best_effort', 'volatile')
_RELIABLE = QosProfile('reliable', 'volatile')
_LATCHED = QosProfile('reliable', 'transient_local')

#: The recorded topics (relative to the namespace, or absolute), their types and the QoS their
#: publishers offer (walker_runtime.qos, docs/architecture.md), as the recorder stores it.
TOPICS = {
    'joint_states': ('sensor_msgs/msg/JointState', _SENSOR),
    'tip_pose': ('geometry_msgs/msg/PoseStamped', _SENSOR),
    'gripper_a_pose': ('geometry_msgs/msg/PoseStamped', _SENSOR),
    'gripper_b_pose': ('geometry_msgs/msg/PoseStamped', _SENSOR),
    'gripper_states': ('walker_msgs/msg/GripperStates', _LATCHED),
    'phase': ('walker_msgs/msg/StepPhase', _LATCHED),
    'phase_history': ('walker_msgs/msg/StepPhase', _LATCHED),
    'goal_rejections': ('walker_msgs/msg/GoalRejection', _LATCHED),
    'step_reports': ('walker_msgs/msg/StepReport', _LATCHED),
    'control_mode': ('walker_msgs/msg/ControlMode', _LATCHED),
    **{f'controllers/{joint}/state': ('walker_msgs/msg/ControllerState', _RELIABLE)
       for joint in PHYSICAL_JOINT_NAMES},
    'planned_trajectory': ('trajectory_msgs/msg/JointTrajectory', _LATCHED),
    'robot_description': ('std_msgs/msg/String', _LATCHED),
    'markers': ('visualization_msgs/msg/MarkerArray', _LATCHED),
    'truss_map_markers': ('visualization_msgs/msg/MarkerArray', _LATCHED),
    '/tf': ('tf2_msgs/msg/TFMessage', _RELIABLE),
    '/tf_static': ('tf2_msgs/msg/TFMessage', _LATCHED),
    '/diagnostics': ('diagnostic_msgs/msg/DiagnosticArray', _RELIABLE),
    '/clock': ('rosgraph_msgs/msg/Clock', _RELIABLE),
}
_TRUSS_FRAME = 'truss'
#: [bytes] The bag's chunk size: larger than the graph recorder's (768 KiB), since every chunk
#: written out also rewrites ``metadata.yaml`` (crash safety), which costs more CPU than the
#: thousands of messages of a chunk; a walk's bag is a few of these. Readers do not care.
CHUNK_SIZE = 8 * 1024 * 1024
_NS_PER_S = 1_000_000_000


@functools.cache
def _typestore():
    """Return the walker's rosbags typestore, one per process.

    A store compiles a serializer per type on first use, which costs more than a walk's
    messages of that type: a campaign records many walks.
    """
    return walker_typestore()


class WalkRecording:
    """A walk's rosbag2 bag (MCAP), written as the graph's recorder writes it.

    Parameters
    ----------
    bag_dir : str or Path
        The bag directory to create (it must not exist).
    namespace : str
        The robot's namespace of the relative topics.

    Raises
    ------
    BagError
        If the bag cannot be created (it exists, or the place is not writable).
    MessageDefinitionError
        If a type's definition is not installed.
    """

    def __init__(self, bag_dir: str | Path, namespace: str = '/walker') -> None:
        self.namespace = namespace
        self._store = _typestore()
        self.types = self._store.types
        self.names: dict[str, str] = {}
        self._topic_types: dict[str, str] = {}
        self.writer = BagWriter(bag_dir, max_chunk_size=CHUNK_SIZE,
                                custom_data={'clock': 'sim_time'})
        try:
            self.add_topics(TOPICS)
        except BaseException:
            self.writer.close()
            raise
        self._joint_states = JointStateEncoder(PHYSICAL_JOINT_NAMES)
        self._pose = PoseEncoder(_TRUSS_FRAME)
        self._controllers = {joint: ControllerStateEncoder(joint)
                             for joint in PHYSICAL_JOINT_NAMES}
        self._transforms: dict[tuple, TransformsEncoder] = {}  # frames -> its encoder
        self._write = self.writer.write

    def add_topics(self, topics: dict[str, tuple[str, QosProfile]]) -> None:
        """Add topics: relative (or absolute) name -> (type, offered QoS), as :data:`TOPICS`.

        Raises
        ------
        MessageDefinitionError
            If a type's definition is not installed.
        """
        for relative, (type_name, qos) in topics.items():
            name = relative if relative.startswith('/') \
                else f'{self.namespace.rstrip("/")}/{relative}'
            self.writer.add_topic(TopicMetadata(name, type_name, (qos,),
                                                type_description_hash(type_name)),
                                  message_definition(type_name))
            self.names[relative], self._topic_types[relative] = name, type_name

    @property
    def path(self) -> Path:
        """The bag directory."""
        return self.writer.path

    def close(self) -> None:
        """Write out everything and close the bag (summary, ``metadata.yaml``)."""
        self.writer.close()

    # ------------------------------------------------------------------ every period
    def clock(self, stamp: int) -> None:
        """``/clock`` at ``stamp`` [ns]."""
        self._write(self.names['/clock'], clock_cdr(stamp), stamp)

    def joint_states(self, stamp: int, positions, velocities, efforts) -> None:
        """``joint_states``: the five joints' angles, speeds and applied torques."""
        self._write(self.names['joint_states'],
                    self._joint_states.encode(stamp, positions, velocities, efforts), stamp)

    def poses(self, stamp: int, state) -> None:
        """``tip_pose``, ``gripper_a_pose`` and ``gripper_b_pose`` of a plant state."""
        encode = self._pose.encode
        tip = state.poses[state.tip]
        self._write(self.names['tip_pose'],
                    encode(stamp, tip.position.tolist(), tip.orientation.tolist()), stamp)
        for gripper in GRIPPERS:
            pose = state.poses[gripper]
            self._write(self.names[f'gripper_{gripper}_pose'],
                        encode(stamp, pose.position.tolist(), pose.orientation.tolist()),
                        stamp)

    def controller_state(self, stamp: int, joint: str, measurement, output,
                         stale: bool) -> None:
        """``controllers/<joint>/state`` of one answer (``ControlOutput`` and measurement)."""
        reference = output.reference
        values = (reference.position, reference.velocity, reference.acceleration,
                  measurement.position, measurement.velocity, measurement.acceleration or 0.0,
                  output.position_error, output.feedforward, output.proportional,
                  output.integral, output.derivative, output.acceleration_feedback,
                  output.friction_compensation, output.effort)
        self._write(self.names[f'controllers/{joint}/state'],
                    self._controllers[joint].encode(stamp, output.role, int(output.mode),
                                                    [float(v) for v in values],
                                                    bool(output.saturated), stale), stamp)

    def transforms(self, relative: str, stamp: int, frames: tuple[tuple[str, str], ...],
                   values: list[float]) -> None:
        """``/tf`` or ``/tf_static`` at ``stamp`` [ns]: transforms between ``frames``.

        ``frames``: ``(parent, child)`` of each transform; ``values``: seven floats of each
        (translation [m], rotation ``(x, y, z, w)``), one after the other.
        """
        encoder = self._transforms.get(frames)
        if encoder is None:
            encoder = self._transforms[frames] = TransformsEncoder(frames)
        self._write(self.names[relative], encoder.encode(stamp, values), stamp)

    # ------------------------------------------------------------------ on change
    def serialize(self, relative: str, message, stamp: int) -> None:
        """Write ``message`` (a rosbags message of its topic's type) on a topic at ``stamp``."""
        type_name = self._topic_types[relative]
        self._write(self.names[relative], bytes(self._store.serialize_cdr(message, type_name)),
                    stamp)

    def header(self, stamp: int, frame: str = ''):
        """Return a ``std_msgs/Header`` stamped ``stamp`` [ns] in ``frame``."""
        sec, nanosec = divmod(int(stamp), _NS_PER_S)
        return self.types['std_msgs/msg/Header'](
            self.types['builtin_interfaces/msg/Time'](sec=sec, nanosec=nanosec), frame)

    def gripper_states(self, stamp: int, state) -> None:
        """``gripper_states`` of a plant state: both grippers and their alignment."""
        t = self.types
        grippers = []
        for gripper in GRIPPERS:
            report = state.grippers[gripper]
            status, alignment = report.status, report.alignment
            grippers.append(t['walker_msgs/msg/GripperState'](
                name=status.name, state=status.mode.code, node=status.node,
                position_error=float(alignment.position_error),
                axis_error=float(alignment.axis_error), message=status.message))
        self.serialize('gripper_states', t['walker_msgs/msg/GripperStates'](
            header=self.header(stamp), grippers=grippers), stamp)

    def control_mode(self, stamp: int, mode: int, base_gripper: str) -> None:
        """``control_mode`` as the supervisor commands it (in its name)."""
        self.serialize('control_mode', self.types['walker_msgs/msg/ControlMode'](
            header=self.header(stamp), mode=mode, base_gripper=base_gripper,
            commander=f'{self.namespace.rstrip("/")}/supervisor'), stamp)

    def phase(self, record) -> None:
        """``phase`` and ``phase_history`` of a :class:`~walker_headless.records.PhaseRecord`."""
        fields = {k: v for k, v in vars(record).items() if k != 'stamp'}
        message = self.types['walker_msgs/msg/StepPhase'](header=self.header(record.stamp),
                                                           **fields)
        data = bytes(self._store.serialize_cdr(message, 'walker_msgs/msg/StepPhase'))
        for relative in ('phase', 'phase_history'):
            self._write(self.names[relative], data, record.stamp)

    def goal_rejection(self, stamp: int, action: str, target_node: str, reason: str) -> None:
        """``goal_rejections``: a goal refused, and why."""
        self.serialize('goal_rejections', self.types['walker_msgs/msg/GoalRejection'](
            header=self.header(stamp), action=action, target_node=target_node,
            reason=reason), stamp)

    def step_report(self, record) -> None:
        """``step_reports`` of a :class:`~walker_headless.records.StepReportRecord`."""
        fields = {k: v for k, v in vars(record).items() if k != 'stamp'}
        fields['phase_durations'] = np.array(fields['phase_durations'], dtype=np.float64)
        self.serialize('step_reports', self.types['walker_msgs/msg/StepReport'](
            header=self.header(record.stamp), **fields), record.stamp)

    def planned_trajectory(self, stamp: int, trajectory, start: int = 0) -> None:
        """``planned_trajectory`` at ``stamp`` [ns]: a plan, ``start`` its time 0 [ns].

        The planner publishes each plan it is asked for (unscheduled: ``start`` 0) and each
        trajectory it begins to stream, stamped with the time its first point applies.
        """
        t = self.types
        points = []
        for k, time in enumerate(trajectory.times):
            total = int(round(float(time) * _NS_PER_S))
            points.append(t['trajectory_msgs/msg/JointTrajectoryPoint'](
                positions=np.array(trajectory.positions[k], dtype=np.float64),
                velocities=np.array(trajectory.velocities[k], dtype=np.float64),
                accelerations=np.array(trajectory.accelerations[k], dtype=np.float64),
                effort=np.zeros(0, dtype=np.float64),
                time_from_start=t['builtin_interfaces/msg/Duration'](
                    sec=total // _NS_PER_S, nanosec=total % _NS_PER_S)))
        self.serialize('planned_trajectory', t['trajectory_msgs/msg/JointTrajectory'](
            header=self.header(start), joint_names=list(PHYSICAL_JOINT_NAMES),
            points=points), stamp)

    def robot_description(self, stamp: int, urdf: str) -> None:
        """``robot_description``: the URDF the plant publishes."""
        self.serialize('robot_description', self.types['std_msgs/msg/String'](data=urdf),
                        stamp)

    def diagnostics(self, stamp: int, name: str, hardware_id: str, level: int, message: str,
                    values: dict) -> None:
        """``/diagnostics`` with one status."""
        t = self.types
        status = t['diagnostic_msgs/msg/DiagnosticStatus'](
            level=level, name=name, message=message, hardware_id=hardware_id,
            values=[t['diagnostic_msgs/msg/KeyValue'](key=str(k), value=str(v))
                    for k, v in values.items()])
        self.serialize('/diagnostics', t['diagnostic_msgs/msg/DiagnosticArray'](
            header=self.header(stamp), status=[status]), stamp)
