"""rclpy node of one joint controller: messages, parameters and clocks around the core.

Run one per physical joint (``joint_name`` parameter), in the robot's namespace::

    ros2 run walker_control joint_controller_node --ros-args -r __ns:=/walker
        -p joint_name:=a_yaw_joint --params-file walker.yaml      (one command line)

The node is named ``controller_<joint without _joint>`` (``controller_a_yaw``) unless remapped.
Topics (relative to the namespace; QoS as in docs/architecture.md):

* subscribes ``joint_states`` (sensor_msgs/JointState; best effort, keep last 1),
  ``joint_accelerations`` (walker_msgs/JointAccelerations; best effort, keep last 1),
  ``controllers/joint_trajectory`` (trajectory_msgs/JointTrajectory, whole trajectories for
  any of the joints, held and sampled at every state; reliable, keep last 10),
  ``controllers/<joint>/setpoint`` (walker_msgs/JointCommand; reliable, keep last 10),
  ``control_mode`` (walker_msgs/ControlMode; reliable, transient local, depth 10);
* publishes, for every joint state, ``effort_commands`` (sensor_msgs/JointState with this
  joint's name and effort, stamped with the state's stamp; reliable, keep last 10) and
  ``controllers/<joint>/state`` (walker_msgs/ControllerState; reliable, keep last 10).

:class:`ControllerNode` is the node of one or several joints (each a
:class:`~walker_control.joint_channel.JointChannel`); :class:`JointControllerNode` is it for one
joint, ``joint_controllers_node`` for several in one process. No control math here:
:class:`walker_control.core.joint_controller.JointController` computes.
"""

from __future__ import annotations

import math
import sys

from rcl_interfaces.msg import ParameterDescriptor
from rclpy.clock import Clock, ClockType
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.exceptions import ParameterException
from rclpy.node import Node
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory
from walker_msgs.msg import ControlMode, JointAccelerations

from walker_core.joint_roles import GRIPPERS, PHYSICAL_JOINT_NAMES, role_of_joint
from walker_core.mode_command import mode_command_refusal
from walker_runtime.node_parameters import declare_section, guard_section_updates
from walker_runtime.realtime import log_realtime_request
from walker_runtime.node_main import run_node
from walker_runtime.watched_subscription import WatchedSubscription
from walker_control.core.config import ControllerSettings
from walker_control.core.joint_controller import Measurement
from walker_control.core.joint_order import JointOrder, check_joint_names, default_node_name
from walker_control.joint_channel import (
    COMMAND_QOS, MODE_QOS, MODE_SUBSCRIPTION_QOS, RESUBSCRIBE_AFTER_TIMEOUTS, STATE_QOS,
    JointChannel, give_trajectory, seconds)

__all__ = ['STATE_QOS', 'COMMAND_QOS', 'MODE_QOS', 'ControllerNode', 'JointControllerNode',
           'default_node_name', 'run_controller_node', 'main']

_WATCHDOG_CHECKS_PER_TIMEOUT = 4


class ControllerNode(Node):
    """Controllers of one or more joints over DDS: one state in, one effort message out.

    The joints' controllers share the node's ``joint_states``, ``joint_accelerations`` and
    ``control_mode`` subscriptions and answer each state with one ``effort_commands`` message
    naming every joint of the node; each joint keeps its own setpoint topic, state topic and
    watchdog (:class:`~walker_control.joint_channel.JointChannel`). Subclasses choose the
    joints (:meth:`_declare_joints`).

    Raises
    ------
    ValueError
        If a joint is not a physical joint of the walker, or a joint is named twice.
    ParameterError
        If the parameters are invalid or fail the stability check (refuses to start).
    """

    def __init__(self, node_name: str, **kwargs) -> None:
        super().__init__(node_name, **kwargs)
        try:
            joints = self._declare_joints()
        except ParameterException as error:  # a value of the wrong type, say
            raise ValueError(f'parameter {self._joints_parameter} refused: {error}') from None
        check_joint_names(joints, self._joints_parameter)
        self._joints = tuple(joints)
        self._settings = declare_section(self, ControllerSettings)
        guard_section_updates(self, ControllerSettings, '', lambda: self._settings,
                              self._apply_settings)
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        several = len(self._joints) > 1
        # The executor serves ready subscriptions in creation order: the mode, the setpoints
        # and the acceleration that arrived with a state are taken before the state itself.
        self.create_subscription(ControlMode, 'control_mode', self._on_control_mode,
                                 MODE_SUBSCRIPTION_QOS)
        self.create_subscription(JointTrajectory, 'controllers/joint_trajectory',
                                 self._on_trajectory, COMMAND_QOS)
        self._channels = [JointChannel(self, joint, self._settings, self._steady_now,
                                       self._sim_clock_now, f'{joint}: ' if several else '',
                                       after_setpoint=self._answer_waiting_state)
                          for joint in self._joints]
        self._order = JointOrder(self._joints)
        self._accelerations: tuple[float, list[float | None]] | None = None
        self._last_stamp: float | None = None
        self._last_effort: JointState | None = None
        # A state waiting for the setpoints its stream owes it (sim time), and since when [s]
        self._waiting: JointState | None = None
        self._waiting_stamp: float | None = None
        self._waiting_since = 0.0
        self._effort_msg = JointState(name=list(self._joints))
        # QoS event handlers (incompatible QoS or type warnings) stay on the low-rate topics;
        # on the control-rate ones each handler would cost the executor on every wake-up.
        self._effort_pub = self.create_publisher(
            JointState, 'effort_commands', COMMAND_QOS,
            event_callbacks=PublisherEventCallbacks(use_default_callbacks=False))
        # With the plant in this process, in sim time: where the answers go, by a call
        # (see answer_plant_directly); None: published on effort_commands.
        self._effort_sink = None
        self._acceleration_sub = None
        self._update_acceleration_subscription()
        # joint_states, made anew when silent (None while the plant hands states over by call)
        self._states: WatchedSubscription | None = WatchedSubscription(
            self, JointState, 'joint_states', self._on_joint_state, STATE_QOS,
            after=RESUBSCRIBE_AFTER_TIMEOUTS * self._settings.control.state_timeout,
            last_heard=self._last_state_heard, steady_now=self._steady_now)
        self._watchdog_timer = self._create_watchdog_timer()
        roles = ', '.join(f'{joint} (J{channel.controller.role})'
                          for joint, channel in zip(self._joints, self._channels, strict=True))
        self.get_logger().info(
            f'controlling {roles} with base gripper a at '
            f'{self._settings.timing.control_rate:g} Hz; holding until a mode is commanded')

    _joints_parameter = 'joint_name'

    def _declare_joints(self) -> list[str]:
        raise NotImplementedError

    @property
    def joints(self) -> tuple[str, ...]:
        """The joints this node controls."""
        return self._joints

    def request_realtime_scheduling(self) -> bool:
        """Ask for ``SCHED_FIFO`` (``timing.realtime_priority``) on the wall clock, and log it.

        Called by :func:`run_controller_node`, for the process the node owns: a node built
        inside another process (a composed graph, a test) leaves that process's scheduling
        alone. With ``use_sim_time`` true (what a sim-time graph of ``walker_bringup`` gives
        it: lock-stepped, no deadlines), or ``timing.realtime_priority`` 0, nothing is asked.
        """
        if self.get_parameter('use_sim_time').value:
            return False
        return log_realtime_request(self.get_logger(), self._settings.timing.realtime_priority)

    def _steady_now(self) -> float:
        return self._steady.now().nanoseconds * 1e-9

    def _sim_clock_now(self) -> float | None:
        """Return the simulated clock's time [s] with ``use_sim_time``; None on the wall clock."""
        clock = self.get_clock()
        return clock.now().nanoseconds * 1e-9 if clock.ros_time_is_active else None

    def answer_plant_directly(self, effort_sink) -> None:
        """Take the plant's states by call and answer them by calling ``effort_sink``.

        For a plant in this process, in sim time (as Gazebo's ros2_control plugin runs its
        controllers inside the simulator): the plant calls :meth:`take_state` (and
        :meth:`take_accelerations` before it) with the messages it publishes, and each answer,
        the ``effort_commands`` message, goes to ``effort_sink(message)`` instead of DDS. The
        ``joint_states`` and ``joint_accelerations`` subscriptions are destroyed; setpoints,
        modes, the watchdogs and the controller states are as before.
        """
        self._effort_sink = effort_sink
        self._states.destroy()
        self._states = None
        if self._acceleration_sub is not None:
            self.destroy_subscription(self._acceleration_sub)
            self._acceleration_sub = None

    def take_state(self, msg: JointState) -> None:
        """Answer a joint state handed over by the plant (see :meth:`answer_plant_directly`).

        The setpoints received for it are taken first, directly: the plant hands states
        over between two turns of the process's executor, which would otherwise spend a
        turn on each of the five setpoint messages of every period before they count.
        """
        for channel in self._channels:
            channel.take_setpoints()
        self._on_joint_state(msg)

    def take_accelerations(self, msg: JointAccelerations) -> None:
        """Take the joint accelerations handed over with the next state."""
        self._on_accelerations(msg)

    def _send_effort(self, msg: JointState) -> None:
        if self._effort_sink is None:
            self._effort_pub.publish(msg)
        else:
            self._effort_sink(msg)

    # ------------------------------------------------------------------------- parameters
    def _create_watchdog_timer(self):
        control = self._settings.control
        period = min(control.state_timeout, control.setpoint_timeout,
                     control.sim_time_setpoint_wait or math.inf) / _WATCHDOG_CHECKS_PER_TIMEOUT
        return self.create_timer(period, self._on_watchdog, clock=self._steady)

    def _last_state_heard(self) -> float | None:
        """[s] steady time of the newest joint state any joint's watchdog has had."""
        return max((c.watchdog.last_state for c in self._channels
                    if c.watchdog.last_state is not None), default=None)

    def _resubscribe_silent_streams(self, now: float) -> None:
        """Make anew the subscription of a stream silent for long (see WatchedSubscription)."""
        if self._states is not None:
            self._states.check(now)
        renewed = [channel.setpoint_subscription.check(now) for channel in self._channels]
        if any(renewed) and self._states is not None:
            # the state's subscription is made after them again: it stays last in the
            # executor's order (a setpoint that arrived with a state is taken first)
            self._states.renew()

    def _update_acceleration_subscription(self) -> None:
        """Subscribe to joint_accelerations only while a role of a joint feeds it back."""
        gains = self._settings.control.coarse.acceleration_feedback
        needed = self._effort_sink is None and any(
            gains[role_of_joint(joint, base) - 1] > 0.0
            for joint in self._joints for base in GRIPPERS)
        if needed and self._acceleration_sub is None:
            self._acceleration_sub = self.create_subscription(
                JointAccelerations, 'joint_accelerations', self._on_accelerations, STATE_QOS,
                event_callbacks=SubscriptionEventCallbacks(use_default_callbacks=False))
        elif not needed and self._acceleration_sub is not None:
            self.destroy_subscription(self._acceleration_sub)
            self._acceleration_sub = None
            self._accelerations = None

    def _apply_settings(self, settings: ControllerSettings) -> None:
        self._settings = settings
        for channel in self._channels:
            channel.apply_settings(settings)
        self._update_acceleration_subscription()
        if self._states is not None:
            self._states.after = RESUBSCRIBE_AFTER_TIMEOUTS * settings.control.state_timeout
        self.destroy_timer(self._watchdog_timer)
        self._watchdog_timer = self._create_watchdog_timer()
        self.get_logger().info('controller parameters updated (stability check passed)')

    # -------------------------------------------------------------------------- callbacks
    def _on_control_mode(self, msg: ControlMode) -> None:
        refusal = mode_command_refusal(msg.commander, msg.base_gripper, self.get_namespace())
        if refusal:
            self.get_logger().error(f'{refusal}; nothing changed')
            return
        for channel in self._channels:
            channel.on_control_mode(msg)
        self._answer_waiting_state()

    def _on_trajectory(self, msg: JointTrajectory) -> None:
        """Give a whole trajectory to each joint of the node it names (others ignore it)."""
        if give_trajectory(self._channels, msg):
            self._answer_waiting_state()

    def _on_accelerations(self, msg: JointAccelerations) -> None:
        values = msg.acceleration
        self._accelerations = (seconds(msg.header.stamp),
                               [values[i] if 0 <= i < len(values) else None
                                for i in self._order.acceleration_indices(msg.name)])

    def _on_joint_state(self, msg: JointState) -> None:
        now = self._steady_now()
        stamp = seconds(msg.header.stamp)
        for channel in self._channels:
            channel.watchdog.state_received(now, stamp)
        if stamp == self._last_stamp and self._last_effort is not None:
            self._send_effort(self._last_effort)  # the plant asked again
            return
        if self._must_wait(stamp, now):
            self._waiting = msg
            return
        self._waiting = None
        self._answer(msg, stamp)

    def _must_wait(self, stamp: float, now: float) -> bool:
        """Say whether the state stamped ``stamp`` [s] waits for the setpoints owed to it.

        Only in sim time (``use_sim_time``), where the plant waits for the efforts: a state
        whose stream's setpoint has not come waits for it, for at most
        ``control.sim_time_setpoint_wait`` seconds of steady time, so that a slow planner
        slows the simulation instead of changing the motion. In real time a state never waits.
        """
        wait = self._settings.control.sim_time_setpoint_wait
        if wait <= 0.0 or not any(channel.owes_setpoint(stamp) for channel in self._channels) \
                or not self.get_parameter('use_sim_time').value:
            return False
        if stamp != self._waiting_stamp:
            self._waiting_stamp, self._waiting_since = stamp, now
        if now - self._waiting_since < wait:
            return True
        late = [c.joint for c in self._channels if c.owes_setpoint(stamp)]
        self.get_logger().warning(
            f'the state at t = {stamp:.3f} s waited {wait:g} s for the setpoint of '
            f'{", ".join(late)} from its stream: answered without it',
            throttle_duration_sec=1.0)
        return False

    def _answer_waiting_state(self) -> None:
        """Answer the state that waited for its setpoints, once they are in (or overdue)."""
        msg = self._waiting
        if msg is None:
            return
        stamp = seconds(msg.header.stamp)
        if self._must_wait(stamp, self._steady_now()):
            return
        self._waiting = None
        self._answer(msg, stamp)

    def _answer(self, msg: JointState, stamp: float) -> None:
        """Compute every joint's effort for the state ``msg`` and publish them together."""
        refusal = self._order.check_state(msg.name, len(msg.position), len(msg.velocity))
        if refusal:
            self.get_logger().error(refusal, throttle_duration_sec=1.0)
            return
        positions = [msg.position[i] for i in self._order.physical]
        accelerations = None
        if self._accelerations is not None \
                and stamp - self._accelerations[0] <= self._settings.control.state_timeout:
            accelerations = self._accelerations[1]
        names, efforts = [], []
        for k, channel in enumerate(self._channels):
            i = self._order.own[k]
            measurement = Measurement(msg.position[i], msg.velocity[i],
                                      accelerations[k] if accelerations else None, positions)
            effort = channel.answer(msg.header, stamp, measurement)
            if effort is not None:
                names.append(channel.joint)
                efforts.append(effort)
        if not efforts:
            return
        # One message object is reused: constructing it costs more than the control law.
        out = self._effort_msg
        if len(names) != len(out.name):
            out = JointState(name=names)
        out.header.stamp = msg.header.stamp
        out.header.frame_id = msg.header.frame_id
        out.effort = efforts
        self._send_effort(out)
        if len(efforts) == len(self._channels):
            self._last_stamp = stamp
            self._last_effort = out
        else:
            self._last_effort = None

    def _on_watchdog(self) -> None:
        now = self._steady_now()
        clock = self._sim_clock_now()
        for channel in self._channels:
            channel.check_inputs(now, clock)
        if any(channel.stale.any for channel in self._channels):
            self._resubscribe_silent_streams(now)
        self._answer_waiting_state()


class JointControllerNode(ControllerNode):
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

    def _declare_joints(self) -> list[str]:
        joint = self.declare_parameter(
            'joint_name', '', ParameterDescriptor(
                description='physical joint this controller drives (one of: '
                            + ', '.join(PHYSICAL_JOINT_NAMES) + ')', read_only=True)).value
        return [joint]


def run_controller_node(node_class, node_name: str, args: list[str] | None = None) -> int:
    """Run a controller node until interrupted; exit codes of :mod:`walker_runtime.node_main`."""
    return run_node(lambda: node_class(node_name), node_name,
                    sys.argv if args is None else args,
                    start=ControllerNode.request_realtime_scheduling)


def main(args: list[str] | None = None) -> int:
    """Run one joint controller until interrupted; exit code 2 when it refuses to start."""
    argv = sys.argv if args is None else args
    return run_controller_node(JointControllerNode, default_node_name(argv), argv)


if __name__ == '__main__':
    sys.exit(main())
