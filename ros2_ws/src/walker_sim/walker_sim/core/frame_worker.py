"""The wrist cameras' render worker: frames rendered beside the plant's loop, in order.

A frame costs two software renders (:mod:`walker_sim.core.wrist_camera`), hundreds of control
periods of the plant's loop. The loop's thread only *exposes* a frame (the gripper's pose, the
truth, the frame's draws: cheap) and hands the exposure to :class:`FrameWorker`, whose single
thread has a renderer render the exposures one after the other, in the order they were taken.
The plant's renderer is a process of its own (:class:`~walker_sim.core.render_process.
RenderProcess`: pybullet holds Python's lock while it renders, so a thread could not render
beside the loop); the worker's thread only waits for it, the lock let go. The handle,
:class:`PendingFrame`, tells when the render is done and waits for it on request.

A reset of the plant discards every frame exposed before it (:meth:`FrameWorker.discard`):
their renders are cancelled, or finish unseen, and their handles never yield a frame.
"""

from __future__ import annotations

import concurrent.futures
from collections.abc import Callable
from typing import Protocol

from walker_sim.core.wrist_camera import CameraFrame, Exposure

__all__ = ['FrameDiscardedError', 'FrameWorker', 'PendingFrame', 'Renderer']


class Renderer(Protocol):
    """What renders exposures for the worker (a :class:`RenderProcess`, or a test's)."""

    cpu_time: float  # [s] CPU time its renders took, wherever they ran

    def render(self, exposure: Exposure) -> CameraFrame:
        """Render an exposure (called on the worker's thread only)."""

    def close(self) -> None:
        """Release what the renderer holds."""


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
    """One thread having exposures rendered, in the order they are submitted.

    Parameters
    ----------
    make_renderer : callable
        ``make_renderer() -> Renderer``, called on the worker's thread, once, by :meth:`start`
        or the first frame; the renderer is used by that thread alone.
    """

    def __init__(self, make_renderer: Callable[[], Renderer]) -> None:
        self._make_renderer = make_renderer
        self._renderer: Renderer | None = None  # the worker thread's alone
        self._executor: concurrent.futures.ThreadPoolExecutor | None = None
        self._epoch = _Epoch()
        self._closed = False

    def _thread(self) -> concurrent.futures.ThreadPoolExecutor:
        if self._closed:
            raise RuntimeError('the frame worker is closed')
        if self._executor is None:
            self._executor = concurrent.futures.ThreadPoolExecutor(
                max_workers=1, thread_name_prefix='wrist_camera_render')
        return self._executor

    def _open(self) -> Renderer:
        """Return the renderer, made on its first use (on the worker's thread)."""
        if self._renderer is None:
            self._renderer = self._make_renderer()
        return self._renderer

    def _render(self, exposure: Exposure) -> CameraFrame:
        return self._open().render(exposure)

    def _close_renderer(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    @property
    def cpu_time(self) -> float:
        """[s] CPU time the renders took so far (in the render process: not the caller's)."""
        renderer = self._renderer
        return 0.0 if renderer is None else renderer.cpu_time

    def start(self) -> None:
        """Make the renderer now, in the background, rather than at the first frame."""
        self._thread().submit(self._open)

    def submit(self, exposure: Exposure) -> PendingFrame:
        """Queue an exposure's render; return its handle at once.

        Raises
        ------
        RuntimeError
            If the worker was closed.
        """
        future = self._thread().submit(self._render, exposure)
        epoch = self._epoch
        epoch.futures = [f for f in epoch.futures if not f.done()] + [future]
        return PendingFrame(exposure, future, epoch)

    def discard(self) -> None:
        """Discard every frame submitted so far (the plant was reset): none will be had.

        Renders not started are cancelled; one under way finishes, and its frame is dropped.
        """
        self._epoch.end()
        self._epoch = _Epoch()

    def close(self) -> None:
        """Discard every frame, wait for a render under way, close the renderer and the thread."""
        if self._closed:
            return
        self.discard()
        if self._executor is not None:
            self._executor.submit(self._close_renderer)
            self._executor.shutdown(wait=True)
            self._executor = None
        self._closed = True
