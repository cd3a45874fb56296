"""When a frame goes out: its latency passed and its render done; sim time waits for it."""

import numpy as np
import pytest

from walker_sim.core.frame_delivery import FrameDelivery
from walker_sim.core.wrist_camera import CameraFrame

MS = 1_000_000  # [ns]


class Render:
    """A frame's render, done only when told, or when waited for (``result``)."""

    def __init__(self, gripper='b', latency=0.009, finished=False):
        self.gripper, self.latency = gripper, latency
        self.finished = finished
        self.waited = False
        self.discarded = False

    def done(self):
        return self.finished or self.discarded

    def result(self):
        self.waited = not self.finished
        self.finished = True
        return CameraFrame(self.gripper, np.zeros((2, 2, 3), np.uint8), 0.0, self.latency,
                           'n1_1', np.zeros(3))


@pytest.mark.parametrize('sim_time', [True, False])
def test_a_frame_rendered_in_time_goes_out_at_its_ready_state(sim_time):
    delivery, render = FrameDelivery(wait_for_renders=sim_time), Render(finished=True)
    delivery.add(render, 20 * MS)
    assert delivery.due(28 * MS) == []  # 9 ms after its exposure, not before
    (exposure, frame), = delivery.due(30 * MS)
    assert exposure == 20 * MS and frame.gripper == 'b'
    assert len(delivery) == 0 and delivery.due(40 * MS) == []


def test_in_sim_time_a_frame_due_is_waited_for():
    delivery, render = FrameDelivery(wait_for_renders=True), Render()
    delivery.add(render, 20 * MS)
    assert delivery.due(28 * MS) == [] and not render.waited  # not due: the loop goes on
    assert [exposure for exposure, _ in delivery.due(30 * MS)] == [20 * MS]
    assert render.waited  # at the very state it is due, whatever the render's time


def test_in_real_time_a_frame_goes_out_at_the_first_state_its_render_is_done_by():
    delivery, render = FrameDelivery(wait_for_renders=False), Render()
    delivery.add(render, 20 * MS)
    for stamp in range(30 * MS, 160 * MS, 2 * MS):  # due, the render still under way
        assert delivery.due(stamp) == []
    assert not render.waited and len(delivery) == 1
    render.finished = True
    (exposure, _), = delivery.due(162 * MS)
    assert exposure == 20 * MS  # stamped with its exposure, however late it goes out


@pytest.mark.parametrize('sim_time', [True, False])
def test_frames_due_together_go_out_in_the_order_they_were_exposed(sim_time):
    delivery = FrameDelivery(wait_for_renders=sim_time)
    first, second = Render('a', finished=True), Render('b', latency=0.0, finished=True)
    delivery.add(first, 20 * MS)
    delivery.add(second, 22 * MS)
    assert [f.gripper for _, f in delivery.due(22 * MS)] == ['b']  # ready first
    delivery.add(Render('b', latency=0.0, finished=True), 24 * MS)
    assert [(e, f.gripper) for e, f in delivery.due(40 * MS)] == [(20 * MS, 'a'), (24 * MS, 'b')]


@pytest.mark.parametrize('sim_time', [True, False])
def test_a_discarded_frame_never_goes_out(sim_time):
    delivery, render = FrameDelivery(wait_for_renders=sim_time), Render()
    delivery.add(render, 20 * MS)
    render.discarded = True  # the plant was reset
    assert delivery.due(100 * MS) == [] and len(delivery) == 0
    assert not render.waited


def test_a_clock_stepped_back_does_not_hold_a_rendered_frame_for_ever():
    delivery = FrameDelivery(wait_for_renders=False)
    delivery.add(Render(finished=True), 20 * MS)
    assert [exposure for exposure, _ in delivery.due(10 * MS)] == [20 * MS]
