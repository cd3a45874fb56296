"""The render process: the in-process frame of an exposure, bit for bit; it ends when told."""

import functools
import os
import signal

import numpy as np
import pytest

from walker_core.camera import CameraModel
from walker_core.parameter_schema import replace_in_section
from walker_core.truss import Truss
from walker_sim.core.camera_truth import MountErrors
from walker_sim.core.contact import NodeGeometry
from walker_sim.core.render_process import RenderProcess, RenderProcessError
from walker_sim.core.wrist_camera import WristCameras


@pytest.fixture
def make_cameras(params, sim):
    """Cameras over the nominal truss, a mount error and noise drawn: made alike each call."""
    seeing = replace_in_section(params, {'gripper.camera.enabled': True})
    truss = Truss.from_parameters(seeing)
    mouths = {name: truss.position(name) for name in truss.node_names}
    return functools.partial(WristCameras, CameraModel.from_parameters(seeing.gripper.camera),
                             sim.camera, MountErrors(0.002, 0.01, 5), truss, mouths,
                             NodeGeometry.from_parameters(seeing), 5)


def pose_over(cameras, node, offset):
    pose = np.eye(4)
    pose[:3, 3] = cameras.truss.position(node) + [*offset, 0.03]
    return pose


def test_the_process_renders_the_in_process_frame_of_each_exposure(make_cameras):
    here, exposing = make_cameras(), make_cameras()
    renderer = RenderProcess(make_cameras)
    try:
        for gripper, node, offset in (('b', 'n2_1', (0.001, -0.002)), ('a', 'n1_1', (0.0, 0.0)),
                                      ('b', 'n2_2', (-0.003, 0.001))):
            pose = pose_over(here, node, offset)
            expected = here.frame(gripper, pose, 1.0)
            got = renderer.render(exposing.expose(gripper, pose, 1.0))
            assert (got.gripper, got.node, got.latency) == (gripper, node, expected.latency)
            np.testing.assert_array_equal(got.image, expected.image)
            np.testing.assert_array_equal(got.mouth_in_gripper, expected.mouth_in_gripper)
        assert renderer.cpu_time > 0.0  # the child's, counted for whoever reports CPU time
    finally:
        renderer.close()
        here.close()


def test_a_render_error_reaches_the_caller_and_the_process_goes_on(make_cameras):
    cameras = make_cameras()
    renderer = RenderProcess(make_cameras)
    try:
        exposure = cameras.expose('a', pose_over(cameras, 'n1_1', (0.0, 0.0)), 0.0)
        with pytest.raises(ValueError, match='nowhere'):  # the child's error, raised here
            renderer.render(type(exposure)(**{**exposure.__dict__, 'node': 'nowhere'}))
        assert renderer.render(exposure).node == 'n1_1'
    finally:
        renderer.close()


def test_the_process_ends_when_closed_and_a_dead_one_is_reported(make_cameras):
    cameras = make_cameras()
    closed, killed = RenderProcess(make_cameras), RenderProcess(make_cameras)
    exposure = cameras.expose('a', pose_over(cameras, 'n1_1', (0.0, 0.0)), 0.0)
    closed.render(exposure)
    closed.close()
    assert closed._process.poll() == 0  # ended of itself, when told
    os.kill(killed.pid, signal.SIGKILL)
    with pytest.raises(RenderProcessError, match='ended'):
        killed.render(exposure)
    killed.close()
