"""The planner's setpoint streaming as a whole: one stream at a time, and the hold after it.

Everything the planner node decides about streams, free of ROS, so that the node and the
headless lock-step loop (``walker_headless``) run the same code: :class:`TrajectoryStreamer`
starts a stream on the newest joint state (refused while one runs, or when the trajectory
does not start where the joints are), sends at each joint state the setpoints due
(:meth:`~walker_planner.core.streaming.SetpointStream.due`), ends the stream at the state one
period before its final setpoint, ends it at once on a cancel or a stop with a setpoint at
rest where its sent setpoints end, and, while the controllers track (COARSE or FINE) with no
stream, keeps streaming a hold: the last position streamed, or, back in a tracking mode after
HOLD or OFF, the measured position (docs/architecture.md, ``follow_trajectory``).

Setpoints leave through ``send(stamp, positions, velocities, accelerations)``: ``stamp`` the
clock time [ns] the setpoint applies, the others sequences of five floats in physical joint
order [rad, rad/s, rad/s^2]. Clock times are integer nanoseconds (the states' stamps). Not
thread-safe: a caller with several threads holds its own lock around every call.

With ``send_trajectory(start, trajectory)`` given, the streamer sends whole trajectories
instead, as to controllers that hold them (joint_trajectory_controller's contract,
``walker_control.core.trajectory_follower``): a stream's trajectory once, when it starts, with
``start`` the clock time [ns] of its time 0; at a cancel or a stop a one-point trajectory at
rest, from the stamp its hold setpoint would have had, where its setpoints would have ended;
nothing per period, and no hold after a stream (the controllers hold the last point, and
start from where the joints are when they track again after it). Its timing, its end and its
feedback are the stream's, to the period. Since the controllers then follow without the
planner, nothing in the loop waits for the planner's states: the clock may have run on past
the newest state heard here. Given the clock (``now`` of :meth:`TrajectoryStreamer.start`,
:meth:`~TrajectoryStreamer.end_now`, :meth:`~TrajectoryStreamer.on_clock`), a trajectory
starts, holds and ends by it, on the states' grid of stamps: it starts one period after the
clock's stamp, a cancel holds where the trajectory is then, and the stream ends (its end on
the clock reached) even when no state comes.
"""

from __future__ import annotations

import threading

from collections.abc import Callable, Sequence

import numpy as np

from walker_planner.core.errors import PlanningError
from walker_planner.core.streaming import (
    SampledTrajectory, Setpoint, SetpointStream, check_start, stamps_due)

__all__ = ['ActiveStream', 'TrajectoryStreamer', 'Send', 'SendTrajectory']

#: ``send(stamp, positions, velocities, accelerations)`` (see the module docstring).
Send = Callable[[int, Sequence[float], Sequence[float], Sequence[float]], None]
#: ``send_trajectory(start, trajectory)``: start [ns], the trajectory in physical order.
SendTrajectory = Callable[[int, SampledTrajectory], None]

_ZEROS = (0.0, 0.0, 0.0, 0.0, 0.0)


class ActiveStream:
    """A stream under way, and how it ended.

    Attributes
    ----------
    stream : SetpointStream
        Its timing and trajectory.
    owner : object
        Whatever the caller tied to it (the node's action goal), or None.
    last : Setpoint or None
        The last setpoint sent.
    ticks : int
        Setpoints sent.
    fed_back : int
        ``ticks`` at the last feedback (:meth:`TrajectoryStreamer.feedback_due`).
    cancelled : bool
        It ended before its end (cancel, stop).
    ended : bool
        It has ended, whether complete or not.
    message : str
        Why it ended early ('' when it completed).
    """

    def __init__(self, stream: SetpointStream, owner: object = None) -> None:
        self.stream = stream
        self.owner = owner
        self.last: Setpoint | None = None
        self.ticks = 0
        self.fed_back = 0
        self.cancelled = False
        self.ended = False
        self.message = ''

    def cancel(self, message: str = 'cancelled') -> None:
        """Mark the stream cancelled: it ends, holding, at the next joint state."""
        if not self.cancelled:
            self.cancelled, self.message = True, message

    @property
    def duration(self) -> float:
        """Trajectory time [s] of the last setpoint sent (0 before the first)."""
        return self.last.time_from_start if self.last is not None else 0.0


class TrajectoryStreamer:
    """One stream at a time, paced by the joint states (see the module docstring).

    Parameters
    ----------
    period : int
        Control period [ns].
    lookahead : int
        ``planner.stream.lookahead``: periods ahead of the newest state sent at once.
    start_tolerance : float
        ``planner.stream.start_tolerance`` [rad].
    send : callable
        Where setpoints go (see the module docstring).
    send_trajectory : callable, optional
        Where whole trajectories go instead of setpoints (see the module docstring).
    """

    def __init__(self, period: int, lookahead: int, start_tolerance: float, send: Send,
                 send_trajectory: SendTrajectory | None = None) -> None:
        self.period = int(period)
        self.lookahead = lookahead
        self.start_tolerance = start_tolerance
        self._send = send
        self._send_trajectory = send_trajectory
        self.active: ActiveStream | None = None
        #: (stamp [ns], positions [rad] in physical order) of the newest joint state
        self.measured: tuple[int, np.ndarray] | None = None
        # [rad] held at rest while the controllers track with no stream: the last position
        # streamed, or where the joints were when they went back to tracking
        self._holding: np.ndarray | None = None
        self._hold_sent: int | None = None  # [ns] stamp of the newest hold setpoint sent
        self._tracking = False  # the controllers are in COARSE or FINE (they need setpoints)
        self._ended: list[ActiveStream] = []
        self._heard = threading.Event()  # a joint state was taken

    # ------------------------------------------------------------------ inputs
    def on_state(self, stamp: int, positions: np.ndarray) -> None:
        """Take a joint state stamped ``stamp`` [ns] (finite positions, physical order).

        Sends the setpoints due: every one not sent yet up to ``lookahead`` periods after
        ``stamp``, each stamped with the time it applies, so that it is in place before the
        state it applies to. A stream ends (complete) at the state one period before its
        final setpoint, as it would with each setpoint sent just in time.
        """
        self.measured = (int(stamp), positions)
        if not self._heard.is_set():
            self._heard.set()
        active = self.active
        if active is None:
            if self._holding is not None and self._tracking and self._send_trajectory is None:
                self._send_hold(self._holding, stamp)
            return
        if active.cancelled:
            self._finish(active, active.stream.hold(stamp, active.last))
            return
        self._send_due(active, stamp)
        if active.last.final and stamp + self.period >= active.last.stamp:
            self._finish(active, None)

    def on_clock(self, now: int) -> None:
        """Take the clock's time ``now`` [ns]: end a whole trajectory whose end it reached.

        With whole trajectories only (a stream of setpoints ends with its setpoints): the
        stream ends, complete, once the latest stamp of the states' grid not after ``now`` is
        one period before the trajectory's end on the clock (:attr:`SetpointStream.end_stamp`),
        as :meth:`on_state` ends it at that state. Nothing without a stream or a state yet.
        """
        active = self.active
        if active is None or active.cancelled or self._send_trajectory is None \
                or self.measured is None:
            return
        end = active.stream.end_stamp
        if self._grid_stamp(now) + self.period < end:
            return
        sent = active.stream.origin - self.period if active.last is None else active.last.stamp
        active.ticks += max(0, (end - sent) // self.period)
        active.last = active.stream.setpoint_at(end)
        self._finish(active, None)

    def on_control_mode(self, tracking: bool) -> None:
        """Take a mode command: ``tracking`` True for COARSE or FINE.

        Tracking again with no stream (a resume, a step's start): hold where the joints are,
        as the controllers do, not where the last stream left its setpoints; a stream cut
        short (a fault, a hold) may have left them far away.
        """
        if tracking and not self._tracking and self.active is None \
                and self.measured is not None:
            self._holding = np.array(self.measured[1])
            self._hold_sent = None  # from the next state on, over any sent before
        self._tracking = tracking

    def wait_for_state(self, timeout: float) -> bool:
        """Wait up to ``timeout`` [s] of wall time for the first joint state; True once taken.

        For a stream asked for before any state came (the plant's ``joint_states`` matched
        late, on a loaded machine): started at once, :meth:`start` would refuse it for want of
        a state to check its start against, and the step it serves would end. Returns at once
        once a state was taken; called from another thread than :meth:`on_state`'s.
        """
        return self._heard.wait(timeout)

    # ------------------------------------------------------------------ streams
    def start(self, trajectory: SampledTrajectory, owner: object = None,
              now: int | None = None) -> ActiveStream:
        """Start streaming ``trajectory`` from the newest joint state; return the stream.

        The trajectory's time 0 applies one period after that state's stamp; the setpoints
        due are sent at once. With whole trajectories and the clock's time ``now`` [ns] given,
        one period after the latest stamp of the states' grid not after ``now`` when that is
        later (see the module docstring); the start is checked against the newest state.

        Raises
        ------
        PlanningError
            No joint state yet, a joint too far from the trajectory's first point
            (``start_tolerance``), or a stream already under way; nothing changes.
        """
        measured = None if self.measured is None else self.measured[1]
        check_start(trajectory, measured, self.start_tolerance)
        if self.active is not None:
            raise PlanningError('a stream is already running (cancel it or call '
                                'stop_trajectory)')
        now = self._grid_stamp(now) if self._send_trajectory is not None \
            else self.measured[0]
        self.active = ActiveStream(SetpointStream(trajectory, now, self.period), owner)
        if self._send_trajectory is not None:
            self._send_trajectory(self.active.stream.origin, trajectory)
        self._send_due(self.active, now)
        return self.active

    def end_now(self, active: ActiveStream, message: str, now: int | None = None) -> None:
        """End a stream at once, holding where its sent setpoints end (a cancel, a stop).

        It does not wait for a joint state: a plant that stopped sending them (frozen, gone)
        would otherwise keep a cancelled stream running, and the next one refused. With whole
        trajectories and the clock's time ``now`` [ns] given, the hold starts one period after
        the latest stamp of the states' grid not after ``now`` when that is later, where the
        trajectory is then.
        """
        active.cancelled, active.message = True, message
        if self.measured is None:
            stamp = active.stream.origin
        elif self._send_trajectory is not None:
            stamp = self._grid_stamp(now)
        else:
            stamp = self.measured[0]
        self._finish(active, active.stream.hold(stamp, active.last))

    def stop(self, now: int | None = None) -> bool:
        """End whatever stream runs (``stop_trajectory``); return False when none ran.

        ``now``: the clock's time [ns], as for :meth:`end_now`.
        """
        active = self.active
        if active is not None:
            self.end_now(active, 'stopped by stop_trajectory', now)
        return active is not None

    def take_ended(self) -> list[ActiveStream]:
        """Return the streams ended since the last call, oldest first."""
        ended, self._ended = self._ended, []
        return ended

    # ------------------------------------------------------------------ figures
    def tracking_error(self, stream: SetpointStream) -> float:
        """Largest joint error [rad] of the newest state against ``stream``; -1 without one."""
        if self.measured is None:
            return -1.0
        stamp, positions = self.measured
        return stream.tracking_error(stamp, positions)

    def progress(self, active: ActiveStream) -> tuple[float, float]:
        """Where a stream is: trajectory time [s] and fraction, at the state after the newest."""
        stream = active.stream
        duration = stream.trajectory.duration
        elapsed = min(duration, max(0.0, stream.trajectory_time(
            self.measured[0] + self.period))) if self.measured else 0.0
        return elapsed, min(1.0, elapsed / duration) if duration else 1.0

    def feedback_due(self, every: int) -> ActiveStream | None:
        """Return the stream under way when it has sent ``every`` setpoints since its last.

        Marks the feedback given. None when no stream runs, none was sent, or it is not due.
        """
        active = self.active
        if active is None or active.last is None:
            return None
        every = max(1, int(every))
        if active.ticks // every <= active.fed_back // every:
            return None
        active.fed_back = active.ticks
        return active

    # ------------------------------------------------------------------ internals
    def _grid_stamp(self, now: int | None) -> int:
        """Return the newest state's stamp [ns], or the latest of its grid not after ``now``.

        Needs a state. The states come every period (``stamp + k * period``), so a time on
        that grid is one a state has or will have.
        """
        stamp = self.measured[0]
        if now is not None and int(now) > stamp:
            stamp += (int(now) - stamp) // self.period * self.period
        return stamp

    def _send_due(self, active: ActiveStream, now: int) -> None:
        for setpoint in active.stream.due(now, active.last, self.lookahead):
            self._send_setpoint(active, setpoint)

    def _send_setpoint(self, active: ActiveStream, setpoint: Setpoint) -> None:
        if self._send_trajectory is None:
            self._send(setpoint.stamp, setpoint.position.tolist(),
                       setpoint.velocity.tolist(), setpoint.acceleration.tolist())
        active.last = setpoint
        active.ticks += 1

    def _finish(self, active: ActiveStream, hold: Setpoint | None) -> None:
        """End the stream; the controllers keep getting its last position while they track."""
        if hold is not None:
            self._send_setpoint(active, hold)
            if self._send_trajectory is not None:
                zeros = np.zeros((1, 5))
                self._send_trajectory(hold.stamp, SampledTrajectory(
                    np.zeros(1), hold.position[None, :].copy(), zeros, zeros.copy()))
        self._holding = None if active.last is None else np.array(active.last.position)
        self._hold_sent = None if active.last is None else active.last.stamp
        self.active = None
        active.ended = True
        self._ended.append(active)

    def _send_hold(self, position: np.ndarray, now: int) -> None:
        """Send the hold's setpoints not sent yet, up to the lookahead after ``now`` [ns]."""
        for stamp in stamps_due(now, self._hold_sent, self.period, self.lookahead):
            self._send(stamp, position.tolist(), _ZEROS, _ZEROS)
            self._hold_sent = stamp
