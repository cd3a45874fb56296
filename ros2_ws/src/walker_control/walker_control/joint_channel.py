"""One joint's controller inside a controller node: its core, its inputs and its state topic.

A controller node drives one joint (``joint_controller_node``) or several
(``joint_controllers_node``); either way each joint has a :class:`JointChannel`: the
:class:`~walker_control.core.joint_controller.JointController` core, the joint's setpoint
subscription and buffer, its watchdog over the state and setpoint streams, and its
``controllers/<joint>/state`` publisher. The node owns what the joints share: the
``joint_states``, ``joint_accelerations`` and ``control_mode`` subscriptions, the
``effort_commands`` publisher and the watchdog timer.

No control math here: the channel converts messages and calls the core.
"""

from __future__ import annotations

from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.node import Node
from walker_msgs.msg import ControlMode, ControllerState, JointCommand

from walker_core.qos import COMMAND_QOS, MODE_QOS, MODE_SUBSCRIPTION_QOS, SENSOR_QOS
from walker_core.resubscription import Resubscription

from walker_control.core.config import ControllerSettings
from walker_control.core.inputs import (
    InputWatchdog, Setpoint, SetpointBuffer, SetpointError, StaleInputs,
    StreamPacing, carry_forward, validate_setpoint)
from walker_control.core.joint_controller import (
    ControlOutput, JointController, Measurement, MeasurementError, MissingAccelerationError,
    RoleChangeError)
from walker_control.core.modes import Mode

__all__ = ['STATE_QOS', 'COMMAND_QOS', 'MODE_QOS', 'MODE_SUBSCRIPTION_QOS',
           'RESUBSCRIBE_AFTER_TIMEOUTS', 'JointChannel', 'seconds']

#: joint_states and joint_accelerations: best effort, newest only (walker_core.qos)
STATE_QOS = SENSOR_QOS
# A stream silent for this many of its timeouts has its subscription made anew, and again
# as often while the silence lasts (see Resubscription): 2 s by default, the supervisor's
# watchdog, so that a publisher merely stalled by a loaded machine is not matched anew
# (re-matching would lengthen the stall) while a walker held on a silent input has a fresh
# subscription by the time it is resumed.
RESUBSCRIBE_AFTER_TIMEOUTS = 4.0
# In sim time an input's silence counts only once the simulated clock has run this many
# control periods past its last message (InputWatchdog): a clock held still owes nothing.
CLOCK_SLACK_PERIODS = 2


def seconds(stamp) -> float:
    """Return a ``builtin_interfaces/Time`` as float seconds."""
    return stamp.sec + stamp.nanosec * 1e-9


class JointChannel:
    """One joint's controller in ``node`` (see the module docstring).

    Parameters
    ----------
    node : rclpy.node.Node
        The controller node: it creates this channel's subscription and publisher, gives its
        logger and its steady clock ``now`` [s].
    joint : str
        The physical joint.
    settings : ControllerSettings
        The node's validated settings.
    steady_now : callable
        Steady-clock time [s].
    clock_now : callable
        The ROS clock's time [s] in sim time, None on the wall clock (see
        :class:`~walker_control.core.inputs.InputWatchdog`).
    log_prefix : str
        Put before this channel's log lines (the joint's name in a node of several joints).
    after_setpoint : callable, optional
        Called after each setpoint message is taken (or refused): the node answers a state
        that waited for it.
    """

    def __init__(self, node: Node, joint: str, settings: ControllerSettings, steady_now,
                 clock_now, log_prefix: str = '', after_setpoint=None) -> None:
        self.joint = joint
        self._node = node
        self._logger = node.get_logger()
        self._prefix = log_prefix
        self._steady_now = steady_now
        self._clock_now = clock_now
        self._settings = settings
        self.controller = JointController(settings, joint, 'a')
        self._setpoints = SetpointBuffer()
        self._pacing = StreamPacing()
        self._after_setpoint = after_setpoint
        control = settings.control
        self.watchdog = InputWatchdog(control.state_timeout, control.setpoint_timeout,
                                      CLOCK_SLACK_PERIODS * settings.sample_time)
        self._setpoint_resubscription = Resubscription(
            RESUBSCRIBE_AFTER_TIMEOUTS * control.setpoint_timeout)
        self.stale = StaleInputs()
        self.setpoint_lagging = False
        self.last_stamp: float | None = None  # [s] stamp of the last state answered
        self.last_effort: float | None = None  # [N*m] the effort last answered
        self._last_state_publish: float | None = None  # [s] stamp of the last ControllerState
        self._state_msg = ControllerState(joint_name=joint)
        quiet = PublisherEventCallbacks(use_default_callbacks=False)
        self._state_pub = node.create_publisher(ControllerState, f'controllers/{joint}/state',
                                                COMMAND_QOS, event_callbacks=quiet)
        self._setpoint_sub = self.subscribe_setpoints()

    # ------------------------------------------------------------------------- settings
    def subscribe_setpoints(self):
        """Subscribe to ``controllers/<joint>/setpoint`` (the node keeps the order).

        Without QoS event handlers: the subscription is made anew while the node spins (see
        :meth:`setpoint_resubscription_due`), and destroying one that has handlers under the
        events executor is an open crash report (ros2/rclpy#1644). A publisher of incompatible
        QoS is still warned of on its own side.
        """
        self._setpoint_sub = self._node.create_subscription(
            JointCommand, f'controllers/{self.joint}/setpoint', self._on_setpoint_message,
            COMMAND_QOS,
            event_callbacks=SubscriptionEventCallbacks(use_default_callbacks=False))
        return self._setpoint_sub

    def take_setpoints(self) -> None:
        """Take the setpoints already received that no callback has had yet.

        For a caller that needs them now, between two turns of its executor (the plant
        handing a state over by call, :meth:`ControllerNode.take_state`): each taken here
        costs a take from the middleware, not a turn of the executor and a callback; the
        executor then finds nothing left to take for them.
        """
        subscription = self._setpoint_sub
        while True:
            with subscription.handle:
                taken = subscription.handle.take_message(JointCommand, False)
            if taken is None:
                return
            self.on_setpoint(taken[0])

    def setpoint_resubscription_due(self, now: float) -> bool:
        """Say whether the setpoint stream has been silent long enough to subscribe anew."""
        return self._setpoint_resubscription.due(now, self.watchdog.last_setpoint)

    def destroy_setpoint_subscription(self) -> None:
        """Destroy the setpoint subscription (before :meth:`subscribe_setpoints`)."""
        self._node.destroy_subscription(self._setpoint_sub)

    def apply_settings(self, settings: ControllerSettings) -> None:
        """Take validated new settings (the node's parameters changed)."""
        self._settings = settings
        self.controller.apply_settings(settings)
        self.watchdog.state_timeout = settings.control.state_timeout
        self.watchdog.setpoint_timeout = settings.control.setpoint_timeout
        self.watchdog.clock_slack = CLOCK_SLACK_PERIODS * settings.sample_time
        self._setpoint_resubscription.after = \
            RESUBSCRIBE_AFTER_TIMEOUTS * settings.control.setpoint_timeout

    # -------------------------------------------------------------------------- inputs
    def on_control_mode(self, msg: ControlMode) -> None:
        """Take a mode command (the node passes each one to every channel)."""
        controller = self.controller
        before = (controller.mode, controller.base_gripper)
        try:
            mode = Mode(msg.mode)
            controller.command(mode, msg.base_gripper or None)
        except RoleChangeError as error:
            controller.hold(str(error))
            self._logger.error(f'{self._prefix}{error}; holding')
            return
        except ValueError as error:
            self._logger.error(f'{self._prefix}control_mode refused ({error}); nothing changed')
            return
        self.setpoint_lagging = False
        if (controller.mode, controller.base_gripper) != before:
            # Setpoints sent ahead for the states to come stay (a stream that goes on from
            # COARSE into FINE); older ones, and every one under another base, are dropped.
            if controller.base_gripper != before[1] or self.last_stamp is None:
                self._setpoints.clear()
            else:
                self._setpoints.drop_until(self.last_stamp)
            self._pacing.reset()
            self._logger.info(f'{self._prefix}mode {controller.mode.name}, base gripper '
                              f'{controller.base_gripper}, role J{controller.role}')
        self.watchdog.expect_setpoints(mode.tracks_setpoints)
        # Judge the inputs again now: the next states must not report a staleness that this
        # command has ended (the supervisor would take it for a fault of the motion it starts).
        self.stale = self.watchdog.check(self._steady_now(), self._clock_now())

    def _on_setpoint_message(self, msg: JointCommand) -> None:
        self.on_setpoint(msg)
        if self._after_setpoint is not None:
            self._after_setpoint()

    def on_setpoint(self, msg: JointCommand) -> None:
        """Take one setpoint of the joint's stream; refuse (and hold) an invalid one."""
        try:
            if msg.joint_name not in ('', self.joint):
                raise SetpointError(f'setpoint for {msg.joint_name!r} on the topic of '
                                    f'{self.joint}')
            setpoint = validate_setpoint(
                Setpoint(msg.position, msg.velocity, msg.acceleration, msg.effort),
                self._settings.drive(self.controller.role), self.joint)
        except SetpointError as error:
            self.controller.hold(f'setpoint refused: {error}')
            self._logger.error(f'{error}; holding')
            return
        stamp = seconds(msg.header.stamp)
        if stamp == 0.0:  # unstamped (an operator's command): it applies from the next state
            stamp = self.last_stamp or 0.0
        self._setpoints.add(stamp, setpoint)
        self.setpoint_lagging = False
        self.watchdog.setpoint_received(self._steady_now())

    # --------------------------------------------------------------------------- update
    def owes_setpoint(self, stamp: float) -> bool:
        """Say whether the state stamped ``stamp`` [s] lacks the setpoint its stream owes it.

        True only while tracking a stream paced by the states (see
        :class:`~walker_control.core.inputs.StreamPacing`) whose setpoint for ``stamp`` has not
        come yet; in sim time the node then waits for it before answering.
        """
        return self.controller.mode.tracks_setpoints \
            and self._pacing.owed(stamp, self._setpoints.newest_stamp())

    def answer(self, header, stamp: float, measurement: Measurement) -> float | None:
        """Compute the joint's effort [N*m] for a state stamped ``stamp`` [s].

        Publishes the joint's ``ControllerState`` at ``control.state_rate``. Returns None
        when the measurement is refused and the joint has never answered (the controller
        holds); after a refused measurement otherwise, the last effort again.
        """
        dt = self._sample_time(stamp)
        setpoint = self._select_setpoint(stamp)
        try:
            output = self.controller.update(measurement, setpoint, dt)
        except MissingAccelerationError as error:
            self.controller.hold(str(error))
            self._logger.error(f'{self._prefix}{error}; holding')
            output = self.controller.update(measurement, setpoint, dt)
        except MeasurementError as error:
            self.controller.hold(str(error))
            self._logger.error(f'{self._prefix}{error}; holding, last effort repeated',
                               throttle_duration_sec=1.0)
            return self.last_effort
        self.last_stamp = stamp
        self.last_effort = output.effort
        self._publish_state(header, stamp, measurement, output)
        return output.effort

    def check_inputs(self, now: float, clock: float | None) -> None:
        """Check the inputs at steady time ``now`` [s]; hold on a stale one.

        ``clock``: the ROS clock [s] in sim time, None on the wall clock.
        """
        stale = self.watchdog.check(now, clock)
        if stale.any and not self.stale.any:
            self._logger.warning(f'{self._prefix}input stale: {stale.reason}; holding')
        elif self.stale.any and not stale.any:
            self._logger.info(f'{self._prefix}inputs fresh again; holding until the next '
                              'mode command')
        self.stale = stale
        if stale.any:
            self.controller.hold(f'input stale: {stale.reason}')
            if stale.state:
                self._publish_stale_report()

    # ------------------------------------------------------------------------- helpers
    def _sample_time(self, stamp: float) -> float:
        nominal = self._settings.sample_time
        if self.last_stamp is None:
            return nominal
        if stamp < self.last_stamp:
            self._logger.warning(f'{self._prefix}joint_states stamp went backwards '
                                 '(plant reset?)')
            return nominal
        return stamp - self.last_stamp

    def _select_setpoint(self, stamp: float) -> Setpoint | None:
        selected = self._setpoints.select(stamp) if self.controller.mode.tracks_setpoints \
            else None
        self._pacing.used(stamp, None if selected is None else selected[0])
        if selected is None:
            return None
        lag = self.watchdog.setpoint_lag(stamp, selected[0])
        if lag:
            self._pacing.reset()
            self.setpoint_lagging = True
            self.controller.hold(f'setpoint stream stale: {lag}')
            self._logger.warning(f'{self._prefix}setpoint stream stale: {lag}; holding')
            return None
        return carry_forward(selected[1], stamp - selected[0],
                             self._settings.control.setpoint_extrapolation,
                             self._settings.drive(self.controller.role))

    def _publish_state(self, header, stamp: float, measurement: Measurement,
                       out: ControlOutput) -> None:
        period = 1.0 / self._settings.control.state_rate
        if self._last_state_publish is not None and \
                0.0 <= stamp - self._last_state_publish < period - 1e-9:
            return
        self._last_state_publish = stamp
        # One message object is reused: constructing it costs more than the control law.
        state = self._state_msg
        state.header.stamp = header.stamp
        state.role = out.role
        state.mode = int(out.mode)
        state.position_setpoint = float(out.reference.position)
        state.velocity_setpoint = float(out.reference.velocity)
        state.acceleration_setpoint = float(out.reference.acceleration)
        state.position = float(measurement.position)
        state.velocity = float(measurement.velocity)
        state.acceleration = float(measurement.acceleration or 0.0)
        state.position_error = float(out.position_error)
        state.feedforward_effort = float(out.feedforward)
        state.proportional_effort = float(out.proportional)
        state.integral_effort = float(out.integral)
        state.derivative_effort = float(out.derivative)
        state.acceleration_feedback_effort = float(out.acceleration_feedback)
        state.friction_compensation_effort = float(out.friction_compensation)
        state.effort = float(out.effort)
        state.saturated = bool(out.saturated)
        state.stale = self.stale.any or self.setpoint_lagging
        self._state_pub.publish(state)

    def _publish_stale_report(self) -> None:
        last = self.controller.last_output
        state = ControllerState()
        if self.last_stamp is not None:  # the controller's time is the state stream's
            state.header.stamp.sec = int(self.last_stamp)
            state.header.stamp.nanosec = \
                int(round((self.last_stamp % 1.0) * 1e9)) % 1_000_000_000
        state.joint_name = self.joint
        state.role = self.controller.role
        state.mode = int(self.controller.mode)
        if last is not None:
            state.position_setpoint = float(last.reference.position)
            state.effort = float(last.effort)
        state.stale = True
        self._state_pub.publish(state)
