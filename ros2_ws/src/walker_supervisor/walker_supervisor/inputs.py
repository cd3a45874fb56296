"""What the supervisor hears, handed to the walk runner (ROS layer).

The plant's joint states (500 Hz), the tip pose and each controller's state are sampled at the
decision rate, not handled message by message: a Python callback per message would cost more
CPU than every decision the supervisor makes. The gripper states and the latched mode arrive by
callback. A source silent for long while its publisher is in the graph has its subscription
made anew, and again as often while the silence lasts, through the helper every reader of the
walker uses (:mod:`walker_runtime.watched_subscription`, silence as the walk runner's health
judges it): a controller process restarted after a crash, or a graph frozen and resumed, can
leave a subscription that no longer receives while its publisher lives on.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from walker_msgs.msg import ControllerState, ControlMode, GripperState, GripperStates

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_core.mode_command import mode_command_refusal
from walker_runtime.qos import COMMAND_QOS, LATCHED_QOS, MODE_SUBSCRIPTION_QOS, SENSOR_QOS
from walker_runtime.spinning import TopicSampler
from walker_runtime.watched_subscription import SampledSubscription, WatchedSubscription
from walker_supervisor.clocks import Clocks
from walker_supervisor.core.current_state import CurrentState
from walker_supervisor.core.process_deaths import ProcessDeaths
from walker_supervisor.core.runner import PLANT_GRIPPER_STATES, PLANT_JOINT_STATES, WalkRunner
from walker_supervisor.messages import (
    controller_report, gripper_position_errors, gripper_readings, joint_arrays, seconds,
    stamp_nanoseconds)

__all__ = ['SupervisorInputs', 'RESUBSCRIBE_AFTER_TIMEOUTS']

# Poses are kept between two decisions (at 100 Hz, two or three per 50 Hz tick) for the
# vibration figures.
_POSES = QoSProfile(depth=50, reliability=ReliabilityPolicy.BEST_EFFORT,
                    durability=DurabilityPolicy.VOLATILE, history=HistoryPolicy.KEEP_LAST)
_CONTROLLER_STATES = QoSProfile(depth=20, reliability=ReliabilityPolicy.RELIABLE,
                                durability=DurabilityPolicy.VOLATILE,
                                history=HistoryPolicy.KEEP_LAST)
#: A source silent for this many watchdog timeouts has its subscription made anew: the walker
#: is in safe hold after one timeout; a second tells a dead or restarted publisher from a stall
#: of a loaded machine.
RESUBSCRIBE_AFTER_TIMEOUTS = 2.0
_STATE_POLL = 0.0005  # [s] wall: how often a decision waiting for its state looks again


class SupervisorInputs:
    """The supervisor's subscriptions; they feed ``runner``, and ``execute`` its commands.

    Attributes
    ----------
    gripper_messages : dict of str to GripperState
        The newest state message of each gripper (an operator's gripper command answers it).
    deaths : ProcessDeaths
        The node deaths the bring-up reported on ``/diagnostics`` (the reason of a hold it
        then asks for).
    """

    def __init__(self, node: Node, runner: WalkRunner, clocks: Clocks,
                 execute: Callable[[list], None]) -> None:
        self._node, self._runner, self._clocks, self._execute = node, runner, clocks, execute
        self._sampler = TopicSampler(f'{node.get_name()}_sampler', node.get_namespace(),
                                     node.context)
        after = RESUBSCRIBE_AFTER_TIMEOUTS * runner.settings.watchdog_timeout
        logger = node.get_logger()

        def watch(name: str) -> dict:
            # silence as the runner's health judges it, on the supervisor's steady clock
            return {'after': after, 'label': name, 'steady_now': clocks.steady,
                    'last_heard': lambda: runner.health.last_heard(name)}
        self._joint_states = SampledSubscription(
            self._sampler, JointState, 'joint_states', SENSOR_QOS, logger=logger,
            **watch(PLANT_JOINT_STATES))
        self._tip_poses = self._sampler.subscribe(PoseStamped, 'tip_pose', _POSES)
        self._controllers = {
            joint: SampledSubscription(
                self._sampler, ControllerState, f'controllers/{joint}/state',
                _CONTROLLER_STATES, logger=logger, **watch(f'controller {joint}'))
            for joint in PHYSICAL_JOINT_NAMES}
        self._grippers = WatchedSubscription(
            node, GripperStates, 'gripper_states', self._on_grippers, LATCHED_QOS,
            **watch(PLANT_GRIPPER_STATES))
        self._watched = [self._joint_states, *self._controllers.values(), self._grippers]
        missing = set(runner.health.names) - {w.label for w in self._watched}
        if missing:
            raise RuntimeError(f'sources watched by the runner with no subscription: {missing}')
        self.gripper_messages: dict[str, GripperState] = {}
        self.current_state = CurrentState()
        self._newest_state: int | None = None  # [ns] stamp of the newest joint state taken
        node.create_subscription(ControlMode, 'control_mode', self._on_control_mode,
                                 MODE_SUBSCRIPTION_QOS)
        self.deaths = ProcessDeaths(node.get_namespace())
        node.create_subscription(DiagnosticArray, '/diagnostics', self._on_diagnostics,
                                 COMMAND_QOS)

    def set_watchdog_timeout(self, timeout: float) -> None:
        """Follow a new ``supervisor.watchdog_timeout`` [s] at once."""
        for watched in self._watched:
            watched.after = RESUBSCRIBE_AFTER_TIMEOUTS * timeout

    def sample(self, decision_time: int | None = None) -> None:
        """Hand the runner what the sampled subscriptions received since the last call.

        ``decision_time`` [ns] (sim time only): the joint state of that time is waited for
        first, a bounded wall time (:class:`~walker_supervisor.core.current_state.CurrentState`).
        """
        states = self._joint_states.take()
        if decision_time is not None:
            states = self._await_state(states, decision_time)
        if states:
            self._newest_state = stamp_nanoseconds(states[-1].header.stamp)
        runner, steady = self._runner, self._clocks.steady()
        if states:
            runner.joint_states(*joint_arrays(states[-1]), steady)
        for pose in self._sampler.take(self._tip_poses):
            p = pose.pose.position
            runner.tip_pose(seconds(pose.header.stamp), (p.x, p.y, p.z))
        reports = {}
        for joint, subscription in self._controllers.items():
            taken = subscription.take()
            if taken:
                reports[joint] = controller_report(taken[-1])
        self._execute(runner.controller_states(reports, self._clocks.now(), steady))

    def _await_state(self, states: list, decision_time: int) -> list:
        """Take joint states until one stamped ``decision_time`` [ns] or later, or time is up."""
        newest = stamp_nanoseconds(states[-1].header.stamp) if states else self._newest_state
        if not self.current_state.awaits(newest, decision_time):
            return states
        deadline = time.monotonic() + self.current_state.wait
        while (newest is None or newest < decision_time) and time.monotonic() < deadline:
            time.sleep(_STATE_POLL)
            more = self._joint_states.take()
            if more:
                states = states + more
                newest = stamp_nanoseconds(more[-1].header.stamp)
        self.current_state.waited(newest, decision_time)
        return states

    def _on_control_mode(self, msg: ControlMode) -> None:
        # A restarted supervisor takes the base back from the latched mode: its own commands
        # only, never a stray publisher's (walker_core.mode_command).
        if not mode_command_refusal(msg.commander, msg.base_gripper,
                                    self._node.get_namespace()):
            self._runner.latched_mode(msg.base_gripper)

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        steady = self._clocks.steady()
        for status in msg.status:
            self.deaths.status(status.name, status.level[0], status.message, steady)

    def _on_grippers(self, msg: GripperStates) -> None:
        for state in msg.grippers:
            self.gripper_messages[state.name] = state
        self._execute(self._runner.gripper_states(gripper_readings(msg), self._clocks.now(),
                                                  self._clocks.steady(),
                                                  gripper_position_errors(msg)))

    def resubscribe_silent(self) -> None:
        """Make anew the subscription of each source silent for long (see the module)."""
        steady = self._clocks.steady()
        for watched in self._watched:
            watched.check(steady)

    def destroy(self) -> None:
        """Destroy the sampled subscriptions."""
        self._sampler.destroy()
