"""rclpy node of one joint controller: messages, parameters and clocks around the core.

Run one per physical joint (``joint_name`` parameter), in the robot's namespace::

    ros2 run walker_control joint_controller_node --ros-args -r __ns:=/walker
        -p joint_name:=a_yaw_joint --params-file walker.yaml      (one command line)

The node is named ``controller_<joint without _joint>`` (``controller_a_yaw``) unless remapped.
Topics (relative to the namespace; QoS as in docs/architecture.md):

* subscribes ``joint_states`` (sensor_msgs/JointState; best effort, keep last 1),
  ``joint_accelerations`` (walker_msgs/JointAccelerations; best effort, keep last 1),
  ``controllers/<joint>/setpoint`` (walker_msgs/JointCommand; reliable, keep last 10),
  ``control_mode`` (walker_msgs/ControlMode; reliable, transient local, depth 1);
* publishes, for every joint state, ``effort_commands`` (sensor_msgs/JointState with this
  joint's name and effort, stamped with the state's stamp; reliable, keep last 10) and
  ``controllers/<joint>/state`` (walker_msgs/ControllerState; reliable, keep last 10).

No control math here: :class:`walker_control.core.joint_controller.JointController` computes.
"""

from __future__ import annotations

import sys

import rclpy
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.clock import Clock, ClockType
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from walker_msgs.msg import ControlMode, ControllerState, JointAccelerations, JointCommand

from walker_core.joint_roles import GRIPPERS, PHYSICAL_JOINT_NAMES, role_of_joint
from walker_core.node_parameters import declare_section, guard_section_updates
from walker_core.parameter_schema import ParameterError
from walker_core.realtime import log_realtime_request
from walker_core.spinning import init_node_process, spin_nodes
from walker_control.core.config import ControllerSettings
from walker_control.core.inputs import (
    InputWatchdog, Resubscription, Setpoint, SetpointBuffer, SetpointError, StaleInputs,
    carry_forward, validate_setpoint)
from walker_control.core.joint_controller import (
    ControlOutput, JointController, Measurement, MeasurementError, MissingAccelerationError,
    RoleChangeError)
from walker_control.core.modes import Mode

__all__ = ['STATE_QOS', 'COMMAND_QOS', 'MODE_QOS', 'JointControllerNode', 'default_node_name',
           'main']

STATE_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                       reliability=ReliabilityPolicy.BEST_EFFORT,
                       durability=DurabilityPolicy.VOLATILE)
COMMAND_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                         reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.VOLATILE)
# Depth 10: the HOLD that ends a step and the next step's mode (with the other base) are
# published milliseconds apart; a reader keeping one could lose the HOLD and refuse the swap.
MODE_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                      reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL)
_WATCHDOG_CHECKS_PER_TIMEOUT = 4
# A stream silent for this many of its timeouts has its subscription made anew, and again
# as often while the silence lasts (see Resubscription): 2 s by default, the supervisor's
# watchdog, so that a publisher merely stalled by a loaded machine is not matched anew
# (re-matching would lengthen the stall) while a walker held on a silent input has a fresh
# subscription by the time it is resumed.
_RESUBSCRIBE_AFTER_TIMEOUTS = 4.0


def _seconds(stamp) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


def default_node_name(argv: list[str]) -> str:
    """Name the node ``controller_<joint>`` from a ``-p joint_name:=...`` argument, if any."""
    for flag, value in zip(argv, argv[1:], strict=False):
        if flag in ('-p', '--param') and value.startswith('joint_name:='):
            joint = value.split(':=', 1)[1]
            if joint in PHYSICAL_JOINT_NAMES:
                return 'controller_' + joint.removesuffix('_joint')
    return 'joint_controller'


class JointControllerNode(Node):
    """One joint's controller over DDS (see the module docstring for its interfaces).

    Raises
    ------
    ValueError
        If ``joint_name`` is not a physical joint.
    ParameterError
        If the parameters are invalid or fail the stability check (refuses to start).
    """

    def __init__(self, node_name: str = 'joint_controller', **kwargs) -> None:
        super().__init__(node_name, **kwargs)
        joint = self.declare_parameter(
            'joint_name', '', ParameterDescriptor(
                description='physical joint this controller drives (one of: '
                            + ', '.join(PHYSICAL_JOINT_NAMES) + ')', read_only=True)).value
        if joint not in PHYSICAL_JOINT_NAMES:
            raise ValueError(f'parameter joint_name = {joint!r} is not a joint of the walker: '
                             f'expected one of {", ".join(PHYSICAL_JOINT_NAMES)}')
        self._joint = joint
        self._settings = declare_section(self, ControllerSettings)
        guard_section_updates(self, ControllerSettings, '', lambda: self._settings,
                              self._apply_settings)
        self._controller = JointController(self._settings, joint, 'a')
        self._setpoints = SetpointBuffer()
        control = self._settings.control
        self._watchdog = InputWatchdog(control.state_timeout, control.setpoint_timeout)
        self._state_resubscription = Resubscription(
            _RESUBSCRIBE_AFTER_TIMEOUTS * control.state_timeout)
        self._setpoint_resubscription = Resubscription(
            _RESUBSCRIBE_AFTER_TIMEOUTS * control.setpoint_timeout)
        self._stale = StaleInputs()
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._names: tuple[str, ...] = ()
        self._indices: list[int] = []
        self._acceleration_names: tuple[str, ...] = ()
        self._acceleration_index = -1
        self._acceleration: tuple[float, float] | None = None
        self._last_stamp: float | None = None
        self._last_state_publish: float | None = None  # [s] stamp of the last ControllerState
        self._last_effort: JointState | None = None
        self._setpoint_lagging = False
        self._effort_msg = JointState(name=[joint])
        self._state_msg = ControllerState(joint_name=joint)

        # QoS event handlers (incompatible QoS or type warnings) stay on the low-rate topics;
        # on the control-rate ones each handler would cost the executor on every wake-up.
        quiet_pub = PublisherEventCallbacks(use_default_callbacks=False)
        self._effort_pub = self.create_publisher(JointState, 'effort_commands', COMMAND_QOS,
                                                 event_callbacks=quiet_pub)
        self._state_pub = self.create_publisher(ControllerState, f'controllers/{joint}/state',
                                                COMMAND_QOS, event_callbacks=quiet_pub)
        # The executor serves ready subscriptions in creation order: the mode, the setpoint and
        # the acceleration that arrived with a state are taken before the state itself.
        self.create_subscription(ControlMode, 'control_mode', self._on_control_mode, MODE_QOS)
        self._setpoint_sub = self._subscribe_setpoints()
        self._acceleration_sub = None
        self._update_acceleration_subscription()
        self._state_sub = self._subscribe_states()
        self._watchdog_timer = self._create_watchdog_timer()
        self.get_logger().info(
            f'controlling {joint} (role J{self._controller.role} with base gripper a) at '
            f'{self._settings.timing.control_rate:g} Hz; holding until a mode is commanded')

    def request_realtime_scheduling(self) -> bool:
        """Ask for ``SCHED_FIFO`` (``timing.realtime_priority``) on the wall clock, and log it.

        Called by :func:`main`, for the process the node owns: a node built inside another
        process (a composed graph, a test) leaves that process's scheduling alone. The
        controller runs on the plant's stamps and cannot tell the clock mode: with
        ``use_sim_time`` true, or ``timing.realtime_priority`` 0 (what a sim-time graph of
        ``walker_bringup`` gives it), nothing is asked.
        """
        if self.get_parameter('use_sim_time').value:
            return False
        return log_realtime_request(self.get_logger(), self._settings.timing.realtime_priority)

    # ------------------------------------------------------------------------- parameters
    def _create_watchdog_timer(self):
        control = self._settings.control
        period = min(control.state_timeout, control.setpoint_timeout) \
            / _WATCHDOG_CHECKS_PER_TIMEOUT
        return self.create_timer(period, self._on_watchdog, clock=self._steady)

    def _subscribe_setpoints(self):
        return self.create_subscription(JointCommand, f'controllers/{self._joint}/setpoint',
                                        self._on_setpoint, COMMAND_QOS)

    def _subscribe_states(self):
        return self.create_subscription(
            JointState, 'joint_states', self._on_joint_state, STATE_QOS,
            event_callbacks=SubscriptionEventCallbacks(use_default_callbacks=False))

    def _resubscribe_silent_streams(self, now: float) -> None:
        """Make anew the subscription of a stream silent for long (see Resubscription)."""
        if self._state_resubscription.due(now, self._watchdog.last_state):
            self.destroy_subscription(self._state_sub)
            self._state_sub = self._subscribe_states()
            self.get_logger().warning(
                f'no joint_states for {now - self._watchdog.last_state:.1f} s: subscription '
                'made anew (a restarted or resumed plant is matched again)')
        if self._setpoint_resubscription.due(now, self._watchdog.last_setpoint):
            # the state's subscription is made after it again: it stays last in the
            # executor's order (a setpoint that arrived with a state is taken first)
            self.destroy_subscription(self._setpoint_sub)
            self.destroy_subscription(self._state_sub)
            self._setpoint_sub = self._subscribe_setpoints()
            self._state_sub = self._subscribe_states()
            self.get_logger().warning(
                f'no setpoint for {now - self._watchdog.last_setpoint:.1f} s while tracking: '
                'subscription made anew')

    def _update_acceleration_subscription(self) -> None:
        """Subscribe to joint_accelerations only while a role of this joint feeds it back."""
        roles = {role_of_joint(self._joint, base) for base in GRIPPERS}
        needed = any(self._settings.control.coarse.acceleration_feedback[role - 1] > 0.0
                     for role in roles)
        if needed and self._acceleration_sub is None:
            self._acceleration_sub = self.create_subscription(
                JointAccelerations, 'joint_accelerations', self._on_accelerations, STATE_QOS,
                event_callbacks=SubscriptionEventCallbacks(use_default_callbacks=False))
        elif not needed and self._acceleration_sub is not None:
            self.destroy_subscription(self._acceleration_sub)
            self._acceleration_sub = None
            self._acceleration = None

    def _apply_settings(self, settings: ControllerSettings) -> None:
        self._settings = settings
        self._controller.apply_settings(settings)
        self._update_acceleration_subscription()
        self._watchdog.state_timeout = settings.control.state_timeout
        self._watchdog.setpoint_timeout = settings.control.setpoint_timeout
        self._state_resubscription.after = \
            _RESUBSCRIBE_AFTER_TIMEOUTS * settings.control.state_timeout
        self._setpoint_resubscription.after = \
            _RESUBSCRIBE_AFTER_TIMEOUTS * settings.control.setpoint_timeout
        self.destroy_timer(self._watchdog_timer)
        self._watchdog_timer = self._create_watchdog_timer()
        self.get_logger().info('controller parameters updated (stability check passed)')

    # -------------------------------------------------------------------------- callbacks
    def _on_control_mode(self, msg: ControlMode) -> None:
        controller = self._controller
        before = (controller.mode, controller.base_gripper)
        try:
            mode = Mode(msg.mode)
            controller.command(mode, msg.base_gripper or None)
        except RoleChangeError as error:
            controller.hold(str(error))
            self.get_logger().error(f'{error}; holding')
            return
        except ValueError as error:
            self.get_logger().error(f'control_mode refused ({error}); nothing changed')
            return
        self._setpoint_lagging = False
        if (controller.mode, controller.base_gripper) != before:
            self._setpoints.clear()
            self.get_logger().info(f'mode {controller.mode.name}, base gripper '
                                   f'{controller.base_gripper}, role J{controller.role}')
        self._watchdog.expect_setpoints(mode.tracks_setpoints)
        # Judge the inputs again now: the next states must not report a staleness that this
        # command has ended (the supervisor would take it for a fault of the motion it starts).
        self._stale = self._watchdog.check(self._steady.now().nanoseconds * 1e-9)

    def _on_setpoint(self, msg: JointCommand) -> None:
        try:
            if msg.joint_name not in ('', self._joint):
                raise SetpointError(f'setpoint for {msg.joint_name!r} on the topic of '
                                    f'{self._joint}')
            setpoint = validate_setpoint(
                Setpoint(msg.position, msg.velocity, msg.acceleration, msg.effort),
                self._settings.drive(self._controller.role), self._joint)
        except SetpointError as error:
            self._controller.hold(f'setpoint refused: {error}')
            self.get_logger().error(f'{error}; holding')
            return
        stamp = _seconds(msg.header.stamp)
        if stamp == 0.0:  # unstamped (an operator's command): it applies from the next state
            stamp = self._last_stamp or 0.0
        self._setpoints.add(stamp, setpoint)
        self._setpoint_lagging = False
        self._watchdog.setpoint_received(self._steady.now().nanoseconds * 1e-9)

    def _on_accelerations(self, msg: JointAccelerations) -> None:
        names = tuple(msg.name)
        if names != self._acceleration_names:
            self._acceleration_names = names
            self._acceleration_index = names.index(self._joint) if self._joint in names else -1
        if 0 <= self._acceleration_index < len(msg.acceleration):
            self._acceleration = (_seconds(msg.header.stamp),
                                  msg.acceleration[self._acceleration_index])

    def _on_joint_state(self, msg: JointState) -> None:
        self._watchdog.state_received(self._steady.now().nanoseconds * 1e-9)
        stamp = _seconds(msg.header.stamp)
        if stamp == self._last_stamp and self._last_effort is not None:
            self._effort_pub.publish(self._last_effort)  # the plant asked again
            return
        measurement = self._measurement(msg, stamp)
        if measurement is None:
            return
        dt = self._sample_time(stamp)
        setpoint = self._select_setpoint(stamp)
        try:
            output = self._controller.update(measurement, setpoint, dt)
        except MissingAccelerationError as error:
            self._controller.hold(str(error))
            self.get_logger().error(f'{error}; holding')
            output = self._controller.update(measurement, setpoint, dt)
        except MeasurementError as error:
            self._controller.hold(str(error))
            self.get_logger().error(f'{error}; holding, last effort repeated',
                                    throttle_duration_sec=1.0)
            if self._last_effort is not None:
                self._last_effort.header.stamp = msg.header.stamp
                self._effort_pub.publish(self._last_effort)
            return
        self._last_stamp = stamp
        self._publish(msg, measurement, output)

    def _on_watchdog(self) -> None:
        now = self._steady.now().nanoseconds * 1e-9
        stale = self._watchdog.check(now)
        if stale.any and not self._stale.any:
            self.get_logger().warning(f'input stale: {stale.reason}; holding')
        elif self._stale.any and not stale.any:
            self.get_logger().info('inputs fresh again; holding until the next mode command')
        self._stale = stale
        if stale.any:
            self._controller.hold(f'input stale: {stale.reason}')
            if stale.state:
                self._publish_stale_report()
            self._resubscribe_silent_streams(now)

    # ---------------------------------------------------------------------------- helpers
    def _measurement(self, msg: JointState, stamp: float) -> Measurement | None:
        names = tuple(msg.name)
        if names != self._names:
            missing = [j for j in PHYSICAL_JOINT_NAMES if j not in names]
            if missing:
                self.get_logger().error(
                    f'joint_states lacks {", ".join(missing)}; state ignored',
                    throttle_duration_sec=1.0)
                return None
            self._names = names
            self._indices = [names.index(j) for j in PHYSICAL_JOINT_NAMES]
        if len(msg.position) != len(names) or len(msg.velocity) != len(names):
            self.get_logger().error('joint_states needs a position and a velocity per joint; '
                                    'state ignored', throttle_duration_sec=1.0)
            return None
        positions = [msg.position[i] for i in self._indices]
        i = self._indices[PHYSICAL_JOINT_NAMES.index(self._joint)]
        acceleration = None
        if self._acceleration is not None \
                and stamp - self._acceleration[0] <= self._settings.control.state_timeout:
            acceleration = self._acceleration[1]
        return Measurement(msg.position[i], msg.velocity[i], acceleration, positions)

    def _sample_time(self, stamp: float) -> float:
        nominal = self._settings.sample_time
        if self._last_stamp is None:
            return nominal
        if stamp < self._last_stamp:
            self.get_logger().warning('joint_states stamp went backwards (plant reset?)')
            return nominal
        return stamp - self._last_stamp

    def _select_setpoint(self, stamp: float) -> Setpoint | None:
        if not self._controller.mode.tracks_setpoints:
            return None
        selected = self._setpoints.select(stamp)
        if selected is None:
            return None
        lag = self._watchdog.setpoint_lag(stamp, selected[0])
        if lag:
            self._setpoint_lagging = True
            self._controller.hold(f'setpoint stream stale: {lag}')
            self.get_logger().warning(f'setpoint stream stale: {lag}; holding')
            return None
        return carry_forward(selected[1], stamp - selected[0],
                             self._settings.control.setpoint_extrapolation,
                             self._settings.drive(self._controller.role))

    def _publish(self, msg: JointState, measurement: Measurement, out: ControlOutput) -> None:
        # One message object of each kind is reused: constructing them costs more than the
        # control law.
        effort = self._effort_msg
        effort.header.stamp = msg.header.stamp
        effort.header.frame_id = msg.header.frame_id
        effort.effort = [out.effort]
        self._effort_pub.publish(effort)
        self._last_effort = effort
        stamp = _seconds(msg.header.stamp)
        period = 1.0 / self._settings.control.state_rate
        if self._last_state_publish is not None and \
                0.0 <= stamp - self._last_state_publish < period - 1e-9:
            return
        self._last_state_publish = stamp
        state = self._state_msg
        state.header.stamp = msg.header.stamp
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
        state.stale = self._stale.any or self._setpoint_lagging
        self._state_pub.publish(state)

    def _publish_stale_report(self) -> None:
        last = self._controller.last_output
        state = ControllerState()
        if self._last_stamp is not None:  # the controller's time is the state stream's
            state.header.stamp.sec = int(self._last_stamp)
            state.header.stamp.nanosec = int(round((self._last_stamp % 1.0) * 1e9)) % 1_000_000_000
        state.joint_name = self._joint
        state.role = self._controller.role
        state.mode = int(self._controller.mode)
        if last is not None:
            state.position_setpoint = float(last.reference.position)
            state.effort = float(last.effort)
        state.stale = True
        self._state_pub.publish(state)


def main(args: list[str] | None = None) -> int:
    """Run one joint controller until interrupted; exit code 2 when it refuses to start."""
    argv = sys.argv if args is None else args
    stop = init_node_process(argv)
    node = None
    code = 0
    try:
        node = JointControllerNode(default_node_name(argv))
        node.request_realtime_scheduling()
        spin_nodes(node, stop=stop)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except (ParameterError, ValueError) as error:
        print(f'[joint_controller_node] refusing to start: {error}', file=sys.stderr,
              flush=True)
        code = 2
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return code


if __name__ == '__main__':
    sys.exit(main())
