"""What enters a joint controller: setpoints (validated), their selection by stamp, staleness.

* :class:`Setpoint` and :func:`validate_setpoint`: NaN, infinity and values outside the joint's
  limits are refused with a :class:`SetpointError` naming the field.
* :class:`SetpointBuffer`: setpoints arrive ahead of the state they apply to (the planner streams
  one period ahead); for a state stamped ``t`` the controller uses the newest setpoint whose
  stamp is not later than ``t``.
* :func:`carry_forward`: when that setpoint is older than the state (the next one is late), it
  is carried forward along its own velocity and acceleration, for a bounded time.
* :class:`StreamPacing`: in sim time, whether a state must wait for the setpoint a stream
  paced by the states owes it, instead of carrying an older one forward.
* :class:`InputWatchdog`: decides, on a steady clock, whether the state or setpoint stream has
  stopped for longer than its timeout; in sim time only while the simulated clock runs.

Times are float seconds: stamps in the ROS time of the messages, watchdog times on a steady
clock. Nothing here knows about ROS.
"""

from __future__ import annotations

import bisect
import dataclasses
import math
from typing import NamedTuple

from walker_core.robot_parameters import Drive

__all__ = ['Setpoint', 'SetpointError', 'validate_setpoint', 'carry_forward', 'SetpointBuffer',
           'StreamPacing', 'InputWatchdog', 'StaleInputs']


class SetpointError(ValueError):
    """A setpoint that must not be followed (non-finite or outside the joint's limits)."""


class Setpoint(NamedTuple):
    """Desired motion of one joint (immutable).

    Attributes
    ----------
    position : float
        [rad]
    velocity : float
        [rad/s], feed-forward and reference of the derivative term.
    acceleration : float
        [rad/s^2], feed-forward through the rigid-model inertia.
    effort : float
        Additional feed-forward torque [N*m].
    """

    position: float
    velocity: float = 0.0
    acceleration: float = 0.0
    effort: float = 0.0


def validate_setpoint(setpoint: Setpoint, drive: Drive, joint_name: str = 'joint') -> Setpoint:
    """Return ``setpoint`` if it may be followed, else raise :class:`SetpointError`.

    Refused: any non-finite field; a position outside ``[position_min, position_max]``; a speed
    above ``velocity_limit``; an extra effort above ``torque_limit``.
    """
    position, velocity, acceleration, effort = setpoint
    # the common case first, cheaply (a stream validates five setpoints every period): floats
    # whose sum is finite are each finite
    if not (type(position) is float and type(velocity) is float
            and type(acceleration) is float and type(effort) is float
            and math.isfinite(position + velocity + acceleration + effort)):
        for name, value in zip(Setpoint._fields, setpoint, strict=True):
            if not (isinstance(value, (int, float)) and math.isfinite(value)):
                raise SetpointError(f'{joint_name} setpoint {name} = {value!r} refused: '
                                    f'must be a finite number')
    if not drive.position_min <= setpoint.position <= drive.position_max:
        raise SetpointError(
            f'{joint_name} setpoint position {setpoint.position:.6g} rad refused: outside the '
            f'joint limits [{drive.position_min:g}, {drive.position_max:g}] rad')
    if abs(setpoint.velocity) > drive.velocity_limit:
        raise SetpointError(
            f'{joint_name} setpoint velocity {setpoint.velocity:.6g} rad/s refused: above the '
            f'velocity limit {drive.velocity_limit:g} rad/s')
    if abs(setpoint.effort) > drive.torque_limit:
        raise SetpointError(
            f'{joint_name} setpoint effort {setpoint.effort:.6g} N*m refused: above the torque '
            f'limit {drive.torque_limit:g} N*m')
    return setpoint


def carry_forward(setpoint: Setpoint, elapsed: float, horizon: float, drive: Drive) -> Setpoint:
    """Return the setpoint ``elapsed`` seconds after its stamp, carried along its own motion.

    A streamed setpoint is a sample of a trajectory at its stamp. When the next sample is late
    (a starved planner, a message lost), the state the controller answers is newer than the
    sample, and holding the sample would stop the reference's position while its velocity and
    acceleration (the feed-forward) go on: the joint would run ahead of its reference, and
    jump back when the stream resumes. The sample is instead carried forward as the trajectory
    it describes, ``p + v t + a t^2 / 2`` and ``v + a t``, exact within a segment of constant
    acceleration; at most for ``horizon`` seconds (a stopped stream then holds what it
    reached, until its timeout), and within the joint's position and velocity limits. A
    setpoint at rest (``v = a = 0``, an operator's) is unchanged.

    Parameters
    ----------
    setpoint : Setpoint
        The newest setpoint whose stamp is not later than the state's (validated).
    elapsed : float
        State stamp minus setpoint stamp [s].
    horizon : float
        Longest time [s] a setpoint is carried forward (``control.setpoint_extrapolation``);
        0 holds it as it is.
    drive : Drive
        The joint's limits.

    Returns
    -------
    Setpoint
    """
    t = min(elapsed, horizon)
    if not t > 0.0 or (setpoint.velocity == 0.0 and setpoint.acceleration == 0.0):
        return setpoint
    a = setpoint.acceleration
    position = setpoint.position + (setpoint.velocity + 0.5 * a * t) * t
    velocity = setpoint.velocity + a * t
    return Setpoint(position=min(max(position, drive.position_min), drive.position_max),
                    velocity=min(max(velocity, -drive.velocity_limit), drive.velocity_limit),
                    acceleration=a, effort=setpoint.effort)


class SetpointBuffer:
    """Setpoints ordered by stamp; selects the newest one not later than a state's stamp.

    Parameters
    ----------
    capacity : int
        Setpoints kept (the oldest are dropped first).
    """

    def __init__(self, capacity: int = 64) -> None:
        if capacity < 1:
            raise ValueError(f'capacity must be >= 1, got {capacity!r}')
        self._capacity = capacity
        self._stamps: list[float] = []
        self._setpoints: list[Setpoint] = []

    def __len__(self) -> int:
        return len(self._stamps)

    def clear(self) -> None:
        """Forget every setpoint."""
        self._stamps.clear()
        self._setpoints.clear()

    def add(self, stamp: float, setpoint: Setpoint) -> None:
        """Insert a setpoint for time ``stamp`` [s]; one with the same stamp is replaced."""
        if not math.isfinite(stamp):
            raise SetpointError(f'setpoint stamp must be finite, got {stamp!r}')
        index = bisect.bisect_left(self._stamps, stamp)
        if index < len(self._stamps) and self._stamps[index] == stamp:
            self._setpoints[index] = setpoint
            return
        self._stamps.insert(index, stamp)
        self._setpoints.insert(index, setpoint)
        if len(self._stamps) > self._capacity:
            del self._stamps[0]
            del self._setpoints[0]

    def drop_until(self, stamp: float) -> None:
        """Forget the setpoints stamped at or before ``stamp`` [s]; keep the later ones."""
        index = bisect.bisect_right(self._stamps, stamp)
        del self._stamps[:index]
        del self._setpoints[:index]

    def newest_stamp(self) -> float | None:
        """Stamp [s] of the newest setpoint held, or None when there is none."""
        return self._stamps[-1] if self._stamps else None

    def select(self, stamp: float) -> tuple[float, Setpoint] | None:
        """Newest ``(stamp, setpoint)`` with a stamp not later than ``stamp``, or None.

        Older setpoints are dropped: they can never be selected again for a later state.
        """
        index = bisect.bisect_right(self._stamps, stamp) - 1
        if index < 0:
            return None
        del self._stamps[:index]
        del self._setpoints[:index]
        return self._stamps[0], self._setpoints[0]


class StreamPacing:
    """Whether a state must wait for the setpoint that a stream paced by the states owes it.

    The planner streams on the plant's states: for the state stamped ``t`` it sends the
    setpoint stamped ``t + T``, one period ahead, so that it is in place before the next state.
    In sim time the plant waits for the controllers' efforts before it steps, and a controller
    can therefore wait for that setpoint too, instead of carrying an older one forward
    (:func:`carry_forward`) when the streaming process was slow: the motion is then the same
    however loaded the machine is. A stream counts as paced while the setpoint used for the
    last state answered was stamped with that state's own time; an operator's setpoints
    (unstamped, or at their own rate) are not, and are never waited for. A mode or role change
    (the setpoints are dropped) starts afresh: nothing is owed until a setpoint stamped with
    its state's time has been used again.

    Parameters
    ----------
    tolerance : float
        Largest difference [s] between two stamps taken as the same time.
    """

    def __init__(self, tolerance: float = 1e-6) -> None:
        self.tolerance = tolerance
        self.paced = False

    def reset(self) -> None:
        """Forget the stream (the setpoints were dropped: a mode or role change)."""
        self.paced = False

    def used(self, state_stamp: float, setpoint_stamp: float | None) -> None:
        """Record that the state stamped ``state_stamp`` [s] was answered with a setpoint.

        ``setpoint_stamp``: the stamp [s] of the setpoint used, None when there was none (the
        joint held or did not track).
        """
        self.paced = setpoint_stamp is not None \
            and abs(setpoint_stamp - state_stamp) <= self.tolerance

    def owed(self, state_stamp: float, newest_setpoint_stamp: float | None) -> bool:
        """Say whether the state stamped ``state_stamp`` [s] should wait for its setpoint.

        True while the stream is paced and no setpoint stamped at or after the state has come.
        """
        if not self.paced:
            return False
        return newest_setpoint_stamp is None \
            or newest_setpoint_stamp < state_stamp - self.tolerance


@dataclasses.dataclass(frozen=True)
class StaleInputs:
    """Which input streams have stopped, and why (empty reason when none)."""

    state: bool = False
    setpoint: bool = False
    reason: str = ''

    @property
    def any(self) -> bool:
        """True when some stream is stale."""
        return self.state or self.setpoint


class InputWatchdog:
    """Detects a state or setpoint stream that stopped for longer than its timeout.

    Parameters
    ----------
    state_timeout, setpoint_timeout : float
        [s] on the steady clock.
    clock_slack : float, optional
        [s] of ROS time the simulated clock may run past a stream's last message before that
        stream's silence counts (see Notes); 0 by default.

    Notes
    -----
    The state stream is watched from the first state on. The setpoint stream is watched only
    while a tracking mode expects it, from the first setpoint received in that mode on: before
    any setpoint the controller holds the measured position, which is not a fault.

    In sim time (:meth:`check` given the ROS clock) a silence counts only once the clock has
    also run more than ``clock_slack`` past the ROS time of the stream's last message (for a
    state its stamp; for a setpoint the newest state's stamp when it came): a clock standing
    still (held while the supervisor waits for an answer, or a stopped plant) owes no states,
    and the setpoints are paced by the states. A plant that stopped is then the supervisor's to
    name (its watchdog also hears the plant's steady heartbeat); states lost while the clock
    runs are still stale here.
    """

    def __init__(self, state_timeout: float, setpoint_timeout: float,
                 clock_slack: float = 0.0) -> None:
        self.state_timeout = float(state_timeout)
        self.setpoint_timeout = float(setpoint_timeout)
        self.clock_slack = float(clock_slack)
        self._last_state: float | None = None
        self._last_setpoint: float | None = None
        self._state_clock: float | None = None  # [s] ROS time of the last state
        self._setpoint_clock: float | None = None  # [s] ROS time known at the last setpoint
        self._watch_setpoints = False

    @property
    def last_state(self) -> float | None:
        """[s] Steady time of the last state received (None before the first)."""
        return self._last_state

    @property
    def last_setpoint(self) -> float | None:
        """[s] Steady time of the last setpoint received while watched (None: none yet)."""
        return self._last_setpoint if self._watch_setpoints else None

    def state_received(self, now: float, stamp: float | None = None) -> None:
        """Note a state stamped ``stamp`` [s, ROS time] received at steady time ``now`` [s]."""
        self._last_state = now
        if stamp is not None:
            self._state_clock = stamp

    def setpoint_received(self, now: float) -> None:
        """Note a setpoint received at steady time ``now`` [s]."""
        self._last_setpoint = now
        self._setpoint_clock = self._state_clock

    def expect_setpoints(self, expected: bool) -> None:
        """Start (tracking mode entered) or stop watching the setpoint stream."""
        if expected != self._watch_setpoints:
            self._last_setpoint = None
        self._watch_setpoints = expected

    def check(self, now: float, clock: float | None = None) -> StaleInputs:
        """Which streams are stale at steady time ``now`` [s].

        ``clock``: the ROS clock now [s], in sim time only (None on the wall clock, where the
        steady silence alone counts).
        """
        reasons = []
        state = self._silent(now, self._last_state, self.state_timeout, clock,
                             self._state_clock)
        if state:
            reasons.append(f'no joint state for {now - self._last_state:.3f} s '
                           f'(timeout {self.state_timeout:g} s)')
        setpoint = self._watch_setpoints and self._silent(
            now, self._last_setpoint, self.setpoint_timeout, clock, self._setpoint_clock)
        if setpoint:
            reasons.append(f'no setpoint for {now - self._last_setpoint:.3f} s '
                           f'(timeout {self.setpoint_timeout:g} s)')
        return StaleInputs(state=state, setpoint=setpoint, reason='; '.join(reasons))

    def _silent(self, now: float, last: float | None, timeout: float, clock: float | None,
                clock_then: float | None) -> bool:
        if last is None or now - last <= timeout:
            return False
        return clock is None or clock_then is None or clock - clock_then > self.clock_slack

    def setpoint_lag(self, state_stamp: float, setpoint_stamp: float) -> str:
        """Why the setpoint in force is too old for a state, by stamps [s] ('' when it is not).

        This catches a stopped setpoint stream in ROS time, which the steady-clock check misses
        when simulated time runs faster than the wall clock.
        """
        lag = state_stamp - setpoint_stamp
        if lag > self.setpoint_timeout:
            return (f'the newest setpoint is {lag:.3f} s older than the joint state '
                    f'(timeout {self.setpoint_timeout:g} s)')
        return ''
