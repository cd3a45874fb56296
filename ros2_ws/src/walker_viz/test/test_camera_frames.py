"""The wrist cameras' optical frames in TF: on a fixed joint at each camera's nominal mount."""

import numpy as np

from walker_core.camera import mount_transform
from walker_core.parameter_schema import replace_in_section
from walker_core.robot_parameters import load_walker_parameters
from walker_core.urdf import description_urdf
from walker_viz.core.robot_tree import RobotTree


def test_a_robot_without_cameras_has_no_camera_frame():
    tree = RobotTree(description_urdf(load_walker_parameters()))
    assert not [link for link in tree.links if link.startswith('camera_')]


def test_each_camera_frame_sits_at_its_mount_on_its_gripper():
    params = replace_in_section(load_walker_parameters(), {'gripper.camera.enabled': True})
    camera = params.gripper.camera
    mount = mount_transform(camera.mount_position, camera.aim_distance)
    static = {(t.parent, t.child): t.matrix
              for t in RobotTree(description_urdf(params)).static_transforms()}
    for gripper in 'ab':
        np.testing.assert_allclose(static[(f'gripper_{gripper}', f'camera_{gripper}_optical')],
                                   mount, atol=1e-8)  # the URDF's 9 digits
    # REP 104: the optical z axis looks down the gripper's axis, toward the truss
    assert mount[2, 2] < -0.5
