"""The supervisor's teleoperation services (ROS layer of :mod:`walker_supervisor.core.teleop`).

A mixin of :class:`walker_supervisor.supervisor_node.SupervisorNode`, kept apart from the
walking code. Services (relative to the node's namespace):

* ``jog_joint`` (``walker_msgs/srv/JogJoint``): one joint by a relative angle, a minimum-jerk
  move (the planner's ``joint_min_jerk``);
* ``jog_tip`` (``walker_msgs/srv/JogTip``): the free gripper along a straight line in its own
  frame, kept vertical (the planner's ``cartesian_line``);
* ``operate_gripper`` (``walker_msgs/srv/GripperCommand``): screw a gripper in or unscrew it,
  through the plant's ``gripper_command``.

Each command is checked by :class:`~walker_supervisor.core.teleop.TeleopRules` first; a refused
one is answered at once with the reason and nothing is sent anywhere. An accepted jog is planned
by the planner, streamed by its ``follow_trajectory`` with the controllers in FINE mode, and
answered once the joints have settled (``supervisor.settle_velocity`` for
``supervisor.settle_time``), after which the controllers HOLD; an accepted gripper command is
answered once the plant reports the gripper attached or free. The callbacks are coroutines in a
callback group of their own, so the executor goes on spinning while they wait. ``hold`` stops a
jog (the stream is cancelled, the controllers hold, the answer says so); a screw-in or unscrew
the plant has begun runs to its end.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np
import rclpy
from rclpy.callback_groups import ReentrantCallbackGroup
from walker_msgs.action import FollowTrajectory
from walker_msgs.msg import GripperState, GripperStates
from walker_msgs.srv import GripperCommand, JogJoint, JogTip, PlanTrajectory

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_runtime.node_parameters import declare_section, guard_section_updates
from walker_runtime.qos import LATCHED_QOS
from walker_core.text import unknown_choice
from walker_supervisor.core.sequencer import MAX_FINE_LINES, SequencerError, TrajectoryRequest
from walker_supervisor.core.teleop import (
    JointJog, SettleDetector, Situation, TeleopParameters, TeleopRefusedError, TeleopRules,
    TipJog, busy_reason)
from walker_supervisor.step_state import clear_step_state
from walker_supervisor.trajectory_requests import plan_request

__all__ = ['TeleopServer']

#: The commands of operate_gripper, by name (how an unknown one is refused)
_GRIPPER_COMMANDS = {'SCREW_IN': GripperCommand.Request.SCREW_IN,
                     'UNSCREW': GripperCommand.Request.UNSCREW}

_STATE_NAMES = {'free': GripperState.FREE, 'screwing': GripperState.SCREWING,
                'attached': GripperState.ATTACHED, 'unscrewing': GripperState.UNSCREWING,
                'jammed': GripperState.JAMMED}


@dataclasses.dataclass
class _Wait:
    """A teleoperation coroutine waiting for a future or a condition, with a deadline."""

    deadline: float  # [s] ROS clock
    waiter: rclpy.task.Future
    condition: Callable[[float], bool] | None = None


@dataclasses.dataclass
class _Outcome:
    success: bool
    message: str
    duration: float = 0.0  # [s]
    error: float = math.nan  # [rad or m]
    corrections: int = 0


class TeleopServer:
    """Mixin: the operator's jog and gripper services of the supervisor node.

    The host node provides ``params``, ``settings``, ``kinematics``, ``sequencer``, ``walk``,
    the measurements (``_positions``, ``_velocities``, ``_grippers``, ``_gripper_nodes``), the
    clients (``plan_client``, ``follow_client``, ``gripper_client``), the step file
    (``_state_file``) and ``_when_ready``, ``_publish_mode``, ``_release_interlock``, ``_now``.
    """

    # ------------------------------------------------------------------ set-up
    def _init_teleop(self) -> None:
        """Declare the ``teleop.`` parameters and create the services (call in __init__)."""
        self.teleop_settings = declare_section(self, TeleopParameters, 'teleop.')
        guard_section_updates(self, TeleopParameters, 'teleop.', lambda: self.teleop_settings,
                              self._apply_teleop_settings)
        self.teleop = TeleopRules.from_parameters(self.teleop_settings, self.params)
        self._teleop_operation = ''  # the command under way ('' when none)
        self._teleop_moving = False  # it is a jog (hold stops it)
        self._teleop_stopped = ''  # why hold stopped the jog under way
        self._teleop_follow = None
        self._teleop_waits: list[_Wait] = []
        self._teleop_gripper_msgs: dict[str, GripperState] = {}
        group = ReentrantCallbackGroup()
        self.create_subscription(GripperStates, 'gripper_states', self._teleop_on_grippers,
                                 LATCHED_QOS, callback_group=group)
        self.create_service(JogJoint, 'jog_joint', self._on_jog_joint, callback_group=group)
        self.create_service(JogTip, 'jog_tip', self._on_jog_tip, callback_group=group)
        self.create_service(GripperCommand, 'operate_gripper', self._on_operate_gripper,
                            callback_group=group)

    def _apply_teleop_settings(self, settings: TeleopParameters) -> None:
        self.teleop_settings = settings
        self.teleop.parameters = settings

    def _teleop_on_grippers(self, msg: GripperStates) -> None:
        for state in msg.grippers:
            self._teleop_gripper_msgs[state.name] = state

    # ------------------------------------------------------------------ hooks of the node
    def _teleop_check_idle(self) -> None:
        """Refuse to start a walk or a step while a teleoperation command is under way."""
        if self._teleop_operation:
            raise SequencerError(f'a teleoperation command is under way '
                                 f'({self._teleop_operation}): wait for its answer, or call '
                                 f'hold to stop a jog')

    def _teleop_stop(self, reason: str) -> None:
        """Stop a jog under way (``hold``): cancel its stream; its answer gives the reason."""
        if not self._teleop_moving:
            return
        self._teleop_stopped = reason
        if self._teleop_follow is not None:
            self._teleop_follow.cancel_goal_async()
            self._teleop_follow = None
        self._teleop_tick(self._now())

    def _teleop_tick(self, now: float) -> None:
        """Release the waits that are over (every decision tick, after the measurements)."""
        for wait in list(self._teleop_waits):
            if not wait.waiter.done():
                if self._teleop_stopped:
                    wait.waiter.set_result(False)
                elif wait.condition is not None and wait.condition(now):
                    wait.waiter.set_result(True)
                elif now > wait.deadline:
                    wait.waiter.set_result(False)
            if wait.waiter.done():
                self._teleop_waits.remove(wait)

    # ------------------------------------------------------------------ waiting
    def _teleop_situation(self) -> Situation:
        target = self.walk.target if self.walk is not None else None
        return Situation(busy_reason(target, self.sequencer.phase, self._teleop_operation),
                         dict(self._grippers), dict(self._gripper_nodes),
                         self.sequencer.base_gripper,
                         None if self._positions is None else self._positions.copy())

    async def _teleop_ready(self, ready: Callable[[], bool]) -> bool:
        """Wait (through the node's request machinery) until a server is discovered."""
        if ready():
            return True
        waiter = rclpy.task.Future()
        self._when_ready(ready, lambda: waiter.set_result(True),
                         lambda: waiter.set_result(False))
        return bool(await waiter)

    async def _teleop_wait(self, future, timeout: float):
        """Return the future's result, or None after ``timeout`` [s] or when stopped."""
        waiter = rclpy.task.Future()

        def done(_future) -> None:
            if not waiter.done():
                waiter.set_result(True)

        self._teleop_waits.append(_Wait(self._now() + timeout, waiter))
        future.add_done_callback(done)
        finished = await waiter
        return future.result() if finished and future.done() else None

    async def _teleop_until(self, condition: Callable[[float], bool], timeout: float) -> bool:
        """Wait until ``condition(now)`` holds at a tick; False after ``timeout`` [s] or a stop."""
        waiter = rclpy.task.Future()
        self._teleop_waits.append(_Wait(self._now() + timeout, waiter, condition))
        return bool(await waiter)

    # ------------------------------------------------------------------ jogs
    async def _on_jog_joint(self, request: JogJoint.Request, response: JogJoint.Response):
        try:
            jog = self.teleop.joint_jog(self._teleop_situation(), request.joint_name,
                                        request.delta, request.max_velocity)
        except TeleopRefusedError as error:
            return self._teleop_answer(response, _Outcome(False, str(error)), 'jog_joint')
        zero = np.zeros(3)
        call = plan_request(TrajectoryRequest('jog_joint', jog.start, jog.goal, zero, zero, 0.0,
                                              jog.base_gripper), self.kinematics)
        call.max_velocity = jog.speed
        index = PHYSICAL_JOINT_NAMES.index(jog.joint_name)

        outcome = await self._teleop_move(
            jog, call, lambda: float(self._positions[index] - jog.target),
            (lambda: self.teleop.joint_miss(self._positions, jog),
             self.teleop_settings.joint_tolerance))
        if outcome.success:
            outcome.message = (
                f'{jog.joint_name} at {self._positions[index]:.4f} rad, '
                f'{outcome.error * 1e3:+.2f} mrad from its target {jog.target:.4f} rad'
                f'{_corrections(outcome.corrections)}; settled {outcome.duration:.2f} s after '
                f'the start')
        return self._teleop_answer(response, outcome, 'jog_joint')

    async def _on_jog_tip(self, request: JogTip.Request, response: JogTip.Response):
        try:
            jog = self.teleop.tip_jog(self._teleop_situation(), list(request.delta),
                                      request.max_velocity)
        except TeleopRefusedError as error:
            return self._teleop_answer(response, _Outcome(False, str(error)), 'jog_tip')

        def error() -> float:
            return self.teleop.tip_miss(self._positions, jog)

        tolerance = self.settings.insertion_alignment
        outcome = await self._teleop_move(jog, self._tip_call(jog), error, (error, tolerance))
        if outcome.success:
            beyond = (f', more than supervisor.insertion_alignment = {tolerance * 1e3:g} mm'
                      if outcome.error > tolerance else '')
            outcome.message = (f'gripper {jog.free_gripper} is {outcome.error * 1e3:.2f} mm from '
                               f'its target{beyond} (forward kinematics of the measured '
                               f'joints){_corrections(outcome.corrections)}; settled '
                               f'{outcome.duration:.2f} s after the '
                               f'start')
        return self._teleop_answer(response, outcome, 'jog_tip')

    def _tip_call(self, jog: TipJog) -> PlanTrajectory.Request:
        call = plan_request(TrajectoryRequest('jog_tip', jog.start, jog.start, jog.start_point,
                                              jog.goal_point, 0.0, jog.base_gripper),
                            self.kinematics)
        call.max_velocity = jog.speed
        return call

    async def _teleop_move(self, jog: JointJog | TipJog, call: PlanTrajectory.Request,
                           error: Callable[[], float],
                           tolerance: tuple[Callable[[], float], float]) -> _Outcome:
        """Run a jog: stream it in FINE mode until the joints settle, then HOLD.

        ``error()`` is what the answer reports. A jog whose ``tolerance[0]()`` exceeds
        ``tolerance[1]`` once settled gets a correction move (from where it settled to its goal
        configuration) up to ``MAX_FINE_LINES`` times, as a step's fine motion gets fine lines.
        """
        off_target, tolerance = tolerance
        what = jog.describe()
        self._teleop_operation, self._teleop_moving, self._teleop_stopped = what, True, ''
        try:
            self.sequencer.base_gripper = jog.base_gripper
            ready = await self._teleop_ready(
                lambda: self.plan_client.service_is_ready()
                and self.follow_client.server_is_ready())
            if not ready:
                return _Outcome(False, f'{what}: the planner is not available; nothing moved')
            started = None
            corrections = 0
            while True:
                failure, started = await self._teleop_stream(what, jog.base_gripper, call,
                                                             error, started)
                if failure is not None:
                    return failure
                if off_target() <= tolerance or corrections >= MAX_FINE_LINES:
                    break
                try:
                    correction = self.teleop.correction(self._positions, jog)
                except TeleopRefusedError as refusal:
                    self.get_logger().warning(f'{what}: no correction: {refusal}')
                    break
                corrections += 1
                self.get_logger().info(f'{what}: settled {off_target():.4g} from its goal '
                                       f'(tolerance {tolerance:g}): correction {corrections}')
                call = plan_request(TrajectoryRequest(
                    'jog_joint', correction.start, correction.goal, np.zeros(3), np.zeros(3),
                    0.0, correction.base_gripper), self.kinematics)
                call.max_velocity = correction.speed
            self._publish_mode('hold', jog.base_gripper)
            return _Outcome(True, '', self._now() - started, error(), corrections)
        finally:
            self._teleop_operation, self._teleop_moving, self._teleop_stopped = '', False, ''
            self._teleop_follow = None

    async def _teleop_stream(self, what: str, base: str, call: PlanTrajectory.Request,
                             error: Callable[[], float], started: float | None
                             ) -> tuple[_Outcome | None, float]:
        """Plan, stream in FINE mode and wait until the joints settle.

        Returns (None, start time) on success, or (the failure, start time); after a failure
        the controllers hold.
        """
        timeout = self.settings.phase_timeout
        planned = await self._teleop_wait(self.plan_client.call_async(call), timeout)
        nothing = ('nothing moved', 0.0, math.nan) if started is None else \
            ('holding', self._now() - started, error())
        if self._teleop_stopped:
            return _Outcome(False, f'{what} stopped: {self._teleop_stopped}; {nothing[0]}',
                            *nothing[1:]), started
        if planned is None or not planned.success:
            reason = 'no answer' if planned is None else planned.message
            self._publish_mode('hold', base)
            return _Outcome(False, f'{what}: the planner refused it ({reason}); {nothing[0]}',
                            *nothing[1:]), started
        self._publish_mode('fine', base)
        sent = self.follow_client.send_goal_async(
            FollowTrajectory.Goal(trajectory=planned.trajectory))
        handle = await self._teleop_wait(sent, timeout)
        if handle is None or not handle.accepted:
            sent.add_done_callback(_cancel_if_accepted)
            self._publish_mode('hold', base)
            reason = (f'stopped: {self._teleop_stopped}' if self._teleop_stopped
                      else 'the planner did not stream it')
            return _Outcome(False, f'{what} {reason}; {nothing[0]}', *nothing[1:]), started
        self._teleop_follow = handle
        started = self._now() if started is None else started
        self.get_logger().info(f'{what}: {planned.duration:.2f} s')
        wrapped = await self._teleop_wait(handle.get_result_async(), planned.duration + timeout)
        self._teleop_follow = None
        if self._teleop_stopped:  # hold has cancelled the stream and holds the controllers
            return _Outcome(False, f'{what} stopped: {self._teleop_stopped}',
                            self._now() - started, error()), started
        result = None if wrapped is None else wrapped.result
        if result is None or not result.success:
            handle.cancel_goal_async()
            self._publish_mode('hold', base)
            reason = 'it did not end in time' if result is None else result.message
            return _Outcome(False, f'{what} failed: {reason}; holding', self._now() - started,
                            error()), started
        settle = SettleDetector(self.settings.settle_velocity, self.settings.settle_time)
        settled = await self._teleop_until(lambda now: settle.update(now, self._velocities),
                                           timeout)
        if self._teleop_stopped:
            return _Outcome(False, f'{what} stopped: {self._teleop_stopped}',
                            self._now() - started, error()), started
        if not settled:
            self._publish_mode('hold', base)
            return _Outcome(False, f'{what}: the joints did not settle within '
                                   f'supervisor.phase_timeout = {timeout:g} s; holding',
                            self._now() - started, error()), started
        return None, started

    # ------------------------------------------------------------------ grippers
    async def _on_operate_gripper(self, request: GripperCommand.Request,
                                  response: GripperCommand.Response):
        action = {GripperCommand.Request.SCREW_IN: 'screw_in',
                  GripperCommand.Request.UNSCREW: 'unscrew'}.get(request.command)
        if action is None:  # refused in the interface's words, as the plant does
            self._teleop_fill_state(response, request.gripper)
            return self._teleop_answer(response, _Outcome(False, unknown_choice(
                'gripper command', request.command, _GRIPPER_COMMANDS)), 'operate_gripper')
        try:
            operation = self.teleop.gripper_operation(self._teleop_situation(),
                                                      request.gripper, action)
        except TeleopRefusedError as error:
            self._teleop_fill_state(response, request.gripper)
            return self._teleop_answer(response, _Outcome(False, str(error)), 'operate_gripper')
        gripper, what = operation.gripper, operation.describe()
        self._teleop_operation = what
        try:
            if not await self._teleop_ready(self.gripper_client.service_is_ready):
                outcome = _Outcome(False, f'{what}: the plant gripper_command service is not '
                                          f'available; nothing changed')
            else:
                outcome = await self._teleop_gripper(operation, request.command, response)
        finally:
            self._teleop_operation = ''
        self._teleop_fill_state(response, gripper)
        return self._teleop_answer(response, outcome, 'operate_gripper')

    async def _teleop_gripper(self, operation, command: int, response) -> _Outcome:
        gripper, what = operation.gripper, operation.describe()
        timeout = self.params.gripper.screw_time + self.settings.phase_timeout
        if operation.action == 'unscrew' and self._grippers.get(gripper) == 'attached':
            refusal = self._release_interlock(gripper)  # the node's own check, as for a step
            if refusal:
                return _Outcome(False, f'{what} refused: {refusal}')
        answer = await self._teleop_wait(self.gripper_client.call_async(
            GripperCommand.Request(gripper=gripper, command=command)), timeout)
        if answer is None:
            return _Outcome(False, f'{what}: no answer from the plant')
        # the stance is changing: an interrupted step can no longer be completed by resume,
        # nor taken up by a restarted supervisor
        self.sequencer.forget_step()
        clear_step_state(self._state_file)
        if not answer.success:
            return _Outcome(False, f'{what} failed: {answer.message}')
        if operation.base_after != self.sequencer.base_gripper:
            self.sequencer.base_gripper = operation.base_after
            self._publish_mode('hold', operation.base_after)
            self.get_logger().info(f'gripper {operation.base_after} is the base now')
        done = await self._teleop_until(
            lambda now: self._grippers.get(gripper) in operation.expected, timeout)
        # hold where the arm is now: seated by the thread, or released from it
        self._publish_mode('hold', self.sequencer.base_gripper)
        state = self._grippers.get(gripper, 'unknown')
        if not done:
            return _Outcome(False, f'{what}: gripper {gripper} did not become '
                                   f'{" or ".join(operation.expected)} within {timeout:g} s '
                                   f'(it reports {state})')
        if state == 'attached':
            return _Outcome(True, f'gripper {gripper} is attached at '
                                  f'{self._gripper_nodes.get(gripper, "?")}; gripper '
                                  f'{self.sequencer.base_gripper} is the base')
        return _Outcome(True, f'gripper {gripper} is free; gripper '
                              f'{self.sequencer.base_gripper} is the base')

    def _teleop_fill_state(self, response: GripperCommand.Response, gripper: str) -> None:
        state = self._teleop_gripper_msgs.get(gripper)
        if state is not None:
            response.state = state
        elif gripper in self._grippers:
            response.state = GripperState(name=gripper,
                                          state=_STATE_NAMES.get(self._grippers[gripper], 0),
                                          node=self._gripper_nodes.get(gripper, ''))

    # ------------------------------------------------------------------ answers
    def _teleop_answer(self, response, outcome: _Outcome, service: str):
        response.success = outcome.success
        response.message = outcome.message
        if hasattr(response, 'duration'):
            response.duration = float(outcome.duration)
            response.position_error = float(outcome.error)
        if outcome.success:
            self.get_logger().info(f'{service}: {outcome.message}')
        else:
            self.get_logger().warning(f'{service}: {outcome.message}')
        return response


def _corrections(count: int) -> str:
    return f' after {count} correction move{"s" if count > 1 else ""}' if count else ''


def _cancel_if_accepted(future) -> None:
    """Cancel a follow goal that was accepted after its jog gave up on it."""
    handle = future.result()
    if handle is not None and handle.accepted:
        handle.cancel_goal_async()
