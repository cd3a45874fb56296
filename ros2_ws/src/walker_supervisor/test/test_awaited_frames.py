"""Which frame answers which look's request: the oldest it was exposed at or after."""

from walker_supervisor.core.awaited_frames import AwaitedFrames
from walker_supervisor.core.looking import LOOK_WAIT

S = 1_000_000_000  # ns in a second


def test_each_frame_answers_the_oldest_request_it_was_exposed_after():
    frames = AwaitedFrames(['a', 'b'])
    frames.asked('a', 3 * S)
    frames.asked('a', 3 * S + 170_000_000)  # before the first frame is back
    assert not frames.answers('b', 3 * S + 10, 3.2)  # the other gripper's: nobody asked
    assert not frames.answers('a', 3 * S - 1, 3.2)  # exposed before any request
    assert frames.answers('a', 3 * S + 10_000_000, 3.2)
    assert frames.answers('a', 3 * S + 180_000_000, 3.4)
    assert not frames.answers('a', 3 * S + 181_000_000, 3.4)  # every request answered


def test_a_request_older_than_the_looks_wait_is_dropped():
    frames = AwaitedFrames(['a'])
    frames.asked('a', 1 * S)
    frames.asked('a', 4 * S)
    assert not frames.answers('a', 2 * S, 1.0 + LOOK_WAIT + 0.5)  # the first dropped, 2 s < 4 s
    assert frames.answers('a', 4 * S, 4.1)
    assert not frames.answers('c', 4 * S, 4.1)  # a gripper without a camera
