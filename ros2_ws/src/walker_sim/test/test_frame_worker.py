"""The cameras' render worker: the blocking render's frames, in order, and none after a reset."""

import threading

import numpy as np
import pytest

from walker_core.parameter_schema import replace_in_section
from walker_sim.core.frame_worker import FrameDiscardedError, FrameWorker
from walker_sim.core.plant import WalkerPlant
from walker_sim.core.wrist_camera import CameraFrame, Exposure


@pytest.fixture
def seeing(params):
    return replace_in_section(params, {'gripper.camera.enabled': True})


def exposure(gripper='a', time=0.0, latency=0.0):
    return Exposure(gripper, np.eye(4), time, latency, 'n1_1', np.zeros(3), None)


def drawn(exposure_):
    """Return a blank frame of an exposure (no renderer)."""
    return CameraFrame(exposure_.gripper, np.zeros((2, 2, 3), np.uint8), exposure_.time,
                       exposure_.latency, exposure_.node, exposure_.mouth_in_gripper)


class HeldRender:
    """Renders blank frames, each only once let through; records the exposures' times."""

    def __init__(self):
        self.let_through = threading.Event()
        self.started = threading.Event()
        self.rendered = []
        self.closed = False

    def render(self, exposure_):
        self.started.set()
        self.let_through.wait()
        self.rendered.append(exposure_.time)
        return drawn(exposure_)

    def close(self):
        self.closed = True


def test_the_worker_renders_the_blocking_frame_of_an_exposure(seeing, sim, one_attached):
    """Exposed, then rendered on the worker while the plant steps: the blocking plant's frame."""
    blocking, stepping = WalkerPlant(seeing, sim), WalkerPlant(seeing, sim)
    try:
        start = one_attached(height=seeing.gripper.approach_height)
        for plant in (blocking, stepping):
            plant.reset(start)
            plant.step(np.zeros(5), 0.01)
        expected = [blocking.camera_frame(g) for g in 'bab']
        pending = [stepping.expose_camera(g) for g in 'bab']
        for _ in range(20):  # the physics runs on while the worker renders
            stepping.step(np.zeros(5), 0.002)
        for frame, handle in zip(expected, pending, strict=True):
            got = handle.result()
            assert got.gripper == frame.gripper and got.node == frame.node
            assert (got.exposure_time, got.latency) == (frame.exposure_time, frame.latency)
            np.testing.assert_array_equal(got.mouth_in_gripper, frame.mouth_in_gripper)
            np.testing.assert_array_equal(got.image, frame.image)
        assert stepping.state().time > blocking.state().time
        assert stepping.render_cpu_time > 0.0  # spent in the render process
    finally:
        blocking.close()
        stepping.close()


def test_frames_come_out_in_the_order_they_were_exposed():
    render = HeldRender()
    worker = FrameWorker(lambda: render)
    try:
        pending = [worker.submit(exposure(time=t)) for t in (0.1, 0.2, 0.3, 0.4)]
        assert not any(p.done() for p in pending)  # the loop is never kept waiting
        render.let_through.set()
        assert [p.result().exposure_time for p in pending] == [0.1, 0.2, 0.3, 0.4]
        assert render.rendered == [0.1, 0.2, 0.3, 0.4]
    finally:
        worker.close()


def test_a_discard_drops_the_frames_rendered_under_way_or_waiting():
    render = HeldRender()
    worker = FrameWorker(lambda: render)
    try:
        under_way = worker.submit(exposure(time=0.1))
        render.started.wait()
        waiting = worker.submit(exposure(time=0.2))
        worker.discard()
        render.let_through.set()
        for pending in (under_way, waiting):
            assert pending.discarded and pending.done()
            with pytest.raises(FrameDiscardedError, match='discarded'):
                pending.result()
        after = worker.submit(exposure(time=0.3))
        assert not after.discarded and after.result().exposure_time == 0.3
        assert 0.2 not in render.rendered  # cancelled before it started
    finally:
        worker.close()


def test_a_closed_worker_takes_no_frame_and_yields_none_pending():
    render = HeldRender()
    worker = FrameWorker(lambda: render)
    pending = worker.submit(exposure())
    render.started.wait()
    render.let_through.set()
    worker.close()
    assert pending.discarded and render.closed
    with pytest.raises(RuntimeError, match='closed'):
        worker.submit(exposure())


def test_a_plant_reset_or_closed_with_a_render_pending_never_yields_its_frame(
        seeing, sim, one_attached):
    plant = WalkerPlant(seeing, sim)
    try:
        start = one_attached(height=seeing.gripper.approach_height)
        plant.reset(start)
        first = plant.camera_frame('b')
        stale = plant.expose_camera('b')
        plant.reset(start)
        assert stale.discarded
        with pytest.raises(FrameDiscardedError):
            stale.result()
        again = plant.camera_frame('b')  # the draws start over with the reset
        assert again.latency == first.latency
        np.testing.assert_array_equal(again.image, first.image)
        pending = plant.expose_camera('a')
    finally:
        plant.close()
    assert pending.discarded
