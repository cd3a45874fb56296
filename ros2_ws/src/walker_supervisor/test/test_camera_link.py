"""The supervisor's camera link: a look triggers the camera, its frame goes to the runner.

A fake node stands for rclpy's (its clients, subscriptions and logger), a fake runner records
the frames handed to it: what is tested is the link's own part, which frame answers which
look, and how the image becomes the array the hole finder takes.
"""

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from geometry_msgs.msg import PointStamped
from sensor_msgs.msg import Image
from std_srvs.srv import Trigger

from walker_runtime.qos import IMAGE_QOS, LOOK_IMAGE_QOS
from walker_supervisor.camera_link import CameraLink, image_array
from walker_supervisor.core.commands import HoleSighted, LookRequest, Notice
from walker_supervisor.core.looking import LOOK_WAIT

WIDTH, HEIGHT = 8, 6


class FakeFuture:
    def __init__(self, response):
        self.response = response

    def add_done_callback(self, callback):
        callback(self)

    def result(self):
        return self.response


class FakeClient:
    def __init__(self, name):
        self.srv_name = name
        self.ready = True
        self.calls = 0

    def service_is_ready(self):
        return self.ready

    def call_async(self, request):
        assert isinstance(request, Trigger.Request)
        self.calls += 1
        return FakeFuture(Trigger.Response(success=True, message='at the next plant step'))


class FakeLogger:
    def __init__(self):
        self.warnings = []

    def warning(self, text):
        self.warnings.append(text)


class FakePublisher:
    def __init__(self):
        self.sent = []

    def publish(self, message):
        self.sent.append(message)


class FakeNode:
    """What the link asks of a node: service clients, subscriptions, publishers, a logger."""

    def __init__(self):
        self.clients, self.subscriptions, self.publishers = {}, {}, {}
        self.logger = FakeLogger()

    def create_publisher(self, message_type, topic, qos):
        assert message_type is PointStamped and qos == IMAGE_QOS
        self.publishers[topic] = FakePublisher()
        return self.publishers[topic]

    def create_client(self, service_type, name):
        assert service_type is Trigger
        self.clients[name] = FakeClient(name)
        return self.clients[name]

    def create_subscription(self, message_type, topic, callback, qos):
        assert message_type is Image and qos == LOOK_IMAGE_QOS  # every frame of a look
        self.subscriptions[topic] = callback

    def get_logger(self):
        return self.logger


class FakeRunner:
    def __init__(self):
        self.frames = []

    def frame_seen(self, gripper, image, exposure_time, now):
        self.frames.append((gripper, image, exposure_time, now))
        return [Notice(f'camera of gripper {gripper}: seen', 'info')]


class FakeClocks:
    def __init__(self, now):
        self.time = now

    def now(self):
        return self.time


def image_message(pixels, stamp_ns, encoding='rgb8', padding=0):
    height, width, _ = pixels.shape
    rows = np.zeros((height, 3 * width + padding), dtype=np.uint8)
    rows[:, :3 * width] = pixels.reshape(height, 3 * width)
    message = Image(height=height, width=width, encoding=encoding, step=3 * width + padding)
    message.header.stamp = Time(sec=stamp_ns // 1_000_000_000, nanosec=stamp_ns % 1_000_000_000)
    message.data = rows.tobytes()
    return message


def pixels(seed=0):
    return np.random.default_rng(seed).integers(0, 256, (HEIGHT, WIDTH, 3), dtype=np.uint8)


@pytest.fixture
def link():
    node, runner, clocks, answers = FakeNode(), FakeRunner(), FakeClocks(12.5), []
    camera_link = CameraLink(node, runner, clocks, answers.extend, enabled=True)
    camera_link.node, camera_link.runner, camera_link.clocks = node, runner, clocks
    camera_link.answers = answers
    return camera_link


def test_a_robot_without_cameras_has_neither_trigger_nor_image_subscription():
    node = FakeNode()
    link = CameraLink(node, FakeRunner(), FakeClocks(0.0), [].extend, enabled=False)
    assert node.clients == {} and node.subscriptions == {} and node.publishers == {}
    link.execute(LookRequest('a', 0.0))  # logged, nothing else
    assert len(node.logger.warnings) == 1 and 'no such camera' in node.logger.warnings[0]


def test_the_first_frame_of_the_gripper_exposed_since_the_look_goes_to_the_runner(link):
    node, runner = link.node, link.runner
    assert set(node.clients) == {'camera_a/trigger', 'camera_b/trigger'}
    image_b = node.subscriptions['camera_b/image_raw']
    image_a = node.subscriptions['camera_a/image_raw']
    image_b(image_message(pixels(1), 12_000_000_000))  # no look under way: nobody's frame
    look = LookRequest('b', 12.5)
    assert link.handles(look) and not link.handles(Notice('x', 'info'))
    link.execute(look)
    assert node.clients['camera_b/trigger'].calls == 1
    assert node.clients['camera_a/trigger'].calls == 0
    image_b(image_message(pixels(2), 12_498_000_000))  # exposed before the look
    image_a(image_message(pixels(3), 12_502_000_000))  # the other camera
    assert runner.frames == []
    link.clocks.time = 12.6
    expected = pixels(4)
    image_b(image_message(expected, 12_502_000_000, padding=2))
    (gripper, image, exposure, now), = runner.frames
    assert (gripper, now) == ('b', 12.6)
    assert exposure == pytest.approx(12.502, abs=1e-9)
    assert image.shape == (HEIGHT, WIDTH, 3) and image.dtype == np.uint8
    np.testing.assert_array_equal(image, expected)
    assert link.answers == [Notice('camera of gripper b: seen', 'info')]  # carried out
    image_b(image_message(pixels(5), 12_504_000_000))  # one frame a look
    assert len(runner.frames) == 1 and node.logger.warnings == []


def test_a_frame_exposed_at_the_instant_of_the_look_answers_it(link):
    link.clocks.time = 3.2
    link.execute(LookRequest('a', 3.2))
    link.node.subscriptions['camera_a/image_raw'](image_message(pixels(), 3_200_000_000))
    assert [(g, e) for g, _, e, _ in link.runner.frames] == [('a', pytest.approx(3.2))]


def test_frames_slower_than_a_looks_requests_answer_each_request_in_turn(link):
    """A frame takes longer than ``frame_interval``: the next request comes before it."""
    image_a = link.node.subscriptions['camera_a/image_raw']
    link.execute(LookRequest('a', 3.0))
    link.execute(LookRequest('a', 3.17))  # before the first frame is back
    link.clocks.time = 3.2
    image_a(image_message(pixels(1), 3_010_000_000))  # exposed for the first request
    link.execute(LookRequest('a', 3.34))
    link.clocks.time = 3.4
    image_a(image_message(pixels(2), 3_180_000_000))
    image_a(image_message(pixels(3), 3_181_000_000))  # a second frame of one request: not asked
    link.clocks.time = 3.6
    image_a(image_message(pixels(4), 3_350_000_000))
    assert [e for _, _, e, _ in link.runner.frames] == pytest.approx([3.01, 3.18, 3.35])
    assert link.node.clients['camera_a/trigger'].calls == 3


def test_a_camera_not_discovered_is_logged_and_no_look_waits(link):
    node = link.node
    node.clients['camera_a/trigger'].ready = False
    link.execute(LookRequest('a', 12.5))
    assert node.clients['camera_a/trigger'].calls == 0
    assert 'camera_a/trigger service is not available' in node.logger.warnings[0]
    node.subscriptions['camera_a/image_raw'](image_message(pixels(), 12_600_000_000))
    assert link.runner.frames == []  # the runner goes on blind after LOOK_WAIT


def test_a_frame_after_the_runner_gave_up_is_dropped(link):
    link.execute(LookRequest('a', 12.5))
    link.clocks.time = 12.5 + LOOK_WAIT + 0.1
    link.node.subscriptions['camera_a/image_raw'](image_message(pixels(), 12_600_000_000))
    assert link.runner.frames == []


def test_an_image_not_rgb8_is_refused_with_a_log(link):
    link.execute(LookRequest('b', 12.5))
    link.node.subscriptions['camera_b/image_raw'](
        image_message(pixels(), 12_600_000_000, encoding='bgr8'))
    assert link.runner.frames == []
    assert "'bgr8' is not 'rgb8'" in link.node.logger.warnings[0]


def test_image_array_refuses_a_message_too_short_for_its_rows():
    message = image_message(pixels(), 0)
    message.data = bytes(message.data)[:-1]
    with pytest.raises(ValueError, match='rows of'):
        image_array(message)


def test_the_hole_a_frame_showed_is_published_in_the_grippers_frame_at_its_stamp(link):
    """``camera_<g>/hole``: the supervisor's measurement, beside the plant's truth."""
    point = np.array([0.0011, -0.0004, -0.0302])
    sighted = HoleSighted('b', 12.502, point)
    assert link.handles(sighted)
    link.execute(sighted)
    message, = link.node.publishers['camera_b/hole'].sent
    assert (message.header.stamp.sec, message.header.stamp.nanosec) == (12, 502_000_000)
    assert message.header.frame_id == 'gripper_b'
    assert [message.point.x, message.point.y, message.point.z] == point.tolist()
    assert link.node.publishers['camera_a/hole'].sent == []
