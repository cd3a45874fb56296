"""Headless images of the walker on the truss."""

import numpy as np
import pytest

from walker_sim.core.render import Camera, TrussScene, render_plant, save_png
from walker_sim.render_walker import main


def test_the_plant_renders_to_an_rgb_image(make_plant):
    image = render_plant(make_plant(), width=320, height=200)
    assert image.shape == (200, 320, 3) and image.dtype == np.uint8
    assert image.std() > 10  # not a blank frame


def test_the_robot_is_in_the_picture(make_plant, params):
    """Folding the robot changes the pixels around it: it is drawn, and where it stands."""
    plant = make_plant()
    state = plant.state()
    middle = 0.5 * (state.poses['a'].position + state.poses['b'].position)
    camera = Camera(target=(middle[0], middle[1], 0.3), distance=1.8)
    with TrussScene(params) as scene:
        pose = state.poses['a']
        scene.pose_robot(state.position, pose.position, pose.orientation)
        standing = scene.render(camera, 240, 160)
        folded = state.position + np.array([0.0, -0.6, 0.9, 0.0, 0.0])
        scene.pose_robot(folded, pose.position, pose.orientation)
        other = scene.render(camera, 240, 160)
    changed = np.any(standing != other, axis=2)
    assert changed.mean() > 0.01


def test_without_shadows_the_same_scene_is_drawn_only_lighter_where_they_fell(make_plant,
                                                                            params):
    state = make_plant().state()
    pose = state.poses['a']
    with TrussScene(params) as scene:
        scene.pose_robot(state.position, pose.position, pose.orientation)
        shaded = scene.render(None, 240, 160).astype(int).sum(axis=2)
        plain = scene.render(None, 240, 160, shadow=False).astype(int).sum(axis=2)
    assert np.any(plain > shaded + 3)  # the shadows are gone ...
    assert not np.any(plain < shaded - 3)  # ... and nothing else changed


def test_tiny_images_are_refused(params):
    with TrussScene(params) as scene, pytest.raises(ValueError, match='at least 16x16'):
        scene.render(width=8, height=8)


def test_png_files_are_written(tmp_path):
    path = save_png(np.zeros((20, 30, 3), dtype=np.uint8), tmp_path / 'sub' / 'x.png')
    assert path.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'


def test_the_command_line_tool_writes_a_png(tmp_path):
    output = tmp_path / 'walker.png'
    assert main(['--output', str(output), '--width', '160', '--height', '120']) == 0
    assert output.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
