"""A screw-in's camera frame: its caption and its picture, from a frame made here."""

import dataclasses

import numpy as np
import pytest
from PIL import Image

from walker_core.camera import CameraModel
from walker_core.robot_parameters import load_walker_parameters
from walker_report.core.camera_figure import caption, screw_in_figure, title
from walker_report.core.screw_in_frames import ScrewInFrame

PARAMS = load_walker_parameters()


@pytest.fixture
def model():
    return CameraModel.from_parameters(PARAMS.gripper.camera)


def frame(model, measured, true):
    image = np.full((model.height, model.width, 3), 200, dtype=np.uint8)
    return ScrewInFrame(2, 'n2_2', 'a', 10.5, 10_500_000_000, image,
                        None if measured is None else np.asarray(measured, dtype=float),
                        None if true is None else np.asarray(true, dtype=float))


def test_the_caption_gives_the_measured_and_true_offsets_and_their_distance(model):
    shown = frame(model, [0.0012, -0.0004, -0.03], [0.0009, 0.0, -0.03])
    assert caption(shown) == ('measured offset (x, y) (+1.20, -0.40) mm at the height assumed; '
                              'true (+0.90, +0.00) mm: 0.50 mm apart')
    assert shown.error == pytest.approx(5e-4)
    assert title(shown).startswith('step 2 -> n2_2: camera a')


def test_a_frame_at_a_height_assumed_wrong_is_compared_on_its_line_of_sight(model):
    """The node 3 mm lower than assumed: what the image said is the true hole, seen from higher."""
    centre = model.mount[:3, 3]
    true = np.array([0.0009, 0.0, -0.033])
    measured = centre + (true - centre) * (-0.03 - centre[2]) / (true[2] - centre[2])
    shown = dataclasses.replace(frame(model, measured, true), camera_centre=centre)
    assert np.hypot(*(measured[:2] - true[:2])) > 1e-3  # at the height assumed, far off
    np.testing.assert_allclose(shown.seen, true, atol=1e-12)
    assert shown.error == pytest.approx(0.0, abs=1e-12)
    assert 'at the true face; true (+0.90, +0.00) mm: 0.00 mm apart' in caption(shown)


def test_a_frame_that_did_not_show_the_hole_says_so(model):
    shown = frame(model, None, [0.0009, 0.0, -0.03])
    assert caption(shown) == 'hole not seen in this frame; true (+0.90, +0.00) mm'
    assert np.isnan(shown.error) and shown.numbers()['error'] is None


@pytest.mark.parametrize('measured', [None, [0.0012, -0.0004, -0.03]])
def test_the_picture_is_drawn_over_the_frame(model, tmp_path, measured):
    path = screw_in_figure(tmp_path / 'camera_step_02.png',
                           frame(model, measured, [0.0009, 0.0, -0.03]), model,
                           PARAMS.gripper.insertion_position_tolerance)
    with Image.open(path) as image:
        assert image.format == 'PNG' and image.width >= 800
        colors = image.convert('RGB').getcolors(maxcolors=2**20)
    assert len(colors) > 20
