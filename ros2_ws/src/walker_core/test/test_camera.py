"""The wrist camera's model: a pinhole on a mount aimed at the gripper's axis."""

import math

import numpy as np
import pytest

from walker_core.camera import CameraModel, mount_rpy, mount_transform
from walker_core.robot_parameters import load_walker_parameters

CAMERA = load_walker_parameters().gripper.camera
MODEL = CameraModel.from_parameters(CAMERA)


def test_the_aim_point_is_at_the_principal_point():
    aim = [0.0, 0.0, -CAMERA.aim_distance]
    np.testing.assert_allclose(MODEL.project(aim)[0], CAMERA.principal_point, atol=1e-9)


def test_the_gripper_axis_runs_down_the_middle_column_far_side_up():
    far, near = MODEL.project([[-0.01, 0.0, -CAMERA.aim_distance],
                               [0.01, 0.0, -CAMERA.aim_distance]])
    assert far[0] == pytest.approx(CAMERA.principal_point[0])
    assert near[0] == pytest.approx(CAMERA.principal_point[0])
    assert far[1] < CAMERA.principal_point[1] < near[1]  # the side away from the camera on top


@pytest.mark.parametrize('point', [(0.004, -0.007, -0.03), (-0.012, 0.01, -0.045)])
def test_a_pixel_carried_back_to_its_plane_is_the_point_it_shows(point):
    pixel = MODEL.project(point)[0]
    np.testing.assert_allclose(MODEL.on_plane(pixel, -point[2]), point, atol=1e-12)


def test_a_point_behind_the_camera_has_no_pixel_and_a_plane_above_no_point():
    behind = MODEL.mount[:3, 3] - 0.01 * MODEL.mount[:3, 2]
    assert np.all(np.isnan(MODEL.project(behind)))
    assert MODEL.on_plane(CAMERA.principal_point, -0.5) is None  # 0.5 m above the gripper


def test_the_mount_is_a_rotation_whose_urdf_angles_give_it_back():
    mount = mount_transform(CAMERA.mount_position, CAMERA.aim_distance)
    np.testing.assert_allclose(mount[:3, :3] @ mount[:3, :3].T, np.eye(3), atol=1e-12)
    assert np.linalg.det(mount[:3, :3]) == pytest.approx(1.0)
    roll, pitch, yaw = mount_rpy(mount)

    def about(axis, angle):
        c, s = math.cos(angle), math.sin(angle)
        i, j = [k for k in range(3) if k != axis]
        r = np.eye(3)
        r[i, i], r[i, j], r[j, i], r[j, j] = c, -s, s, c
        return r if axis != 1 else r.T

    np.testing.assert_allclose(about(2, yaw) @ about(1, pitch) @ about(0, roll), mount[:3, :3],
                               atol=1e-12)


def test_the_calibration_projects_as_the_model_does():
    calibration = MODEL.plumb_bob()
    assert calibration.d == [0.0] * 5
    p = np.reshape(calibration.p, (3, 4))
    np.testing.assert_allclose(p[:, :3], np.reshape(calibration.k, (3, 3)))
    assert MODEL.metres_per_pixel(CAMERA.aim_distance) == pytest.approx(
        np.linalg.norm(MODEL.mount[:3, 3] - [0.0, 0.0, -CAMERA.aim_distance]) / MODEL.fx)
