"""A headless walk with the wrist cameras: its bag holds the looks' frames, the report shows them.

Two steps (gripper b to n1_2, then gripper a to n2_2) with the cameras on, recorded. The bag
holds every frame the plant rendered for a look, as the graph's recorder would (the same topics,
types and QoS), each with the plant's truth and the supervisor's measurement of the same stamp;
the walk report shows the last frame before each screw-in, its caption the summary's numbers.
"""

import json
import re

import numpy as np
import pytest
from PIL import Image

from walker_bag.core.bag_reader import BagReader
from walker_bringup.graph import RECORDED_TOPICS
from walker_config.core.configuration import load_configuration
from walker_core.camera import CameraModel
from walker_headless.camera_recording import CAMERA_TOPICS
from walker_headless.recording import WalkRecording
from walker_headless.runner import walk
from walker_report.core.report import ReportOptions, make_report
from walker_sim.core.frame_worker import PendingFrame
from walker_sim.core.plant import WalkerPlant

TARGET = 'n2_2'
NAMESPACE = '/walker'


@pytest.fixture(scope='module')
def cameras():
    return load_configuration(overrides={'gripper.camera.enabled': True})


@pytest.fixture(scope='module')
def walked(cameras, tmp_path_factory):
    """Walk with the cameras, recorded; return the result, the bag and every frame rendered."""
    exposed, rendered = [], []
    expose, render = WalkerPlant.expose_camera, PendingFrame.result

    def keep_exposure(plant, gripper):
        exposed.append(expose(plant, gripper))
        return exposed[-1]

    def keep_frame(pending, timeout=None):
        rendered.append(render(pending, timeout))
        return rendered[-1]

    bag = tmp_path_factory.mktemp('camera_walk') / 'bag'
    recording = WalkRecording(bag, NAMESPACE)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(WalkerPlant, 'expose_camera', keep_exposure)
        patch.setattr(PendingFrame, 'result', keep_frame)
        try:
            result = walk(cameras, TARGET, recording)
        finally:
            recording.close()
    assert result.reached, result.message
    assert len(rendered) == len(exposed), 'every frame exposed was rendered and taken'
    return result, bag, rendered


@pytest.fixture(scope='module')
def report(walked, tmp_path_factory):
    return make_report(walked[1], tmp_path_factory.mktemp('camera_report') / 'report',
                       options=ReportOptions(animation=False))


def _stamp(message):
    return message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec


def _camera_messages(bag):
    with BagReader(bag) as reader:
        topics = {t: k for t, k in reader.topics.items() if '/camera_' in t}
        return topics, list(reader.messages(list(topics)))


def test_the_bag_holds_every_frame_the_plant_rendered_as_the_graph_records_it(walked, cameras):
    result, bag, rendered = walked
    topics, messages = _camera_messages(bag)
    assert {t.removeprefix(f'{NAMESPACE}/') for t in topics} == {
        t for t in RECORDED_TOPICS if t.startswith('camera_')}
    assert all(topics[f'{NAMESPACE}/camera_{g}/{name}'] == kind
               for g in 'ab' for name, kind in CAMERA_TOPICS.items())
    images = [m for m in messages if m.topic.endswith('image_raw')]
    assert len(rendered) == len(images) == 3 * len(result.looks) > 0
    model = CameraModel.from_parameters(cameras.walker.gripper.camera)
    for frame, record in zip(rendered, images, strict=True):
        message = record.message
        assert record.topic == f'{NAMESPACE}/camera_{frame.gripper}/image_raw'
        assert _stamp(message) == round(frame.exposure_time * 1e9)
        assert record.log_time_ns >= _stamp(message)  # sent once ready, as the plant does
        assert (message.encoding, message.height, message.width, message.step) == (
            'rgb8', model.height, model.width, 3 * model.width)
        assert message.header.frame_id == f'camera_{frame.gripper}_optical'
        np.testing.assert_array_equal(
            np.asarray(message.data).reshape(frame.image.shape), frame.image)
    infos = [m.message for m in messages if m.topic.endswith('camera_info')]
    assert len(infos) == len(images)
    np.testing.assert_array_equal(infos[0].k, model.matrix.reshape(-1))
    truths = {(m.topic, _stamp(m.message)): m.message for m in messages
              if m.topic.endswith('true_hole')}
    for frame in rendered:
        truth = truths[f'{NAMESPACE}/camera_{frame.gripper}/true_hole',
                       round(frame.exposure_time * 1e9)]
        assert truth.header.frame_id == f'gripper_{frame.gripper}'
        p = truth.point
        assert [p.x, p.y, p.z] == frame.mouth_in_gripper.tolist()


def test_each_frame_that_showed_the_hole_has_the_supervisors_measurement_beside_it(walked):
    result, bag, _ = walked
    _, messages = _camera_messages(bag)
    holes = {_stamp(m.message): m.message for m in messages if m.topic.endswith('/hole')}
    assert all(look['seen'] for look in result.looks)
    assert len(holes) == 3 * len(result.looks)
    for look in result.looks:
        last = look['last_frame']
        hole = holes[round(last['time'] * 1e9)]
        assert hole.header.frame_id == f'gripper_{look["gripper"]}'
        assert [hole.point.x, hole.point.y] == pytest.approx(last['measured'], abs=1e-12)
        assert hole.point.z < 0.0  # the face below the gripper


def test_the_report_shows_the_last_frame_before_each_screw_in_with_the_summarys_numbers(
        walked, report):
    result, _, _ = walked
    finals = [look for look in result.looks if look['final']]
    assert [look['node'] for look in finals] == list(result.path) == ['n1_2', TARGET]
    numbers = json.loads(report.json.read_text())['screw_in_frames']
    assert len(numbers) == len(result.reports) == len(finals)
    text = report.markdown.read_text()
    for shown, look, step in zip(numbers, finals, result.reports, strict=True):
        last = look['last_frame']
        assert (shown['to_node'], shown['gripper']) == (step.to_node, step.moving_gripper)
        assert shown['to_node'] == look['node']
        assert shown['stamp'] == pytest.approx(last['time'], abs=1e-9)
        assert shown['measured'][:2] == pytest.approx(last['measured'], abs=1e-12)
        assert shown['true'][:2] == pytest.approx(last['true'], abs=1e-12)
        path = report.directory / shown['figure']
        with Image.open(path) as image:
            assert image.format == 'PNG' and image.width >= 800
        assert f']({shown["figure"]})' in text
        caption = (f'measured offset (x, y) ({last["measured"][0] * 1e3:+.2f}, '
                   f'{last["measured"][1] * 1e3:+.2f}) mm at the height assumed')
        assert caption in text
        assert (f'true ({last["true"][0] * 1e3:+.2f}, {last["true"][1] * 1e3:+.2f}) mm: '
                f'{shown["error"] * 1e3:.2f} mm apart') in text
        assert shown['error'] < 2e-4, 'what the frame saw, at the true face, is the true hole'
        heading = re.search(rf'step {shown["step"]} -> (\S+): camera (\w)', text)
        assert heading.groups() == (look['node'], look['gripper'])
    assert '## The wrist camera before each screw-in' in text
