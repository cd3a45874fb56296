"""The packed encoders give the bytes rosbags' serializer gives, for every field."""

import numpy as np
import pytest

from walker_bag.core.bag_reader import walker_typestore
from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_headless.cdr import (
    ControllerStateEncoder, JointStateEncoder, PoseEncoder, TransformsEncoder, clock_cdr)

STORE = walker_typestore()
TYPES = STORE.types
STAMPS = [0, 1, 999_999_999, 1_000_000_000, 123_456_789_012]


def header(stamp, frame=''):
    return TYPES['std_msgs/msg/Header'](
        TYPES['builtin_interfaces/msg/Time'](sec=stamp // 10**9, nanosec=stamp % 10**9), frame)


def serialized(message, type_name):
    return bytes(STORE.serialize_cdr(message, type_name))


@pytest.mark.parametrize('stamp', STAMPS)
def test_clock(stamp):
    message = TYPES['rosgraph_msgs/msg/Clock'](header(stamp).stamp)
    assert clock_cdr(stamp) == serialized(message, 'rosgraph_msgs/msg/Clock')


@pytest.mark.parametrize('stamp', STAMPS)
def test_joint_states(stamp):
    rng = np.random.default_rng(stamp % 97)
    values = rng.normal(size=(3, 5))
    message = TYPES['sensor_msgs/msg/JointState'](header(stamp), list(PHYSICAL_JOINT_NAMES),
                                                  *values)
    encoded = JointStateEncoder(PHYSICAL_JOINT_NAMES).encode(stamp, *(v.tolist()
                                                                      for v in values))
    assert encoded == serialized(message, 'sensor_msgs/msg/JointState')
    assert STORE.deserialize_cdr(encoded, 'sensor_msgs/msg/JointState').name == list(
        PHYSICAL_JOINT_NAMES)


@pytest.mark.parametrize('frame', ['truss', '', 'a_much_longer_frame_name'])
def test_poses(frame):
    position, orientation = [0.1, -2.0, 3e-3], [0.0, 0.6, 0.0, 0.8]
    message = TYPES['geometry_msgs/msg/PoseStamped'](header(1_500_000_000, frame),
                                                     TYPES['geometry_msgs/msg/Pose'](
        TYPES['geometry_msgs/msg/Point'](*position),
        TYPES['geometry_msgs/msg/Quaternion'](*orientation)))
    assert PoseEncoder(frame).encode(1_500_000_000, position, orientation) == serialized(
        message, 'geometry_msgs/msg/PoseStamped')


@pytest.mark.parametrize('joint', PHYSICAL_JOINT_NAMES)
@pytest.mark.parametrize('saturated, stale', [(False, False), (True, False), (False, True)])
def test_controller_states(joint, saturated, stale):
    values = [0.1 * (k + 1) * (-1) ** k for k in range(len(ControllerStateEncoder.FLOATS))]
    message = TYPES['walker_msgs/msg/ControllerState'](
        header=header(2_004_000_000), joint_name=joint, role=4, mode=3,
        **dict(zip(ControllerStateEncoder.FLOATS, values, strict=True)),
        saturated=saturated, stale=stale)
    encoded = ControllerStateEncoder(joint).encode(2_004_000_000, 4, 3, values, saturated,
                                                   stale)
    assert encoded == serialized(message, 'walker_msgs/msg/ControllerState')


@pytest.mark.parametrize('frames', [
    (), (('truss', 'a_gripper'),),
    (('a_gripper', 'a_wrist'), ('a_wrist', 'link_1'), ('link_1_seg_2', 'x'), ('world', 'ab'))])
@pytest.mark.parametrize('stamp', [0, 123_456_789_012])
def test_transforms(frames, stamp):
    rng = np.random.default_rng(len(frames))
    values = rng.normal(size=(len(frames), 7))
    t = TYPES
    message = t['tf2_msgs/msg/TFMessage'](transforms=[
        t['geometry_msgs/msg/TransformStamped'](
            header=header(stamp, parent), child_frame_id=child,
            transform=t['geometry_msgs/msg/Transform'](
                translation=t['geometry_msgs/msg/Vector3'](*row[:3]),
                rotation=t['geometry_msgs/msg/Quaternion'](*row[3:])))
        for (parent, child), row in zip(frames, values.tolist(), strict=True)])
    encoded = TransformsEncoder(frames).encode(stamp, values.ravel().tolist())
    assert encoded == serialized(message, 'tf2_msgs/msg/TFMessage')
