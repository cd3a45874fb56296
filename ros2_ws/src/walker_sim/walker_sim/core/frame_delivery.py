"""When the plant sends a wrist camera's frame: its latency passed, and its render done.

A frame is exposed at a published state (stamp ``t_e``) and rendered on the cameras' worker
thread (:mod:`walker_sim.core.frame_worker`). It is sent at the first state whose stamp is at
or after its ``ready`` stamp ``t_e + latency`` (the exposure latency drawn with it), and only
once its render is done:

* **sim time** (lock-step, the plant drives ``/clock``): at the state the frame is due, the
  plant waits for its render (sim time stands still meanwhile), so the frame is sent at the
  same state whatever the machine: walks stay deterministic;
* **real time**: the loop never waits: the frame is sent at the first state at or after its
  ``ready`` stamp at which its render is done. Its effective latency is then about the larger
  of its exposure latency and the render's wall time (plus up to one control period); it is
  still stamped with its exposure.

A state stamped before a frame's exposure (the wall clock stepped back) sends the frame once
rendered rather than hold it for ever. A frame the plant discarded (a reset) is dropped.
"""

from __future__ import annotations

from walker_sim.core.frame_worker import PendingFrame
from walker_sim.core.wrist_camera import CameraFrame

__all__ = ['FrameDelivery']

_NS_PER_S = 1_000_000_000


class FrameDelivery:
    """The frames exposed and not yet sent, and which of them go out at a state.

    Parameters
    ----------
    wait_for_renders : bool
        True in sim time: a frame due and not rendered is waited for. False in real time: it
        goes out at the first state its render is done by.
    """

    def __init__(self, wait_for_renders: bool) -> None:
        self.wait_for_renders = wait_for_renders
        self._frames: list[tuple[int, int, PendingFrame]] = []  # (exposure, ready [ns], frame)

    def __len__(self) -> int:
        """Frames exposed and not yet sent (nor dropped)."""
        return len(self._frames)

    def add(self, pending: PendingFrame, stamp: int) -> None:
        """Take a frame exposed at the state stamped ``stamp`` [ns]."""
        self._frames.append((stamp, stamp + round(pending.latency * _NS_PER_S), pending))

    def due(self, stamp: int) -> list[tuple[int, CameraFrame]]:
        """Return the frames to send at the state stamped ``stamp`` [ns], in exposure order.

        Returns
        -------
        list of (int, CameraFrame)
            Each frame with its exposure stamp [ns], the stamp its messages carry. In sim time
            this waits for the renders of the frames due.
        """
        sent, waiting = [], []
        for exposure, ready, pending in self._frames:
            if pending.discarded:
                continue
            due = ready <= stamp or stamp < exposure  # ready, or the plant's clock went back
            if due and (self.wait_for_renders or pending.done()):
                sent.append((exposure, pending.result()))
            else:
                waiting.append((exposure, ready, pending))
        self._frames = waiting
        return sent
