"""The operator's client of a running walker graph (ROS layer of walkerctl).

One rclpy node in the robot's namespace with a client for each operator command (the
supervisor's ``hold``, ``resume``, ``jog_joint``, ``jog_tip``, ``operate_gripper`` services and
``step``, ``walk_to`` actions) and the subscriptions ``status`` reads. Every wait spins the
node's own executor with a short timeout, so Ctrl-C (KeyboardInterrupt) is seen within 0.1 s;
the caller decides what an interruption does (cancel a walk, hold a jog).

This package does not depend on walker_bringup (which starts the whole graph, simulator
included): an operator's machine needs only the interfaces.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable

import numpy as np
from geometry_msgs.msg import PoseStamped
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger
from walker_msgs.action import Step, WalkTo
from walker_msgs.msg import ControlMode, GripperStates, StepPhase
from walker_msgs.srv import GripperCommand, JogJoint, JogTip

from walker_core.mode_command import mode_command_refusal
from walker_runtime.qos import LATCHED_QOS, MODE_SUBSCRIPTION_QOS
from walker_runtime.spinning import destroy_actions, helper_node
from walker_teleop.core.goal_answer import ACCEPTED
from walker_teleop.goal_monitor import GoalLostError, GoalMonitor
from walker_teleop.goal_sender import GoalSender
from walker_teleop.goal_rejections import GoalRejectedError, GoalRejections
from walker_teleop.core.status import (
    GRIPPER_STATE_NAMES, MODE_NAMES, PHASE_NAMES, GripperView, StatusView, name_of)

__all__ = ['TeleopClient', 'GraphUnavailableError', 'ServerLostError',
           'CommandInterruptedError', 'GoalRejectedError']

_POLL = 0.1  # [s] longest wait before Ctrl-C is seen
_LATCHED_GRACE = 0.5  # [s] wait for a latched topic that may never have been published


class GraphUnavailableError(RuntimeError):
    """The walker graph (or the server a command needs) did not answer in time."""


class ServerLostError(GraphUnavailableError):
    """The supervisor running a goal died or was started again (the goal's outcome unknown)."""


class CommandInterruptedError(RuntimeError):
    """The operator interrupted a wait (Ctrl-C)."""


class TeleopClient:
    """A client node for the operator's commands.

    Parameters
    ----------
    namespace : str
        The robot's namespace, e.g. ``/walker``.
    context : rclpy.context.Context
        An initialised context.
    timeout : float
        How long [s] to wait for a server to be discovered, and for an answer that does not
        wait for motion (status, hold, resume).
    """

    def __init__(self, namespace: str, context, timeout: float) -> None:
        self.namespace = namespace
        self.timeout = timeout
        self.node = helper_node(f'walkerctl_{os.getpid()}', namespace, context)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        create = self.node.create_client
        self.services = {'hold': create(Trigger, 'hold'), 'resume': create(Trigger, 'resume'),
                         'jog_joint': create(JogJoint, 'jog_joint'),
                         'jog_tip': create(JogTip, 'jog_tip'),
                         'operate_gripper': create(GripperCommand, 'operate_gripper')}
        self.rejections = GoalRejections(self.node)
        self.goals = {'step': GoalSender(self.node, Step, 'step', self.rejections),
                      'walk_to': GoalSender(self.node, WalkTo, 'walk_to', self.rejections)}

    def close(self) -> None:
        """Destroy the node."""
        self.executor.remove_node(self.node)
        destroy_actions(self.node)
        self.node.destroy_node()

    def where(self) -> str:
        """Say where walkerctl looked for the graph (for the error message)."""
        domain = os.environ.get('ROS_DOMAIN_ID', '0')
        return (f'is the walker graph up (e.g. python3 scripts/run_all.py --serve), in '
                f'namespace {self.namespace} and in this ROS domain (ROS_DOMAIN_ID={domain})?')

    # ------------------------------------------------------------------ waiting
    def spin_until(self, done: Callable[[], bool], timeout: float | None) -> bool:
        """Spin until ``done()`` (True) or ``timeout`` [s] (False); None waits without limit."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while not done():
            if deadline is not None and time.monotonic() > deadline:
                return False
            self.executor.spin_once(timeout_sec=_POLL)
        return True

    def _wait_interruptible(self, done: Callable[[], bool],
                            on_interrupt: Callable[[], None] | None,
                            timeout: float | None = None) -> bool:
        """Spin until ``done()``; the first Ctrl-C calls ``on_interrupt``, a second one stops.

        Returns False when ``timeout`` [s] passed first (None: no time limit).

        Raises
        ------
        CommandInterruptedError
            On Ctrl-C without ``on_interrupt``, or on the second Ctrl-C.
        """
        interrupted = False
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            try:
                left = None if deadline is None else max(0.0, deadline - time.monotonic())
                return self.spin_until(done, left)
            except KeyboardInterrupt:
                if interrupted or on_interrupt is None:
                    raise CommandInterruptedError('interrupted') from None
                interrupted = True
                on_interrupt()

    def _service(self, name: str):
        client = self.services[name]
        if not self.spin_until(client.service_is_ready, self.timeout):
            raise GraphUnavailableError(
                f'the service {self.node.get_namespace().rstrip("/")}/{name} is not available '
                f'(waited {self.timeout:g} s): {self.where()}')
        return client

    def call(self, name: str, request, on_interrupt: Callable[[], None] | None = None,
             timeout: float | None = None):
        """Call a service and return its response.

        Commands that move answer when the motion is over, so they wait without a time limit
        (``timeout`` None); ``on_interrupt`` says what a Ctrl-C does meanwhile.

        Raises
        ------
        GraphUnavailableError
            The service is not discovered, or does not answer, within the timeout.
        CommandInterruptedError
            Ctrl-C (see :meth:`_wait_interruptible`).
        """
        future = self._service(name).call_async(request)
        if not self._wait_interruptible(future.done, on_interrupt, timeout):
            raise GraphUnavailableError(
                f'no answer from {self.node.get_namespace().rstrip("/")}/{name} within '
                f'{timeout:g} s; the command may still have been carried out: check with '
                f'walkerctl status')
        return future.result()

    # ------------------------------------------------------------------ commands
    def trigger(self, name: str) -> Trigger.Response:
        """Call ``hold`` or ``resume`` (they answer at once: waited for ``timeout`` s)."""
        return self.call(name, Trigger.Request(), timeout=self.timeout)

    def hold_now(self) -> None:
        """Ask the supervisor to hold, without waiting for the answer (Ctrl-C of a jog)."""
        self.services['hold'].call_async(Trigger.Request())

    def jog_joint(self, joint: str, delta: float, speed: float) -> JogJoint.Response:
        """Jog a joint; a Ctrl-C meanwhile asks the supervisor to hold (which stops it)."""
        return self.call('jog_joint', JogJoint.Request(joint_name=joint, delta=float(delta),
                                                       max_velocity=float(speed)),
                         self.hold_now)

    def jog_tip(self, delta, speed: float) -> JogTip.Response:
        """Jog the free gripper; a Ctrl-C meanwhile asks the supervisor to hold."""
        return self.call('jog_tip', JogTip.Request(delta=[float(v) for v in delta],
                                                   max_velocity=float(speed)), self.hold_now)

    def operate_gripper(self, gripper: str, command: int) -> GripperCommand.Response:
        """Screw a gripper in or unscrew it (``GripperCommand.Request.SCREW_IN``/``UNSCREW``)."""
        return self.call('operate_gripper', GripperCommand.Request(gripper=gripper,
                                                                   command=command))

    def run_goal(self, action: str, target: str, on_feedback: Callable[[object], None],
                 on_cancel: Callable[[], None]) -> tuple[int, object]:
        """Send a ``step`` or ``walk_to`` goal and wait for its result: (status, result).

        The first Ctrl-C cancels the goal (the step under way finishes, the walker ends with
        both grippers attached) and keeps waiting for the result; a second one stops waiting.
        The goal counts as answered by the supervisor's response or, when that response is lost
        (a slow link: :mod:`walker_teleop.core.goal_answer`), by the goal seen running or
        its rejection heard (:class:`~walker_teleop.goal_sender.GoalSender`).
        Meanwhile the supervisor is watched (:class:`~walker_teleop.goal_monitor.GoalMonitor`):
        dead or started again, it cannot answer, and the wait ends within seconds.

        Raises
        ------
        GraphUnavailableError
            No action server within the timeout.
        ServerLostError
            The supervisor died or was started again while the goal ran.
        GoalRejectedError
            The supervisor rejected the goal (its ``reason`` says why).
        CommandInterruptedError
            Ctrl-C before the goal was accepted, or twice.
        """
        sender = self.goals[action]
        monitor = GoalMonitor(self.node, self.namespace,
                              f'the {"walk" if action == "walk_to" else "step"} to {target}')
        try:
            return self._watched_goal(sender, action, target, monitor, on_feedback, on_cancel)
        finally:
            monitor.close()

    def _watched_goal(self, sender, action: str, target: str, monitor: GoalMonitor,
                      on_feedback: Callable[[object], None], on_cancel: Callable[[], None]
                      ) -> tuple[int, object]:
        """:meth:`run_goal` with ``monitor`` made before the goal is sent."""
        if not self.spin_until(sender.client.server_is_ready, self.timeout):
            raise GraphUnavailableError(
                f'the action {self.node.get_namespace().rstrip("/")}/{action} is not available '
                f'(waited {self.timeout:g} s): {self.where()}')
        # the reason of a rejection is heard only once the rejections are matched
        self.spin_until(lambda: self.rejections.matched, min(self.timeout, _LATCHED_GRACE * 4))

        def fed(feedback) -> None:
            monitor.heard()
            on_feedback(feedback)

        sent = sender.send(sender.action_type.Goal(target_node=target), fed)
        if not self._wait_interruptible(sent.answer, None, self.timeout):
            raise GraphUnavailableError(f'the {action} goal was not answered within '
                                        f'{self.timeout:g} s: check with walkerctl status')
        if sent.answer() != ACCEPTED:
            raise GoalRejectedError(action, target, self.rejections.reason(
                action, target, sent.sent_at, lambda seconds: self.spin_until(lambda: False,
                                                                              seconds)))
        monitor.heard()  # the acceptance: the silence counts from here
        handle = sent.handle()
        result = handle.get_result_async()
        probed: list = []

        def ended() -> bool:
            if result.done():
                return True
            end = monitor.check(handle, result)
            if end is not None:
                probed.append(end)
            return bool(probed)

        def cancel() -> None:
            handle.cancel_goal_async()
            on_cancel()

        try:
            self._wait_interruptible(ended, cancel)
        except GoalLostError as error:
            raise ServerLostError(str(error)) from None
        wrapped = result.result() if result.done() else probed[0]
        return wrapped.status, wrapped.result

    # ------------------------------------------------------------------ status
    def status(self) -> tuple[StatusView, list[str]]:
        """Collect the walker's state; return it and what did not arrive within the timeout."""
        received: dict[str, object] = {}

        def keep(name: str) -> Callable[[object], None]:
            return lambda msg: received.__setitem__(name, msg)

        def keep_mode(msg: ControlMode) -> None:
            # the supervisor's commands only: a stray publisher's is not what the controllers do
            if not mode_command_refusal(msg.commander, msg.base_gripper, self.namespace):
                received['control_mode'] = msg

        subscriptions = [
            self.node.create_subscription(StepPhase, 'phase', keep('phase'), LATCHED_QOS),
            self.node.create_subscription(ControlMode, 'control_mode', keep_mode,
                                          MODE_SUBSCRIPTION_QOS),
            self.node.create_subscription(GripperStates, 'gripper_states', keep('gripper_states'),
                                          LATCHED_QOS),
            self.node.create_subscription(JointState, 'joint_states', keep('joint_states'),
                                          qos_profile_sensor_data)]
        for gripper in ('a', 'b'):
            subscriptions.append(self.node.create_subscription(
                PoseStamped, f'gripper_{gripper}_pose', keep(f'gripper_{gripper}_pose'),
                qos_profile_sensor_data))
        # control_mode is published from the first command on; until then the controllers hold
        wanted = ('phase', 'gripper_states', 'joint_states', 'gripper_a_pose', 'gripper_b_pose')
        try:
            self.spin_until(lambda: all(name in received for name in wanted), self.timeout)
            self.spin_until(lambda: 'control_mode' in received, _LATCHED_GRACE)
        finally:
            for subscription in subscriptions:
                self.node.destroy_subscription(subscription)
        missing = [name for name in wanted if name not in received]
        return self._view(received), missing

    def _view(self, received: dict[str, object]) -> StatusView:
        phase = received.get('phase')
        mode = received.get('control_mode')
        grippers = received.get('gripper_states')
        joints = received.get('joint_states')
        views = []
        for state in (grippers.grippers if grippers is not None else []):
            pose = received.get(f'gripper_{state.name}_pose')
            position = orientation = None
            if pose is not None:
                p, q = pose.pose.position, pose.pose.orientation
                position, orientation = np.array([p.x, p.y, p.z]), np.array([q.x, q.y, q.z,
                                                                             q.w])
            views.append(GripperView(state.name, name_of(state.state, GRIPPER_STATE_NAMES),
                                     state.node, position, orientation))
        step = ''
        if phase is not None and phase.to_node:
            step = f'{phase.from_node} -> {phase.to_node}'
            if phase.step_count:
                step = f'step {phase.step_index + 1}/{phase.step_count}: {step}'
        return StatusView(
            namespace=self.node.get_namespace(),
            phase=None if phase is None else name_of(phase.phase, PHASE_NAMES),
            reason='' if phase is None else phase.reason,
            base_gripper='' if phase is None else phase.base_gripper,
            step=step,
            mode=None if mode is None else name_of(mode.mode, MODE_NAMES),
            mode_base='' if mode is None else mode.base_gripper,
            grippers=tuple(views),
            joints=None if joints is None else tuple(
                (name, float(angle)) for name, angle in zip(joints.name, joints.position,
                                                            strict=False)))
