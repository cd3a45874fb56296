"""The wrist cameras: rendered only when asked, from the truth: the hole, sun, noise, delay."""

import numpy as np
import pytest

from walker_core.camera import CameraModel
from walker_core.parameter_schema import ParameterError, replace_in_section
from walker_sim.core.camera_truth import MountErrors
from walker_sim.core.plant import PlantError, WalkerPlant
from walker_sim.core.wrist_camera import WristCameras


def with_camera(params, **values):
    updates = {'gripper.camera.enabled': True}
    updates.update({f'gripper.camera.{k}': v for k, v in values.items()})
    return replace_in_section(params, updates)


def rendering(sim, **values):
    return replace_in_section(sim, {f'sim.camera.{k}': v for k, v in values.items()}, 'sim.')


def cameras_over(params, sim, mount_errors=(0.0, 0.0), seed=0):
    """Wrist cameras over the nominal truss, posed directly (no physics)."""
    from walker_core.truss import Truss
    from walker_sim.core.contact import NodeGeometry

    truss = Truss.from_parameters(params)
    mouths = {name: truss.position(name) for name in truss.node_names}
    return WristCameras(CameraModel.from_parameters(params.gripper.camera), sim.camera,
                        MountErrors(*mount_errors, seed), truss, mouths,
                        NodeGeometry.from_parameters(params), seed)


def pose_over(params, node, offset=(0.0, 0.0), height=None):
    """Return a vertical gripper over a node, ``offset`` [m] off its hole, ``height`` up."""
    from walker_core.truss import Truss

    height = params.gripper.approach_height if height is None else height
    pose = np.eye(4)
    pose[:3, 3] = Truss.from_parameters(params).position(node) + [*offset, height]
    return pose


def brightness(image, pixel):
    u, v = (int(round(c)) for c in pixel)
    return float(image[v - 1:v + 2, u - 1:u + 2].mean())


def test_the_shipped_robot_is_blind_and_its_plant_opens_no_renderer(params, make_plant):
    assert not params.gripper.camera.enabled
    plant = make_plant()
    assert plant.cameras is None
    with pytest.raises(PlantError, match='gripper.camera.enabled'):
        plant.camera_frame('b')


@pytest.mark.parametrize('name, value, named', [
    ('principal_point', [1.0], 'principal_point'),
    ('mount_position', [0.0, 0.0], 'mount_position'),
    ('far_clip', 0.005, 'far_clip'),
    ('width', 8, 'width')])
def test_bad_camera_parameters_are_refused_naming_them(params, name, value, named):
    with pytest.raises(ParameterError, match=named):
        with_camera(params, **{name: value})


def test_bad_rendering_parameters_are_refused_naming_them(sim):
    with pytest.raises(ParameterError, match='sun_direction'):
        rendering(sim, sun_direction=[0.0, 0.0, 0.0])
    with pytest.raises(ParameterError, match='pixel_noise'):
        rendering(sim, pixel_noise=-1.0)


def test_a_plant_frame_shows_the_true_node_under_the_gripper(params, sim, make_plant,
                                                             one_attached):
    """The truth a frame carries is where the displaced node really is in the gripper's frame."""
    from walker_sim.core.plant import WalkerPlant as _  # noqa: F401 (the plant under test)

    displaced = replace_in_section(sim, {'sim.imperfections.node_placement': 0.002,
                                         'sim.imperfections.seed': 3}, 'sim.')
    plant = WalkerPlant(with_camera(params), displaced)
    try:
        state = plant.reset(one_attached(height=params.gripper.approach_height))
        frame = plant.camera_frame('b')
        node = sim.start.other_node
        pose = state.poses['b'].matrix()
        truth = pose[:3, :3].T @ (plant.node_position(node) - pose[:3, 3])
        camera = params.gripper.camera
        assert frame.node == node and frame.gripper == 'b'
        assert frame.image.shape == (camera.height, camera.width, 3)
        assert frame.image.dtype == np.uint8
        np.testing.assert_allclose(frame.mouth_in_gripper, truth, atol=1e-9)
        assert frame.mouth_in_gripper[2] == pytest.approx(-params.gripper.approach_height,
                                                          abs=2e-3)
        assert 0.0 <= frame.latency <= sim.camera.exposure_latency
        assert frame.exposure_time == state.time
    finally:
        plant.close()


def test_the_hole_is_drawn_dark_in_the_lit_face(params, sim):
    camera_params = with_camera(params)
    quiet = rendering(sim, pixel_noise=0.0)
    cameras = cameras_over(camera_params, quiet)
    try:
        frame = cameras.frame('b', pose_over(params, 'n2_1', (0.001, -0.002)), 0.0)
        model, chamfer = cameras.model, cameras.geometry.chamfer_radius
        angles = np.linspace(0.0, 2.0 * np.pi, 12, endpoint=False)
        ring = np.column_stack([np.cos(angles), np.sin(angles), np.zeros(12)])
        inside = model.project(frame.mouth_in_gripper + 0.7 * chamfer * ring)
        outside = model.project(frame.mouth_in_gripper + 3.0 * chamfer * ring)
        face = min(brightness(frame.image, pixel) for pixel in outside)
        assert max(brightness(frame.image, pixel) for pixel in inside) < 0.5 * face
    finally:
        cameras.close()


@pytest.mark.parametrize('sun_x', [1.0, -1.0])
def test_the_gripper_casts_a_hard_shadow_away_from_the_sun(params, sim, sun_x):
    """The same flat face, lit on the sun's side of the gripper, dark on the other."""
    quiet = rendering(sim, pixel_noise=0.0, sun_direction=[sun_x, 0.0, 1.0])
    cameras = cameras_over(with_camera(params), quiet)
    try:
        frame = cameras.frame('a', pose_over(params, 'n1_1'), 0.0)
        mouth = frame.mouth_in_gripper
        sunny, shaded = (cameras.model.project(mouth + [sign * 0.012, 0.0, 0.0])[0]
                         for sign in (sun_x, -sun_x))
        assert brightness(frame.image, shaded) < 0.5 * brightness(frame.image, sunny)
    finally:
        cameras.close()


def test_frames_repeat_from_the_seed_and_each_has_its_own_noise(params, sim):
    cameras = cameras_over(with_camera(params), sim)
    pose = pose_over(params, 'n2_1')
    try:
        first, second = (cameras.frame('b', pose, 0.0) for _ in range(2))
        cameras.restart()
        again = cameras.frame('b', pose, 0.0)
        np.testing.assert_array_equal(first.image, again.image)
        assert first.latency == again.latency
        difference = first.image.astype(float) - second.image.astype(float)
        assert difference.std() == pytest.approx(np.sqrt(2.0) * sim.camera.pixel_noise, rel=0.2)
    finally:
        cameras.close()


def test_a_mount_error_moves_the_image_and_is_drawn_from_the_seed(params, sim):
    quiet = rendering(sim, pixel_noise=0.0)
    pose = pose_over(params, 'n2_1')
    images = []
    for errors, seed in (((0.0, 0.0), 0), ((0.001, 0.01), 5), ((0.001, 0.01), 5)):
        cameras = cameras_over(with_camera(params), quiet, errors, seed)
        try:
            images.append(cameras.frame('b', pose, 0.0).image)
        finally:
            cameras.close()
    assert np.abs(images[0].astype(int) - images[1]).mean() > 1.0
    np.testing.assert_array_equal(images[1], images[2])
    nominal = CameraModel.from_parameters(params.gripper.camera).mount
    errors = MountErrors(0.001, 0.01, 5)
    moved = errors.true_mount('b', nominal)
    assert 0.0 < np.linalg.norm(moved[:3, 3] - nominal[:3, 3]) < 0.01
    np.testing.assert_array_equal(MountErrors(0.0, 0.0, 5).true_mount('a', nominal), nominal)
