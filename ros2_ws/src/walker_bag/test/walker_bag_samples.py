"""The walk's message types as the recorder's tests write and read them."""

from __future__ import annotations

import dataclasses

import numpy as np

from walker_bag.core.bag_metadata import TopicMetadata
from walker_bag.core.bag_writer import BagWriter
from walker_bag.core.message_definitions import message_definition, type_description_hash
from walker_bag.core.qos import QosProfile

SENSOR = QosProfile('best_effort', 'volatile')
RELIABLE = QosProfile('reliable', 'volatile')
LATCHED = QosProfile('reliable', 'transient_local')

# (topic, type, offered QoS) of the walk, as docs/architecture.md specifies them.
WALK_TOPICS = (
    ('/walker/joint_states', 'sensor_msgs/msg/JointState', SENSOR),
    ('/walker/phase', 'walker_msgs/msg/StepPhase', LATCHED),
    ('/walker/gripper_states', 'walker_msgs/msg/GripperStates', LATCHED),
    ('/walker/controllers/a_yaw_joint/state', 'walker_msgs/msg/ControllerState', RELIABLE),
    ('/walker/tip_pose', 'geometry_msgs/msg/PoseStamped', SENSOR),
    ('/walker/planned_trajectory', 'trajectory_msgs/msg/JointTrajectory', LATCHED),
)
JOINTS = ['a_yaw_joint', 'a_pitch_joint', 'vertex_joint', 'b_pitch_joint', 'b_yaw_joint']


@dataclasses.dataclass(frozen=True)
class WrittenMessage:
    """A message as written to a test bag: its bytes, times and the index it encodes."""

    topic: str
    type: str
    index: int
    data: bytes
    log_time_ns: int
    publish_time_ns: int


def build_message(typestore, type_name: str, i: int):
    """Message number ``i`` of a type; ``i`` is stored in a field the tests read back."""
    t = typestore.types
    header = t['std_msgs/msg/Header'](t['builtin_interfaces/msg/Time'](sec=i, nanosec=7), 'truss')
    if type_name == 'sensor_msgs/msg/JointState':
        return t[type_name](header, JOINTS, np.full(5, float(i)), np.zeros(5), np.zeros(5))
    if type_name == 'walker_msgs/msg/StepPhase':
        return t[type_name](header=header, phase=2, base_gripper='a', step_index=i,
                            step_count=3, from_node='n0_0', to_node='n1_0',
                            base_node='n1_1', base_heading=0.0, phase_progress=0.5,
                            reason=f'phase {i}')
    if type_name == 'walker_msgs/msg/GripperStates':
        gripper = t['walker_msgs/msg/GripperState']
        return t[type_name](header, [gripper('a', 2, 'n0_0', 0.0, 0.0, ''),
                                     gripper('b', 0, '', float(i), 0.01, '')], 'a')
    if type_name == 'walker_msgs/msg/ControllerState':
        efforts = dict.fromkeys((
            'velocity_setpoint', 'acceleration_setpoint', 'position', 'velocity',
            'acceleration', 'position_error', 'feedforward_effort', 'proportional_effort',
            'integral_effort', 'derivative_effort', 'acceleration_feedback_effort',
            'friction_compensation_effort', 'effort'), 0.0)
        return t[type_name](header=header, joint_name='a_yaw_joint', role=1, mode=2,
                            position_setpoint=float(i), saturated=False, stale=False,
                            **efforts)
    if type_name == 'geometry_msgs/msg/PoseStamped':
        pose = t['geometry_msgs/msg/Pose'](t['geometry_msgs/msg/Point'](float(i), 0.0, 0.0),
                                            t['geometry_msgs/msg/Quaternion'](0.0, 0.0, 0.0, 1.0))
        return t[type_name](header, pose)
    if type_name == 'trajectory_msgs/msg/JointTrajectory':
        point = t['trajectory_msgs/msg/JointTrajectoryPoint'](
            np.full(5, float(i)), np.zeros(0), np.zeros(0), np.zeros(0),
            t['builtin_interfaces/msg/Duration'](1, 0))
        return t[type_name](header, JOINTS, [point])
    raise KeyError(type_name)


def index_of(type_name: str, message) -> int:
    """Return the index ``i`` a message from :func:`build_message` carries (any decoder)."""
    if type_name == 'sensor_msgs/msg/JointState':
        return int(message.position[0])
    if type_name == 'walker_msgs/msg/StepPhase':
        return int(message.step_index)
    if type_name == 'walker_msgs/msg/GripperStates':
        return int(message.grippers[1].position_error)
    if type_name == 'walker_msgs/msg/ControllerState':
        return int(message.position_setpoint)
    if type_name == 'geometry_msgs/msg/PoseStamped':
        return int(message.pose.position.x)
    if type_name == 'trajectory_msgs/msg/JointTrajectory':
        return int(message.points[0].positions[0])
    raise KeyError(type_name)


def add_walk_topics(writer: BagWriter, topics=WALK_TOPICS) -> None:
    for name, type_name, qos in topics:
        writer.add_topic(TopicMetadata(name, type_name, (qos,), type_description_hash(type_name)),
                         message_definition(type_name))


def write_walk(writer: BagWriter, typestore, count: int, start_ns: int = 10**18,
               flush_every: int | None = None) -> list[WrittenMessage]:
    """Write ``count`` messages of every walk topic, interleaved, 1 ms apart; return them."""
    written = []
    for i in range(count):
        for k, (name, type_name, _) in enumerate(WALK_TOPICS):
            log_time = start_ns + (i * len(WALK_TOPICS) + k) * 1_000_000
            data = bytes(typestore.serialize_cdr(build_message(typestore, type_name, i),
                                                 type_name))
            writer.write(name, data, log_time, log_time - 250_000, sequence=i + 1)
            written.append(WrittenMessage(name, type_name, i, data, log_time, log_time - 250_000))
        if flush_every and (i + 1) % flush_every == 0:
            writer.flush()
    return written
