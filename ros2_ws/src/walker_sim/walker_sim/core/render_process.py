"""The wrist cameras' renderer in a process of its own, so that a render never holds the loop.

pybullet holds Python's global interpreter lock for the whole of ``getCameraImage`` (its
extension never lets go of it), so a render on a thread of the plant's process would stop the
plant's loop as surely as a render on the loop itself. :class:`RenderProcess` starts a child
interpreter (``python -m walker_sim.core.render_process``: a fresh one, which copies nothing of
the parent's threads or simulators and runs none of its main script) that builds its own
:class:`~walker_sim.core.wrist_camera.WristCameras` from the same arguments as the plant's,
hence the very same scene, and renders the exposures sent to it one at a time:
:meth:`RenderProcess.render` sends one and waits for its frame, the lock let go while it waits.
The child's frames are the parent's bit for bit: a frame depends on its exposure alone.

The two talk over a socket pair with :mod:`multiprocessing.connection` (pickled messages). The
child ignores Ctrl-C (its parent closes it) and ends when told to, or when its parent's end of
the socket closes (the parent ended, whatever the way). Its errors go to the parent's stderr.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
import weakref
from collections.abc import Callable
from multiprocessing.connection import Connection

from walker_sim.core.wrist_camera import CameraFrame, Exposure, WristCameras

__all__ = ['RenderProcess', 'RenderProcessError', 'serve']

_CLOSE_TIMEOUT = 5.0  # [s] wall time a child gets to finish its render and end when closed


class RenderProcessError(RuntimeError):
    """The render process ended before it answered."""


def serve(connection: Connection) -> None:
    """Build the cameras the parent sends first, then render what it sends until None or EOF.

    Runs in the child. Each exposure is answered ``(True, frame, cpu)``, or ``(False, error,
    cpu)`` when rendering it raised, ``cpu`` the CPU time [s] the render took.
    """
    try:
        make_cameras = connection.recv()
    except EOFError:
        return
    cameras: WristCameras = make_cameras()
    try:
        cameras.prepare()
        while True:
            try:
                exposure = connection.recv()
            except EOFError:  # the parent is gone
                return
            if exposure is None:
                return
            started = time.process_time()
            try:
                reply = (True, cameras.render(exposure))
            except Exception as error:  # handed to the parent, which raises it
                reply = (False, error)
            reply += (time.process_time() - started,)
            try:
                connection.send(reply)
            except OSError:  # the parent is gone
                return
    finally:
        cameras.close()


def _stop(process: subprocess.Popen, connection: Connection) -> None:
    """Tell the child to end, wait for it a while, and end it if it does not."""
    try:
        connection.send(None)
    except OSError:
        pass
    try:
        process.wait(_CLOSE_TIMEOUT)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()
    connection.close()


class RenderProcess:
    """A child process rendering exposures with wrist cameras of its own.

    Parameters
    ----------
    make_cameras : callable
        Picklable, returns the :class:`WristCameras` to render with (the same arguments as
        the plant's, e.g. a :func:`functools.partial` of the class).

    Notes
    -----
    Render from one thread at a time (the plant's render worker). The child is started at
    once and builds its scene while the parent goes on; the first render waits for it. It
    finds the modules on the parent's ``sys.path``.
    """

    def __init__(self, make_cameras: Callable[[], WristCameras]) -> None:
        ours, theirs = socket.socketpair()
        environment = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
        with theirs:
            self._process = subprocess.Popen(
                [sys.executable, '-m', __name__, str(theirs.fileno())],
                pass_fds=(theirs.fileno(),), stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL, env=environment)  # stdout: pybullet's banner
        self._connection = Connection(ours.detach())
        self.cpu_time = 0.0  # [s] the renders' CPU time in the child, so far
        self._stop = weakref.finalize(self, _stop, self._process, self._connection)
        self._connection.send(make_cameras)

    @property
    def pid(self) -> int:
        """The child's process id."""
        return self._process.pid

    def render(self, exposure: Exposure) -> CameraFrame:
        """Render an exposure in the child; wait for its frame.

        Raises
        ------
        RenderProcessError
            If the child ended before it answered.
        """
        try:
            self._connection.send(exposure)
            ok, value, cpu_time = self._connection.recv()
        except (EOFError, OSError) as error:
            raise RenderProcessError(
                "the wrist cameras' render process ended (exit code "
                f'{self._process.poll()})') from error
        self.cpu_time += cpu_time
        if not ok:
            raise value
        return value

    def close(self) -> None:
        """End the child (after the render it is on, if any)."""
        self._stop()


if __name__ == '__main__':
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    serve(Connection(int(sys.argv[1])))
