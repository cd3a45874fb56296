"""One joint's controller with its inputs: every decision a controller node makes per joint.

A controller node (``joint_controller_node``, ``joint_controllers_node``) and the headless
lock-step loop (``walker_headless``) drive each joint through a :class:`ControllerChannel`:
the :class:`~walker_control.core.joint_controller.JointController` core, the joint's setpoint
buffer and its pacing, its watchdog over the state and setpoint streams, and what they decide
between them:

* a mode command (:meth:`ControllerChannel.command_mode`): a refused base change latches a
  hold; on a change of mode or base the setpoints for states already answered are dropped and
  those sent ahead for the states to come are kept (a stream that goes on from COARSE into
  FINE), all of them on a base change (docs/architecture.md, "Setpoint stream");
* a setpoint (:meth:`ControllerChannel.take_setpoint`): refused (and the joint held) when it
  names another joint or fails :func:`~walker_control.core.inputs.validate_setpoint`; an
  unstamped one applies from the next state;
* a whole trajectory (:meth:`ControllerChannel.take_trajectory`), held and sampled at every
  state as joint_trajectory_controller does
  (:class:`~walker_control.core.trajectory_follower.TrajectoryFollower`): refused, changing
  nothing, when malformed or beyond the joint's limits; whichever of the two sources came last
  is followed (a trajectory ends a setpoint stream, a setpoint the held trajectory), and a
  trajectory held is never waited for nor timed out: it is the reference until its end, then
  its last point;
* a state (:meth:`ControllerChannel.answer`): the newest setpoint not later than its stamp,
  held when it is too old, carried forward along its own motion when the next is late; a
  measurement the controller cannot use latches a hold and repeats the last effort;
* the inputs' watchdog (:meth:`ControllerChannel.check_inputs`);
* when a ``ControllerState`` is due (:meth:`ControllerChannel.state_due`,
  ``control.state_rate``).

Times are float seconds: stamps in the ROS time of the states, watchdog times on a steady
clock. What the channel has to say goes to a ``log(level, text, throttle)`` callable
(``level`` one of ``'info'``, ``'warning'``, ``'error'``; ``throttle`` [s] the shortest
interval between two such lines, 0 for none); nothing here knows about ROS.
"""

from __future__ import annotations

from collections.abc import Callable

from walker_control.core.config import ControllerSettings
from walker_control.core.inputs import (
    InputWatchdog, Setpoint, SetpointBuffer, SetpointError, StaleInputs, StreamPacing,
    carry_forward, validate_setpoint)
from walker_control.core.joint_controller import (
    ControlOutput, JointController, Measurement, MeasurementError, MissingAccelerationError,
    RoleChangeError)
from walker_control.core.modes import Mode
from walker_control.core.trajectory_follower import (
    JointTrajectory, TrajectoryError, TrajectoryFollower)

__all__ = ['ControllerChannel', 'CLOCK_SLACK_PERIODS', 'Log']

#: In sim time an input's silence counts only once the simulated clock has run this many
#: control periods past its last message (InputWatchdog): a clock held still owes nothing.
CLOCK_SLACK_PERIODS = 2

#: ``log(level, text, throttle)``: ``level`` 'info', 'warning' or 'error'; ``throttle`` [s].
Log = Callable[[str, str, float], None]


def _silent(level: str, text: str, throttle: float) -> None:
    """Say nothing (a channel built without a log)."""


class ControllerChannel:
    """One physical joint's controller and its inputs (see the module docstring).

    Parameters
    ----------
    settings : ControllerSettings
        Validated robot, timing and control parameters.
    joint : str
        The physical joint.
    log : callable, optional
        ``log(level, text, throttle)`` (see the module docstring); silent by default.
    """

    def __init__(self, settings: ControllerSettings, joint: str, log: Log | None = None
                 ) -> None:
        self.joint = joint
        self._settings = settings
        self._log = log or _silent
        self.controller = JointController(settings, joint, 'a')
        self._setpoints = SetpointBuffer()
        self._pacing = StreamPacing()
        #: the whole trajectory held (the reference while it holds one)
        self.trajectory = TrajectoryFollower((joint,))
        self._last_position: float | None = None  # [rad] of the last state answered
        control = settings.control
        self.watchdog = InputWatchdog(control.state_timeout, control.setpoint_timeout,
                                      CLOCK_SLACK_PERIODS * settings.sample_time)
        self.stale = StaleInputs()
        #: the setpoint in force was too old for the last state answered (the joint holds)
        self.setpoint_lagging = False
        self.last_stamp: float | None = None  # [s] stamp of the last state answered
        self.last_effort: float | None = None  # [N*m] the effort last answered
        self._last_state_report: float | None = None  # [s] stamp of the last state report

    # ------------------------------------------------------------------------- settings
    @property
    def settings(self) -> ControllerSettings:
        """Parameters in force."""
        return self._settings

    def apply_settings(self, settings: ControllerSettings) -> None:
        """Take validated new settings."""
        self._settings = settings
        self.controller.apply_settings(settings)
        self.watchdog.state_timeout = settings.control.state_timeout
        self.watchdog.setpoint_timeout = settings.control.setpoint_timeout
        self.watchdog.clock_slack = CLOCK_SLACK_PERIODS * settings.sample_time

    # -------------------------------------------------------------------------- inputs
    def command_mode(self, mode: int, base_gripper: str | None, steady_now: float,
                     clock_now: float | None) -> None:
        """Take a mode command (``walker_msgs/ControlMode``'s ``mode`` and ``base_gripper``).

        ``base_gripper`` None (or '') keeps the base. A base change refused by the controller
        latches a hold; an unknown mode or gripper changes nothing. ``steady_now`` [s] and
        ``clock_now`` [s, sim time; None on the wall clock] judge the inputs again at once: the
        next states must not report a staleness that this command has ended (the supervisor
        would take it for a fault of the motion it starts).
        """
        controller = self.controller
        before = (controller.mode, controller.base_gripper)
        try:
            mode = Mode(mode)
            controller.command(mode, base_gripper or None)
        except RoleChangeError as error:
            controller.hold(str(error))
            self._log('error', f'{error}; holding', 0.0)
            return
        except ValueError as error:
            self._log('error', f'control_mode refused ({error}); nothing changed', 0.0)
            return
        self.setpoint_lagging = False
        if (controller.mode, controller.base_gripper) != before:
            if controller.base_gripper != before[1] or self.last_stamp is None:
                self._setpoints.clear()
                self.trajectory.clear()
            else:
                self._setpoints.drop_until(self.last_stamp)
                if not before[0].tracks_setpoints and controller.mode.tracks_setpoints \
                        and self.trajectory.holding_trajectory \
                        and self._last_position is not None \
                        and self.trajectory.ended(self.last_stamp):
                    # back to tracking after a trajectory ended: from where the joint is,
                    # not where the trajectory left off (as the planner's hold after a
                    # stream); one still under way goes on, as a stream would, and those
                    # sent ahead for the time to come stay
                    self.trajectory.hold((self._last_position,), self.last_stamp,
                                         keep_queued=True)
            self._pacing.reset()
            self._log('info', f'mode {controller.mode.name}, base gripper '
                      f'{controller.base_gripper}, role J{controller.role}', 0.0)
        self._expect_setpoints()
        self.stale = self.watchdog.check(steady_now, clock_now)

    def take_setpoint(self, joint_name: str, setpoint: Setpoint, stamp: float,
                      steady_now: float) -> bool:
        """Take one setpoint of the joint's stream, for the state stamped ``stamp`` [s].

        ``joint_name`` is the name the setpoint carries ('' for none); ``stamp`` 0 (an
        operator's unstamped setpoint) applies from the next state. Returns False when the
        setpoint is refused: it names another joint or fails
        :func:`~walker_control.core.inputs.validate_setpoint`; the joint then holds.
        """
        try:
            if joint_name not in ('', self.joint):
                raise SetpointError(f'setpoint for {joint_name!r} on the topic of {self.joint}')
            setpoint = validate_setpoint(setpoint, self._settings.drive(self.controller.role),
                                         self.joint)
        except SetpointError as error:
            self.controller.hold(f'setpoint refused: {error}')
            self._log('error', f'{error}; holding', 0.0)
            return False
        if stamp == 0.0:
            stamp = self.last_stamp or 0.0
        if self.trajectory.holding_trajectory:  # the newest source is followed
            self.trajectory.clear()
            self._expect_setpoints()
        self._setpoints.add(stamp, setpoint)
        self.setpoint_lagging = False
        self.watchdog.setpoint_received(steady_now)
        return True

    def take_trajectory(self, joint_names, times, positions, velocities=(), accelerations=(),
                        start: float = 0.0) -> bool:
        """Take a whole trajectory (``trajectory_msgs/JointTrajectory``'s fields) to follow.

        ``joint_names`` must name this joint (a trajectory for several joints gives it its
        column); ``times`` [s] from ``start`` [s, the states' clock; 0: from the next state];
        ``positions``, ``velocities``, ``accelerations`` per point [rad, rad/s, rad/s^2]
        (velocities and accelerations may be empty). It replaces the trajectory held from its
        start time (:class:`~walker_control.core.trajectory_follower.TrajectoryFollower`) and
        any setpoint stream. Returns False when it is refused: malformed, not finite (the
        follower's checks), or a point beyond the joint's limits; nothing then changes (the
        joint goes on following what it held) and the reason is logged.
        """
        now = self.last_stamp or 0.0
        try:
            trajectory = JointTrajectory.from_points(
                (self.joint,), joint_names, times, positions, velocities, accelerations,
                start)
            drive = self._settings.drive(self.controller.role)
            speeds = trajectory.velocities if trajectory.velocities is not None \
                else [(0.0,)] * len(trajectory.times)
            for point, speed in zip(trajectory.positions, speeds, strict=True):
                validate_setpoint(Setpoint(float(point[0]), float(speed[0])), drive,
                                  self.joint)
            measured = None if self._last_position is None else (self._last_position,)
            self.trajectory.set_trajectory(trajectory, now, measured)
        except (TrajectoryError, SetpointError) as error:
            self._log('error', f'trajectory refused: {error}; nothing changed', 0.0)
            return False
        self._setpoints.clear()
        self._pacing.reset()
        self.setpoint_lagging = False
        self._expect_setpoints()
        return True

    # --------------------------------------------------------------------------- update
    def owes_setpoint(self, stamp: float) -> bool:
        """Say whether the state stamped ``stamp`` [s] lacks the setpoint its stream owes it.

        True only while tracking a stream paced by the states (see
        :class:`~walker_control.core.inputs.StreamPacing`) whose setpoint for ``stamp`` has not
        come yet; in sim time a controller node then waits for it before answering.
        """
        return self.controller.mode.tracks_setpoints \
            and self._pacing.owed(stamp, self._setpoints.newest_stamp())

    def answer(self, stamp: float, measurement: Measurement) -> ControlOutput | None:
        """Compute the joint's output for a state stamped ``stamp`` [s].

        Returns None when the measurement is refused (the controller holds, and
        :attr:`last_effort`, the effort of the last state answered or None, is the one to
        repeat); else the output, whose ``effort`` is now :attr:`last_effort`.
        """
        dt = self._sample_time(stamp)
        setpoint = self._select_setpoint(stamp)
        try:
            output = self.controller.update(measurement, setpoint, dt)
        except MissingAccelerationError as error:
            self.controller.hold(str(error))
            self._log('error', f'{error}; holding', 0.0)
            output = self.controller.update(measurement, setpoint, dt)
        except MeasurementError as error:
            self.controller.hold(str(error))
            self._log('error', f'{error}; holding, last effort repeated', 1.0)
            return None
        self.last_stamp = stamp
        self.last_effort = output.effort
        self._last_position = measurement.position
        return output

    def state_due(self, stamp: float) -> bool:
        """Say whether a ``ControllerState`` is due for the state stamped ``stamp`` [s].

        One every ``1 / control.state_rate`` of the states' time; True marks it sent.
        """
        period = 1.0 / self._settings.control.state_rate
        last = self._last_state_report
        if last is not None and 0.0 <= stamp - last < period - 1e-9:
            return False
        self._last_state_report = stamp
        return True

    @property
    def reports_stale(self) -> bool:
        """The ``stale`` flag of the joint's ``ControllerState``: a stale input or setpoint."""
        return self.stale.any or self.setpoint_lagging

    def check_inputs(self, now: float, clock: float | None) -> StaleInputs:
        """Check the inputs at steady time ``now`` [s]; hold on a stale one, and return it.

        ``clock``: the ROS clock [s] in sim time, None on the wall clock.
        """
        stale = self.watchdog.check(now, clock)
        if stale.any and not self.stale.any:
            self._log('warning', f'input stale: {stale.reason}; holding', 0.0)
        elif self.stale.any and not stale.any:
            self._log('info', 'inputs fresh again; holding until the next mode command', 0.0)
        self.stale = stale
        if stale.any:
            self.controller.hold(f'input stale: {stale.reason}')
        return stale

    # ------------------------------------------------------------------------- helpers
    def _sample_time(self, stamp: float) -> float:
        nominal = self._settings.sample_time
        if self.last_stamp is None:
            return nominal
        if stamp < self.last_stamp:
            self._log('warning', 'joint_states stamp went backwards (plant reset?)', 0.0)
            return nominal
        return stamp - self.last_stamp

    def _expect_setpoints(self) -> None:
        """Watch the setpoint stream only while tracking one, not while a trajectory is held."""
        self.watchdog.expect_setpoints(self.controller.mode.tracks_setpoints
                                       and not self.trajectory.holding_trajectory)

    def _select_setpoint(self, stamp: float) -> Setpoint | None:
        tracking = self.controller.mode.tracks_setpoints
        if tracking and self.trajectory.holding_trajectory:
            self._pacing.used(stamp, None)  # a trajectory held is never waited for
            sample = self.trajectory.sample(stamp)
            if sample is None:  # it starts later: hold where the joint is until then
                return None
            drive = self._settings.drive(self.controller.role)
            # interpolation between points within the limits stays within them, but for
            # a quintic's overshoot: clamped, as the joint's own limits would
            position = min(max(float(sample.positions[0]), drive.position_min),
                           drive.position_max)
            velocity = min(max(float(sample.velocities[0]), -drive.velocity_limit),
                           drive.velocity_limit)
            return Setpoint(position, velocity, float(sample.accelerations[0]))
        selected = self._setpoints.select(stamp) if tracking else None
        self._pacing.used(stamp, None if selected is None else selected[0])
        if selected is None:
            return None
        lag = self.watchdog.setpoint_lag(stamp, selected[0])
        if lag:
            self._pacing.reset()
            self.setpoint_lagging = True
            self.controller.hold(f'setpoint stream stale: {lag}')
            self._log('warning', f'setpoint stream stale: {lag}; holding', 0.0)
            return None
        return carry_forward(selected[1], stamp - selected[0],
                             self._settings.control.setpoint_extrapolation,
                             self._settings.drive(self.controller.role))
