"""One joint's controller inside a controller node: its core, its topics, its log.

A controller node drives one joint (``joint_controller_node``) or several
(``joint_controllers_node``); either way each joint has a :class:`JointChannel`: the joint's
:class:`~walker_control.core.channel.ControllerChannel` (the controller core with its setpoint
buffer, pacing and watchdog, where every decision is made), its setpoint subscription and its
``controllers/<joint>/state`` publisher. The node owns what the joints share: the
``joint_states``, ``joint_accelerations`` and ``control_mode`` subscriptions, the
``effort_commands`` publisher and the watchdog timer.

No decision here: the channel converts messages and calls the core.
"""

from __future__ import annotations

from rclpy.event_handler import PublisherEventCallbacks
from rclpy.node import Node
from walker_msgs.msg import ControlMode, ControllerState, JointCommand

from walker_runtime.qos import COMMAND_QOS, MODE_QOS, MODE_SUBSCRIPTION_QOS, SENSOR_QOS
from walker_runtime.watched_subscription import WatchedSubscription

from walker_control.core.channel import CLOCK_SLACK_PERIODS, ControllerChannel
from walker_control.core.config import ControllerSettings
from walker_control.core.inputs import Setpoint
from walker_control.core.joint_controller import ControlOutput, Measurement

__all__ = ['STATE_QOS', 'COMMAND_QOS', 'MODE_QOS', 'MODE_SUBSCRIPTION_QOS',
           'RESUBSCRIBE_AFTER_TIMEOUTS', 'JointChannel', 'CLOCK_SLACK_PERIODS', 'seconds',
           'give_trajectory']

#: joint_states and joint_accelerations: best effort, newest only (walker_runtime.qos)
STATE_QOS = SENSOR_QOS
# A stream silent for this many of its timeouts has its subscription made anew, and again
# as often while the silence lasts (see WatchedSubscription): 2 s by default, the supervisor's
# watchdog, so that a publisher merely stalled by a loaded machine is not matched anew
# (re-matching would lengthen the stall) while a walker held on a silent input has a fresh
# subscription by the time it is resumed.
RESUBSCRIBE_AFTER_TIMEOUTS = 4.0


def seconds(stamp) -> float:
    """Return a ``builtin_interfaces/Time`` as float seconds."""
    return stamp.sec + stamp.nanosec * 1e-9


def give_trajectory(channels: list[JointChannel], msg) -> bool:
    """Give a ``trajectory_msgs/JointTrajectory`` to each channel whose joint it names.

    Returns whether any channel was given it (each channel's core refuses a malformed one and
    logs why, :meth:`~walker_control.core.channel.ControllerChannel.take_trajectory`).
    """
    names = list(msg.joint_names)
    taking = [channel for channel in channels if channel.joint in names]
    if not taking:
        return False
    points = msg.points
    times = [seconds(point.time_from_start) for point in points]
    positions = [list(point.positions) for point in points]
    velocities = [list(point.velocities) for point in points]
    accelerations = [list(point.accelerations) for point in points]
    start = seconds(msg.header.stamp)
    for channel in taking:
        channel.core.take_trajectory(names, times, positions, velocities, accelerations, start)
    return True


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
        self.core = ControllerChannel(settings, joint, self._log)
        self._after_setpoint = after_setpoint
        self._state_msg = ControllerState(joint_name=joint)
        quiet = PublisherEventCallbacks(use_default_callbacks=False)
        self._state_pub = node.create_publisher(ControllerState, f'controllers/{joint}/state',
                                                COMMAND_QOS, event_callbacks=quiet)
        #: ``controllers/<joint>/setpoint``, made anew when silent while tracking (the node
        #: calls its ``check`` and keeps the order of its subscriptions)
        self.setpoint_subscription = WatchedSubscription(
            node, JointCommand, f'controllers/{joint}/setpoint', self._on_setpoint_message,
            COMMAND_QOS, after=RESUBSCRIBE_AFTER_TIMEOUTS * settings.control.setpoint_timeout,
            last_heard=lambda: self.core.watchdog.last_setpoint, steady_now=steady_now)

    def _log(self, level: str, text: str, throttle: float) -> None:
        # one call site per severity and throttling: rclpy's logger keys its filters by the
        # caller's line, and refuses another severity from the same line
        text = f'{self._prefix}{text}'
        logger = self._logger
        if level == 'error' and throttle > 0.0:
            logger.error(text, throttle_duration_sec=throttle)
        elif level == 'error':
            logger.error(text)
        elif level == 'warning':
            logger.warning(text)
        else:
            logger.info(text)

    @property
    def controller(self):
        """The joint's :class:`~walker_control.core.joint_controller.JointController`."""
        return self.core.controller

    @property
    def watchdog(self):
        """The joint's :class:`~walker_control.core.inputs.InputWatchdog`."""
        return self.core.watchdog

    @property
    def stale(self):
        """The inputs found stale at the last check."""
        return self.core.stale

    @property
    def last_stamp(self) -> float | None:
        """[s] Stamp of the last state answered."""
        return self.core.last_stamp

    # ------------------------------------------------------------------------- settings

    def take_setpoints(self) -> None:
        """Take the setpoints already received that no callback has had yet.

        For a caller that needs them now, between two turns of its executor (the plant
        handing a state over by call, :meth:`ControllerNode.take_state`): each taken here
        costs a take from the middleware, not a turn of the executor and a callback; the
        executor then finds nothing left to take for them.
        """
        subscription = self.setpoint_subscription.subscription
        while subscription is not None:
            with subscription.handle:
                taken = subscription.handle.take_message(JointCommand, False)
            if taken is None:
                return
            self.on_setpoint(taken[0])

    def apply_settings(self, settings: ControllerSettings) -> None:
        """Take validated new settings (the node's parameters changed)."""
        self.core.apply_settings(settings)
        self.setpoint_subscription.after = \
            RESUBSCRIBE_AFTER_TIMEOUTS * settings.control.setpoint_timeout

    # -------------------------------------------------------------------------- inputs
    def on_control_mode(self, msg: ControlMode) -> None:
        """Take a mode command (the node passes each one to every channel)."""
        self.core.command_mode(msg.mode, msg.base_gripper, self._steady_now(),
                               self._clock_now())

    def _on_setpoint_message(self, msg: JointCommand) -> None:
        self.on_setpoint(msg)
        if self._after_setpoint is not None:
            self._after_setpoint()

    def on_setpoint(self, msg: JointCommand) -> None:
        """Take one setpoint of the joint's stream; refuse (and hold) an invalid one."""
        self.core.take_setpoint(
            msg.joint_name, Setpoint(msg.position, msg.velocity, msg.acceleration, msg.effort),
            seconds(msg.header.stamp), self._steady_now())

    def take_setpoint_values(self, stamp: float, position: float, velocity: float,
                             acceleration: float) -> None:
        """Take one setpoint handed over by call, stamped ``stamp`` [s], as :meth:`on_setpoint`.

        [rad, rad/s, rad/s^2]; no feed-forward effort (a stream's setpoints carry none).
        """
        self.core.take_setpoint(self.joint, Setpoint(position, velocity, acceleration, 0.0),
                                stamp, self._steady_now())

    # --------------------------------------------------------------------------- update
    def owes_setpoint(self, stamp: float) -> bool:
        """Say whether the state stamped ``stamp`` [s] lacks the setpoint its stream owes it."""
        return self.core.owes_setpoint(stamp)

    def answer(self, header, stamp: float, measurement: Measurement) -> float | None:
        """Compute the joint's effort [N*m] for a state stamped ``stamp`` [s].

        Publishes the joint's ``ControllerState`` at ``control.state_rate``. Returns None
        when the measurement is refused and the joint has never answered (the controller
        holds); after a refused measurement otherwise, the last effort again.
        """
        output = self.core.answer(stamp, measurement)
        if output is None:
            return self.core.last_effort
        if self.core.state_due(stamp):
            self._publish_state(header, measurement, output)
        return output.effort

    def check_inputs(self, now: float, clock: float | None) -> None:
        """Check the inputs at steady time ``now`` [s]; hold on a stale one.

        ``clock``: the ROS clock [s] in sim time, None on the wall clock.
        """
        if self.core.check_inputs(now, clock).state:
            self._publish_stale_report()

    # ------------------------------------------------------------------------- helpers
    def _publish_state(self, header, measurement: Measurement, out: ControlOutput) -> None:
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
        state.stale = self.core.reports_stale
        self._state_pub.publish(state)

    def _publish_stale_report(self) -> None:
        controller = self.core.controller
        last = controller.last_output
        state = ControllerState()
        last_stamp = self.core.last_stamp
        if last_stamp is not None:  # the controller's time is the state stream's
            state.header.stamp.sec = int(last_stamp)
            state.header.stamp.nanosec = int(round((last_stamp % 1.0) * 1e9)) % 1_000_000_000
        state.joint_name = self.joint
        state.role = controller.role
        state.mode = int(controller.mode)
        if last is not None:
            state.position_setpoint = float(last.reference.position)
            state.effort = float(last.effort)
        state.stale = True
        self._state_pub.publish(state)
