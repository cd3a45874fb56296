"""The cameras' topics and triggers: REP 104 messages, frames on request, none without cameras.

Streaming (``sim.camera.frame_rate`` above 0) renders while an image is heard; at 0 nothing is
rendered but what a trigger asks for, one frame a call, sent once its exposure latency has
passed.
"""

import numpy as np
import pytest

from walker_core.camera import CameraModel
from walker_core.parameter_schema import replace_in_section
from walker_sim.camera_publishers import (
    CameraPublishers, camera_info_msg, image_msg, image_topic, info_topic, trigger_service)
from walker_sim.core.wrist_camera import CameraFrame

PERIOD_NS = 2_000_000  # [ns] a control period (500 Hz)


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
    """What the cameras ask of a node: publishers that count their subscribers; services."""

    def __init__(self):
        self.publishers = {}
        self.services = {}

    def create_publisher(self, message_type, topic, qos):
        self.publishers[topic] = FakePublisher(topic)
        return self.publishers[topic]

    def create_service(self, service_type, name, callback):
        self.services[name] = (service_type, callback)

    def call(self, name):
        """Call a service as the executor would; return its response."""
        service_type, callback = self.services[name]
        return callback(service_type.Request(), service_type.Response())


class Drawn:
    """A frame rendered at once (what ``expose_camera`` hands back)."""

    def __init__(self, frame):
        self.frame, self.latency, self.discarded = frame, frame.latency, False

    def done(self):
        return True

    def result(self):
        return self.frame


class DrawnPlant:
    """Renders a blank frame per request, ready ``latency`` [s] after it shows (no renderer)."""

    def __init__(self, model, latency):
        self.model, self.latency = model, latency
        self.rendered = []
        self.time = 0.0  # [s]

    def expose_camera(self, gripper):
        self.rendered.append((gripper, self.time))
        image = np.zeros((self.model.height, self.model.width, 3), dtype=np.uint8)
        return Drawn(CameraFrame(gripper, image, self.time, self.latency, 'n1_1', np.zeros(3)))


def run_plant(cameras, plant, stamps):
    """Publish the states of ``stamps`` [ns], the plant's clock following them."""
    for stamp in stamps:
        plant.time = stamp * 1e-9
        cameras.publish(plant, stamp)


class FakePlant:
    """Renders a frame per request (what the publishers must not ask for nobody)."""

    def __init__(self, plant):
        self.plant = plant
        self.rendered = []

    def expose_camera(self, gripper):
        self.rendered.append(gripper)
        return self.plant.expose_camera(gripper)


def settings(sim, frame_rate, sim_time):
    """Return the plant's settings with a camera frame rate [Hz] and a clock mode."""
    return replace_in_section(sim, {'sim.camera.frame_rate': frame_rate, 'sim.clock_mode':
                                    'sim_time' if sim_time else 'real_time'}, 'sim.')


@pytest.fixture
def seeing(params):
    return replace_in_section(params, {'gripper.camera.enabled': True})


def test_a_robot_without_cameras_gets_no_camera_topic(params, sim):
    node = FakeNode()
    cameras = CameraPublishers(node, params, settings(sim, 2.0, True))
    cameras.publish(None, 0)  # nothing to publish, nothing asked of the plant
    assert node.publishers == {} and node.services == {}


def test_streamed_frames_are_rendered_only_for_a_subscriber_and_at_their_rate(seeing, sim):
    from walker_sim.core.plant import WalkerPlant

    plant = WalkerPlant(seeing, sim)
    try:
        node, watched = FakeNode(), FakePlant(plant)
        CameraPublishers(node, seeing, settings(sim, 2.0, True)).publish(watched, 0)
        assert set(node.publishers) == {image_topic(g) for g in 'ab'} | {
            info_topic(g) for g in 'ab'} | {f'camera_{g}/true_hole' for g in 'ab'}
        assert watched.rendered == []  # nobody listens
        node = FakeNode()
        cameras = CameraPublishers(node, seeing, settings(sim, 2.0, True))
        node.publishers[image_topic('b')].subscribers = 1
        for stamp_ms in range(0, 1101, 2):  # 1.1 plant seconds of control periods
            cameras.publish(watched, stamp_ms * 1_000_000)
        assert watched.rendered == ['b'] * 3  # at 0, 0.5 and 1.0 s: 2 Hz
        images = node.publishers[image_topic('b')].sent
        infos = node.publishers[info_topic('b')].sent
        assert len(images) == len(infos) == 3
        assert node.publishers[image_topic('a')].sent == []
        assert images[1].header.stamp.sec == 0 and images[1].header.stamp.nanosec == 500_000_000
    finally:
        plant.close()


@pytest.mark.parametrize('sim_time', [True, False])
@pytest.mark.parametrize('frame_rate', [0.0, 2.0])
def test_a_trigger_renders_one_frame_at_the_next_step_and_sends_it_once_ready(
        seeing, sim, frame_rate, sim_time):
    """One frame a call, of the plant at the next state, stamped then, sent a latency later."""
    model = CameraModel.from_parameters(seeing.gripper.camera)
    node, plant = FakeNode(), DrawnPlant(model, latency=0.009)
    cameras = CameraPublishers(node, seeing, settings(sim, frame_rate, sim_time))
    assert set(node.services) == {trigger_service('a'), trigger_service('b')}
    run_plant(cameras, plant, range(0, 10 * PERIOD_NS, PERIOD_NS))
    plant.rendered.clear()  # what streaming (2 Hz, nobody listening: nothing) did
    response = node.call(trigger_service('b'))
    assert response.success and 'next plant step' in response.message
    images = node.publishers[image_topic('b')].sent
    infos = node.publishers[info_topic('b')].sent
    exposure = 10 * PERIOD_NS
    run_plant(cameras, plant, [exposure, exposure + 4 * PERIOD_NS])
    assert plant.rendered == [('b', exposure * 1e-9)]  # at the next state, once
    assert images == [] and infos == []  # not ready: 9 ms after the exposure
    run_plant(cameras, plant, range(exposure + 5 * PERIOD_NS, exposure + 50 * PERIOD_NS,
                                    PERIOD_NS))
    assert plant.rendered == [('b', exposure * 1e-9)]
    assert len(images) == len(infos) == 1  # at the first state at or after 9 ms: once
    for message in (images[0], infos[0]):
        assert (message.header.stamp.sec, message.header.stamp.nanosec) == (0, exposure)
        assert message.header.frame_id == 'camera_b_optical'
    assert node.publishers[image_topic('a')].sent == []
    # a call per frame: two calls, two frames; one each for both cameras asked at once
    node.call(trigger_service('a'))
    run_plant(cameras, plant, [100 * PERIOD_NS])
    node.call(trigger_service('a'))
    node.call(trigger_service('b'))
    run_plant(cameras, plant, range(101 * PERIOD_NS, 120 * PERIOD_NS, PERIOD_NS))
    assert [gripper for gripper, _ in plant.rendered] == ['b', 'a', 'a', 'b']
    assert len(node.publishers[image_topic('a')].sent) == 2 and len(images) == 2


def test_without_streaming_a_subscriber_gets_no_frame_untriggered(seeing, sim):
    """``sim.camera.frame_rate`` 0: nothing rendered for subscribers, however long they listen."""
    model = CameraModel.from_parameters(seeing.gripper.camera)
    node, plant = FakeNode(), DrawnPlant(model, latency=0.0)
    cameras = CameraPublishers(node, seeing, settings(sim, 0.0, True))
    for gripper in 'ab':
        node.publishers[image_topic(gripper)].subscribers = 1
    run_plant(cameras, plant, range(0, 2_000 * PERIOD_NS, PERIOD_NS))  # 4 s of plant time
    assert plant.rendered == []
    assert all(publisher.sent == [] for publisher in node.publishers.values())


def test_the_messages_follow_rep_104(seeing, sim):
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


def test_each_frame_comes_with_the_true_hole_of_its_instant_in_the_grippers_frame(seeing, sim):
    """``camera_<g>/true_hole``: the simulation's truth beside each image, at its stamp."""
    import dataclasses

    from walker_core.camera import TRUE_HOLE, camera_topic

    mouth = np.array([0.0012, -0.0007, -0.031])

    class TruthPlant(DrawnPlant):
        def expose_camera(self, gripper):
            frame = super().expose_camera(gripper).frame
            return Drawn(dataclasses.replace(frame, mouth_in_gripper=mouth))

    model = CameraModel.from_parameters(seeing.gripper.camera)
    node, plant = FakeNode(), TruthPlant(model, latency=0.0)
    cameras = CameraPublishers(node, seeing, settings(sim, 0.0, True))
    node.call(trigger_service('b'))
    run_plant(cameras, plant, [7 * PERIOD_NS, 8 * PERIOD_NS])
    image, = node.publishers[image_topic('b')].sent
    truth, = node.publishers[camera_topic('b', TRUE_HOLE)].sent
    assert truth.header.stamp == image.header.stamp and truth.header.frame_id == 'gripper_b'
    assert [truth.point.x, truth.point.y, truth.point.z] == mouth.tolist()
    assert node.publishers[camera_topic('a', TRUE_HOLE)].sent == []


class HeldPlant:
    """Exposes blank frames rendered on a worker thread, each render held until let through."""

    def __init__(self, model):
        import threading

        from walker_sim.core.frame_worker import FrameWorker
        from walker_sim.core.wrist_camera import Exposure

        self.model, self.time = model, 0.0
        self.let_through = threading.Event()
        self.worker = FrameWorker(lambda: self)
        self._exposure = Exposure
        self.exposed = []

    def render(self, exposure):
        self.let_through.wait()
        image = np.zeros((self.model.height, self.model.width, 3), dtype=np.uint8)
        return CameraFrame(exposure.gripper, image, exposure.time, exposure.latency,
                           exposure.node, exposure.mouth_in_gripper)

    def close(self):
        pass

    def expose_camera(self, gripper):
        self.exposed.append(self.worker.submit(self._exposure(
            gripper, np.eye(4), self.time, 0.004, 'n1_1', np.zeros(3), None)))
        return self.exposed[-1]


def test_in_sim_time_the_plant_waits_at_the_state_a_frame_is_due_for_its_render(seeing, sim):
    """The render outlasts the frame's latency: the state it is due at sends it all the same."""
    import threading

    model = CameraModel.from_parameters(seeing.gripper.camera)
    node, plant = FakeNode(), HeldPlant(model)
    cameras = CameraPublishers(node, seeing, settings(sim, 0.0, True))
    images = node.publishers[image_topic('a')].sent
    try:
        node.call(trigger_service('a'))
        run_plant(cameras, plant, [0, PERIOD_NS])  # exposed at 0, due at 4 ms
        assert images == []
        releaser = threading.Timer(0.05, plant.let_through.set)  # the render ends meanwhile
        releaser.start()
        run_plant(cameras, plant, [2 * PERIOD_NS])  # due: this state waits for the render
        assert plant.let_through.is_set()
        assert len(images) == 1 and images[0].header.stamp.nanosec == 0
    finally:
        plant.let_through.set()
        plant.worker.close()


def test_in_real_time_the_plant_sends_a_frame_late_rather_than_wait(seeing, sim):
    model = CameraModel.from_parameters(seeing.gripper.camera)
    node, plant = FakeNode(), HeldPlant(model)
    cameras = CameraPublishers(node, seeing, settings(sim, 0.0, False))
    images = node.publishers[image_topic('a')].sent
    try:
        node.call(trigger_service('a'))
        run_plant(cameras, plant, range(0, 40 * PERIOD_NS, PERIOD_NS))  # due at 4 ms
        assert images == []  # never waited for: the render is still held
        plant.let_through.set()
        plant.exposed[0].result()  # the render done
        run_plant(cameras, plant, [40 * PERIOD_NS])
        assert len(images) == 1 and images[0].header.stamp.nanosec == 0  # its exposure
    finally:
        plant.let_through.set()
        plant.worker.close()
