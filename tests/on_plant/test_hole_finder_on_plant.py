"""The hole finder on the plant's own frames: at known offsets, and in the hard cases.

The plant core's wrist cameras render a gripper held over a node at a known offset from its
hole (posed directly, no physics); the finder, which knows only the nominal camera and the
face's height, must give the hole's axis in the gripper's frame within 0.2 mm of the truth the
frame carries, or say why it cannot. The hard cases are the plant's frames under a shadow, with
more noise, with the hole at the image's edge, and edited: an object across the hole, a second
hole-like mark.
"""

import numpy as np
import pytest

from walker_core.camera import CameraModel
from walker_core.parameter_schema import replace_in_section
from walker_core.robot_parameters import load_walker_parameters
from walker_core.truss import Truss
from walker_sim.core.camera_truth import MountErrors
from walker_sim.core.config import load_sim_parameters
from walker_sim.core.contact import NodeGeometry
from walker_sim.core.wrist_camera import WristCameras
from walker_supervisor.core.hole_finder import HoleFinder, Unseen

PARAMS = replace_in_section(load_walker_parameters(), {'gripper.camera.enabled': True})
SIM = load_sim_parameters()
HEIGHT = PARAMS.gripper.approach_height
#: [m] What the visually aligned fine motion needs: a tenth of the 2 mm insertion tolerance.
REQUIRED = 0.2e-3


def cameras(sim=SIM, mount_errors=(0.0, 0.0)):
    truss = Truss.from_parameters(PARAMS)
    mouths = {name: truss.position(name) for name in truss.node_names}
    return WristCameras(CameraModel.from_parameters(PARAMS.gripper.camera), sim.camera,
                        MountErrors(*mount_errors, 7), truss, mouths,
                        NodeGeometry.from_parameters(PARAMS), 7)


def with_rendering(**values):
    return replace_in_section(SIM, {f'sim.camera.{k}': v for k, v in values.items()}, 'sim.')


@pytest.fixture(scope='module')
def finder():
    return HoleFinder(CameraModel.from_parameters(PARAMS.gripper.camera),
                      PARAMS.gripper.insertion_position_tolerance, SIM.camera.pixel_noise)


def frame_over(scene, gripper, node, offset, height=HEIGHT):
    pose = np.eye(4)
    pose[:3, 3] = Truss.from_parameters(PARAMS).position(node) + [*offset, height]
    return scene.frame(gripper, pose, 0.0)


def error_of(measurement, frame):
    assert measurement.found, f'{measurement.reason}: {measurement.detail}'
    return float(np.hypot(*(measurement.offset - frame.mouth_in_gripper[:2])))


def test_rendered_holes_are_found_within_a_fifth_of_a_millimetre(finder):
    """Offsets over the whole coarse-to-fine region, both grippers, several nodes."""
    scene = cameras()
    draws = np.random.default_rng(11).uniform(-0.008, 0.008, (12, 2))
    errors, sigmas = [], []
    try:
        for i, offset in enumerate(draws):
            frame = frame_over(scene, 'ab'[i % 2], ('n1_1', 'n2_1', 'n3_2')[i % 3], offset)
            measurement = finder.find(frame.image, HEIGHT)
            errors.append(error_of(measurement, frame))
            sigmas.append(measurement.sigma)
    finally:
        scene.close()
    assert max(errors) < REQUIRED
    assert max(sigmas) < REQUIRED  # and it knows it is that good


@pytest.mark.parametrize('nearer', [0.016, 0.018])
def test_a_node_far_higher_than_assumed_is_found_on_the_line_of_sight(finder, nearer):
    """A node placed centimetres high: its mouth looks far larger than at the height assumed.

    The finder takes it at the height its size says; the line of sight through what it
    measured passes within a fifth of a millimetre of the true mouth.
    """
    scene = cameras()
    mount = CameraModel.from_parameters(PARAMS.gripper.camera).mount[:3, 3]
    try:
        for i, offset in enumerate(((0.002, -0.002), (-0.003, 0.001))):
            frame = frame_over(scene, 'ab'[i], 'n2_1', offset, HEIGHT - nearer)
            measurement = finder.find(frame.image, HEIGHT)
            assert measurement.found, f'{measurement.reason}: {measurement.detail}'
            assert measurement.height == pytest.approx(HEIGHT - nearer, rel=0.1)
            seen = np.array([*measurement.offset, -measurement.height])
            true = frame.mouth_in_gripper
            along = mount + (seen - mount) * (true[2] - mount[2]) / (seen[2] - mount[2])
            assert np.hypot(*(along[:2] - true[:2])) < REQUIRED
    finally:
        scene.close()


def test_a_hole_in_the_grippers_hard_shadow_is_still_found(finder):
    """The sun behind the camera: the gripper's shadow covers the far side, hole and all."""
    scene = cameras(with_rendering(sun_direction=[1.0, 0.0, 1.0]))
    try:
        frame = frame_over(scene, 'b', 'n2_1', (-0.002, 0.001))
        model = scene.model
        hole = model.project(frame.mouth_in_gripper)[0]
        lit = model.project(frame.mouth_in_gripper + [0.012, 0.0, 0.0])[0]
        grey = frame.image.mean(axis=2)
        assert grey[int(lit[1]), int(lit[0])] > 3.0 * grey[int(hole[1]) + 4, int(hole[0])]
        assert error_of(finder.find(frame.image, HEIGHT), frame) < REQUIRED
    finally:
        scene.close()


def test_a_shadow_edge_across_the_hole_leaves_it_found(finder):
    """A straight hard shadow's edge through the mouth's centre (an edited frame).

    A low sun lights the hole (one within 45 degrees of the gripper's axis leaves the face
    around the hole in the gripper's own shadow at the approach height).
    """
    scene = cameras(with_rendering(sun_direction=[0.0, 1.0, 0.4]))
    try:
        frame = frame_over(scene, 'a', 'n1_1', (0.003, -0.002))
        image = frame.image.astype(float)
        u, _ = scene.model.project(frame.mouth_in_gripper)[0]
        image[:, :int(round(u))] *= 0.25  # the sun gone on the left, ambient light only
        shadowed = np.clip(np.rint(image), 0, 255).astype(np.uint8)
        assert error_of(finder.find(shadowed, HEIGHT), frame) < REQUIRED
    finally:
        scene.close()


def test_a_noisy_sensor_still_finds_the_hole(finder):
    noisy = HoleFinder(finder.model, finder.mouth_radius, 8.0)
    scene = cameras(with_rendering(pixel_noise=8.0))
    try:
        for offset in ((0.004, 0.003), (-0.005, -0.006)):
            frame = frame_over(scene, 'b', 'n2_1', offset)
            assert error_of(noisy.find(frame.image, HEIGHT), frame) < REQUIRED
    finally:
        scene.close()


def offset_seen_at_column(column):
    """[m] The gripper's offset (0, y) that puts the hole's centre on an image column."""
    model = CameraModel.from_parameters(PARAMS.gripper.camera)
    low, high = 0.0, 0.1  # the hole moves to the left as the gripper moves along -y
    for _ in range(50):
        middle = 0.5 * (low + high)
        if model.project([0.0, -middle, -HEIGHT])[0][0] > column:
            low = middle
        else:
            high = middle
    return (0.0, 0.5 * (low + high))


@pytest.mark.parametrize('column', [3.0, -40.0])
def test_a_hole_at_or_past_the_images_edge_is_out_of_view(finder, column):
    """Its centre just inside the image (its outline cut by the edge), or outside."""
    scene = cameras()
    try:
        frame = frame_over(scene, 'a', 'n1_1', offset_seen_at_column(column))
        pixel = scene.model.project(frame.mouth_in_gripper)[0]
        assert pixel[0] == pytest.approx(column, abs=0.5)
        measurement = finder.find(frame.image, HEIGHT)
    finally:
        scene.close()
    assert not measurement.found and measurement.reason == Unseen.OUT_OF_VIEW, measurement.detail
    assert measurement.offset is None and measurement.sigma == np.inf


def test_a_view_past_the_node_finds_no_hole(finder):
    """Far off the node the camera sees space, the gripper and a member: no hole.

    The dark corners of that view may be called out of view or occluded alike.
    """
    scene = cameras()
    try:
        frame = frame_over(scene, 'a', 'n1_1', offset_seen_at_column(-400.0))
        measurement = finder.find(frame.image, HEIGHT)
    finally:
        scene.close()
    assert not measurement.found and measurement.offset is None


def test_an_object_across_the_hole_makes_it_occluded(finder):
    scene = cameras()
    try:
        frame = frame_over(scene, 'b', 'n2_1', (0.001, 0.002))
        u, v = scene.model.project(frame.mouth_in_gripper)[0]
        image = frame.image.copy()
        image[int(v) - 3:int(v) + 4, int(u):int(u) + 60] = 10  # a dark cable over the mouth
        measurement = finder.find(image, HEIGHT)
    finally:
        scene.close()
    assert measurement.reason == Unseen.OCCLUDED, measurement.detail


def test_two_hole_like_marks_are_ambiguous(finder):
    scene = cameras()
    try:
        frame = frame_over(scene, 'a', 'n1_1', (0.0, -0.004))
        u, v = (int(round(c)) for c in scene.model.project(frame.mouth_in_gripper)[0])
        image = frame.image.copy()
        patch = image[v - 12:v + 13, u - 16:u + 17].copy()
        image[v - 12:v + 13, u + 24:u + 57] = patch  # the same mark beside it
        measurement = finder.find(image, HEIGHT)
    finally:
        scene.close()
    assert measurement.reason == Unseen.AMBIGUOUS, measurement.detail


def test_a_miscalibrated_mount_biases_what_the_image_says(finder):
    """The finder knows only the nominal mount: no image reveals the mount's error.

    A mount off by 2 mm and 20 mrad moves the measured hole by about as much (hence the
    campaigns' mount dispersion).
    """
    scene = cameras(mount_errors=(0.002, 0.02))
    try:
        frame = frame_over(scene, 'b', 'n2_1', (0.002, 0.002))
        assert error_of(finder.find(frame.image, HEIGHT), frame) > REQUIRED
    finally:
        scene.close()


def test_an_image_of_another_size_or_a_face_above_is_refused(finder):
    with pytest.raises(ValueError, match='image'):
        finder.find(np.zeros((10, 10, 3), np.uint8), HEIGHT)
    with pytest.raises(ValueError, match='height'):
        finder.find(np.zeros((PARAMS.gripper.camera.height, PARAMS.gripper.camera.width, 3),
                             np.uint8), -0.01)


def test_the_plants_own_frame_at_its_start_measures_its_hole(finder):
    """End to end through the plant: the image of a gripper over a displaced node.

    The free gripper starts at the approach height over the real node; the image says so.
    """
    from walker_sim.core.config import StartConfiguration
    from walker_sim.core.plant import WalkerPlant

    displaced = replace_in_section(SIM, {'sim.imperfections.node_placement': 0.002,
                                         'sim.imperfections.seed': 3}, 'sim.')
    plant = WalkerPlant(PARAMS, displaced)
    try:
        start = displaced.start
        plant.reset(StartConfiguration(base_gripper=start.base_gripper,
                                       base_node=start.base_node, other_node=start.other_node,
                                       other_attached=False, other_height=HEIGHT))
        gripper = 'b' if start.base_gripper == 'a' else 'a'
        frame = plant.camera_frame(gripper)
        assert error_of(finder.find(frame.image, HEIGHT), frame) < REQUIRED
    finally:
        plant.close()
