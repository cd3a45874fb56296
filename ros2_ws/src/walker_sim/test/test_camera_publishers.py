"""The cameras' topics: REP 104 messages, rendered only while heard, none without cameras."""

import numpy as np
import pytest

from walker_core.camera import CameraModel
from walker_core.parameter_schema import replace_in_section
from walker_sim.camera_publishers import (
    CameraPublishers, camera_info_msg, image_msg, image_topic, info_topic)


class FakePublisher:
    def __init__(self, topic):
        self.topic = topic
        self.subscribers = 0
        self.sent = []

    def get_subscription_count(self):
        return self.subscribers

    def publish(self, message):
        self.sent.append(message)


class FakeNode:
    """Only what the publishers ask of a node: publishers that count their subscribers."""

    def __init__(self):
        self.publishers = {}

    def create_publisher(self, message_type, topic, qos):
        self.publishers[topic] = FakePublisher(topic)
        return self.publishers[topic]


class FakePlant:
    """Renders a frame per request (what the publishers must not ask for nobody)."""

    def __init__(self, plant):
        self.plant = plant
        self.rendered = []

    def camera_frame(self, gripper):
        self.rendered.append(gripper)
        return self.plant.camera_frame(gripper)


@pytest.fixture
def seeing(params):
    return replace_in_section(params, {'gripper.camera.enabled': True})


def test_a_robot_without_cameras_gets_no_camera_topic(params):
    node = FakeNode()
    cameras = CameraPublishers(node, params, 2.0)
    cameras.publish(None, 0)  # nothing to publish, nothing asked of the plant
    assert node.publishers == {}


def test_frames_are_rendered_only_for_a_subscriber_and_at_their_rate(seeing, sim):
    from walker_sim.core.plant import WalkerPlant

    plant = WalkerPlant(seeing, sim)
    try:
        node, watched = FakeNode(), FakePlant(plant)
        CameraPublishers(node, seeing, 2.0).publish(watched, 0)
        assert set(node.publishers) == {image_topic(g) for g in 'ab'} | {
            info_topic(g) for g in 'ab'}
        assert watched.rendered == []  # nobody listens
        node = FakeNode()
        cameras = CameraPublishers(node, seeing, 2.0)
        node.publishers[image_topic('b')].subscribers = 1
        for stamp_ms in range(0, 1001, 2):  # one plant second of control periods
            cameras.publish(watched, stamp_ms * 1_000_000)
        assert watched.rendered == ['b'] * 3  # at 0, 0.5 and 1.0 s: 2 Hz
        images = node.publishers[image_topic('b')].sent
        infos = node.publishers[info_topic('b')].sent
        assert len(images) == len(infos) == 3
        assert node.publishers[image_topic('a')].sent == []
        assert images[1].header.stamp.sec == 0 and images[1].header.stamp.nanosec == 500_000_000
    finally:
        plant.close()


def test_the_messages_follow_rep_104(seeing, sim):
    from walker_sim.core.wrist_camera import CameraFrame

    model = CameraModel.from_parameters(seeing.gripper.camera)
    pixels = np.arange(model.height * model.width * 3, dtype=np.uint32).astype(np.uint8)
    frame = CameraFrame('a', pixels.reshape(model.height, model.width, 3), 1.5, 0.01, 'n1_1',
                        np.zeros(3))
    image = image_msg(frame, 1_500_000_000)
    assert (image.width, image.height, image.encoding) == (model.width, model.height, 'rgb8')
    assert image.step == 3 * model.width and bytes(image.data) == frame.image.tobytes()
    assert image.header.frame_id == 'camera_a_optical'
    info = camera_info_msg(model, 'a', 1_500_000_000)
    assert info.header.frame_id == 'camera_a_optical' and info.distortion_model == 'plumb_bob'
    assert (info.width, info.height) == (model.width, model.height)
    assert list(info.d) == [0.0] * 5 and list(info.r) == list(np.eye(3).reshape(-1))
    # P maps a point of the optical frame to the pixel the model projects it to
    point = np.array([0.004, -0.003, 0.02])
    projection = np.reshape(info.p, (3, 4)) @ np.append(point, 1.0)
    in_gripper = model.mount[:3, :3] @ point + model.mount[:3, 3]
    np.testing.assert_allclose(projection[:2] / projection[2], model.project(in_gripper)[0],
                               atol=1e-9)
