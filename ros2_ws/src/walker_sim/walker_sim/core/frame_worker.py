"""The wrist cameras' render worker: frames rendered on a thread of their own, in order.

A frame costs two software renders (:mod:`walker_sim.core.wrist_camera`), hundreds of control
periods of the plant's loop. The loop's thread only *exposes* a frame (the gripper's pose, the
truth, the frame's draws: cheap) and hands the exposure to :class:`FrameWorker`, whose single
thread renders the exposures one after the other, in the order they were taken. pybullet
releases the GIL while it renders, and the renderer has a client of its own, so the physics
keeps stepping meanwhile. The handle, :class:`PendingFrame`, tells when the render is done and
waits for it on request.

A reset of the plant discards every frame exposed before it (:meth:`FrameWorker.discard`):
their renders are cancelled, or finish unseen, and their handles never yield a frame.
"""

from __future__ import annotations

import concurrent.futures
from collections.abc import Callable

from walker_sim.core.wrist_camera import CameraFrame, Exposure

__all__ = ['FrameDiscardedError', 'FrameWorker', 'PendingFrame']


class FrameDiscardedError(RuntimeError):
    """A frame was asked of a handle whose exposure a reset or a close discarded."""


class _Epoch:
    """The frames submitted since the last discard: live until the next one."""

    def __init__(self) -> None:
        self.live = True
        self.futures: list[concurrent.futures.Future] = []

    def end(self) -> None:
        self.live = False
        for future in self.futures:
            future.cancel()  # those not started; one under way finishes, unseen
        self.futures = []


class PendingFrame:
    """A frame exposed and being rendered (:meth:`FrameWorker.submit`).

    Parameters
    ----------
    exposure : Exposure
    future : concurrent.futures.Future
        The render, yielding the :class:`CameraFrame`.
    epoch : _Epoch
        The worker's frames since its last discard, which this one belongs to.
    """

    def __init__(self, exposure: Exposure, future: concurrent.futures.Future,
                 epoch: _Epoch) -> None:
        self.exposure = exposure
        self._future = future
        self._epoch = epoch

    @property
    def gripper(self) -> str:
        """Whose camera."""
        return self.exposure.gripper

    @property
    def exposure_time(self) -> float:
        """[s] Plant time of the instant the image shows."""
        return self.exposure.time

    @property
    def latency(self) -> float:
        """[s] The frame's exposure latency: it is ready that long after its exposure."""
        return self.exposure.latency

    @property
    def ready_time(self) -> float:
        """[s] Plant time the frame is ready (its render aside)."""
        return self.exposure.ready_time

    @property
    def discarded(self) -> bool:
        """True when a reset or a close discarded the frame: it will never be had."""
        return not self._epoch.live

    def done(self) -> bool:
        """Tell whether the render has finished (or failed, or the frame was discarded)."""
        return self.discarded or self._future.done()

    def result(self, timeout: float | None = None) -> CameraFrame:
        """Return the frame, waiting for its render.

        Parameters
        ----------
        timeout : float, optional
            [s] Wall time to wait at most (None: as long as the render takes).

        Raises
        ------
        FrameDiscardedError
            If a reset or a close discarded the frame.
        TimeoutError
            If the render is not done within ``timeout``.
        """
        if self.discarded:
            raise FrameDiscardedError(
                f'the frame of camera {self.gripper} exposed at t={self.exposure_time:.3f} s '
                'was discarded (the plant was reset or closed)')
        return self._future.result(timeout)


class FrameWorker:
    """One thread rendering exposures, in the order they are submitted.

    Parameters
    ----------
    render : callable
        ``render(exposure) -> CameraFrame`` (:meth:`WristCameras.render`); called on the
        worker's thread only, so whatever it renders with is never used by two threads.

    Notes
    -----
    The thread is started with the first frame: a plant whose cameras are never asked runs
    none.
    """

    def __init__(self, render: Callable[[Exposure], CameraFrame]) -> None:
        self._render = render
        self._executor: concurrent.futures.ThreadPoolExecutor | None = None
        self._epoch = _Epoch()
        self._closed = False

    def submit(self, exposure: Exposure) -> PendingFrame:
        """Queue an exposure's render; return its handle at once.

        Raises
        ------
        RuntimeError
            If the worker was closed.
        """
        if self._closed:
            raise RuntimeError('the frame worker is closed')
        if self._executor is None:
            self._executor = concurrent.futures.ThreadPoolExecutor(
                max_workers=1, thread_name_prefix='wrist_camera_render')
        future = self._executor.submit(self._render, exposure)
        epoch = self._epoch
        epoch.futures = [f for f in epoch.futures if not f.done()] + [future]
        return PendingFrame(exposure, future, epoch)

    def discard(self) -> None:
        """Discard every frame submitted so far (the plant was reset): none will be had.

        Renders not started are cancelled; one under way finishes on the worker's thread, and
        its frame is dropped.
        """
        self._epoch.end()
        self._epoch = _Epoch()

    def close(self) -> None:
        """Discard every frame, wait for a render under way, and stop the thread."""
        self._closed = True
        self.discard()
        if self._executor is not None:
            self._executor.shutdown(wait=True, cancel_futures=True)
            self._executor = None
