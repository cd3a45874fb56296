"""The supervisor's teleoperation services (ROS layer of :mod:`walker_supervisor.core.teleop`).

A part of :class:`walker_supervisor.supervisor_node.SupervisorNode`, composed into it through an
explicit interface (:class:`TeleopServer`'s parameters): it judges each command with the walk
runner's view of the walker and reaches the planner and the plant through the node's clients.
Services (relative to the node's namespace):

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
from collections.abc import Callable, Mapping

import numpy as np
import rclpy
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node
from walker_msgs.action import FollowTrajectory
from walker_msgs.msg import GripperState as GripperStateMessage
from walker_msgs.srv import GripperCommand, JogJoint, JogTip

from walker_core.gripper_state import GripperState
from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_runtime.node_parameters import declare_section, guard_section_updates
from walker_core.text import unknown_choice
from walker_supervisor.clocks import Clocks
from walker_supervisor.core.commands import TrajectoryRequest
from walker_supervisor.core.planner_calls import planner_call
from walker_supervisor.core.runner import WalkRunner
from walker_supervisor.core.transitions import MAX_FINE_LINES
from walker_supervisor.core.teleop import (
    GripperOperation, JointJog, SettleDetector, TeleopParameters, TeleopRefusedError,
    TeleopRules, TipJog)
from walker_supervisor.links import SupervisorLinks
from walker_supervisor.messages import gripper_state_code, plan_request_message
from walker_supervisor.teleop_waits import TeleopWaits

__all__ = ['TeleopServer']

#: The commands of operate_gripper, by name (how an unknown one is refused)
_GRIPPER_COMMANDS = {'SCREW_IN': GripperCommand.Request.SCREW_IN,
                     'UNSCREW': GripperCommand.Request.UNSCREW}
_ZERO = np.zeros(3)


@dataclasses.dataclass
class _Outcome:
    success: bool
    message: str
    duration: float = 0.0  # [s]
    error: float = math.nan  # [rad or m]
    corrections: int = 0


class TeleopServer:
    """The operator's jog and gripper services.

    Parameters
    ----------
    node : Node
        Holds the services and the ``teleop.`` parameters; logs.
    runner : WalkRunner
        Judges and keeps the walker's side: :meth:`~WalkRunner.teleop_situation`, the release
        interlock, the base, :attr:`~WalkRunner.teleop_operation`, the mode commands, and the
        stance an operator changes (:meth:`~WalkRunner.stance_changed`).
    links : SupervisorLinks
        The clients of the planner and the plant, and the wait for their servers.
    clocks : Clocks
    execute : callable
        Carries out the runner's commands (``execute(commands)``).
    gripper_messages : mapping of str to GripperStateMessage
        The newest state message of each gripper, for the answers.
    """

    def __init__(self, node: Node, runner: WalkRunner, links: SupervisorLinks, clocks: Clocks,
                 execute: Callable[[list], None],
                 gripper_messages: Mapping[str, GripperStateMessage]) -> None:
        self._node, self._runner, self._links, self._clocks = node, runner, links, clocks
        self._execute, self._gripper_messages = execute, gripper_messages
        self.settings = declare_section(node, TeleopParameters, 'teleop.')
        guard_section_updates(node, TeleopParameters, 'teleop.', lambda: self.settings,
                              self._apply_settings)
        self.rules = TeleopRules.from_parameters(self.settings, runner.params)
        self._moving = False  # a jog is under way (hold stops it)
        self._stopped = ''  # why hold stopped the jog under way
        self._follow = None
        self._waits = TeleopWaits(clocks)
        group = ReentrantCallbackGroup()
        node.create_service(JogJoint, 'jog_joint', self._on_jog_joint, callback_group=group)
        node.create_service(JogTip, 'jog_tip', self._on_jog_tip, callback_group=group)
        node.create_service(GripperCommand, 'operate_gripper', self._on_operate_gripper,
                            callback_group=group)

    def _apply_settings(self, settings: TeleopParameters) -> None:
        self.settings = settings
        self.rules.parameters = settings

    # ------------------------------------------------------------------ the node's calls
    def stop(self, reason: str) -> None:
        """Stop a jog under way (a hold, a fault): cancel its stream; its answer says why."""
        if not self._moving:
            return
        self._stopped = reason
        if self._follow is not None:
            self._follow.cancel_goal_async()
            self._follow = None
        self.tick(self._clocks.now())

    def tick(self, now: float) -> None:
        """Release the waits that are over (every decision tick, after the measurements)."""
        self._waits.release(now, bool(self._stopped))

    # ------------------------------------------------------------------ waiting
    def _mode(self, mode: str, base: str) -> None:
        self._execute(self._runner.command_mode(mode, base, self._clocks.now()))

    def _log(self):
        return self._node.get_logger()

    async def _ready(self, ready: Callable[[], bool]) -> bool:
        """Wait (through the node's request machinery) until a server is discovered."""
        if ready():
            return True
        waiter = rclpy.task.Future()
        self._links.when_ready(ready, lambda: waiter.set_result(True),
                               lambda: waiter.set_result(False))
        return bool(await waiter)

    # ------------------------------------------------------------------ jogs
    def _call(self, purpose: str, start, goal, start_point, goal_point, base: str,
              speed: float):
        request = TrajectoryRequest(purpose, start, goal, start_point, goal_point, 0.0, base)
        return plan_request_message(planner_call(request, self._runner.kinematics, speed))

    async def _on_jog_joint(self, request: JogJoint.Request, response: JogJoint.Response):
        try:
            jog = self.rules.joint_jog(self._runner.teleop_situation(), request.joint_name,
                                       request.delta, request.max_velocity)
        except TeleopRefusedError as error:
            return self._answer(response, _Outcome(False, str(error)), 'jog_joint')
        call = self._call('jog_joint', jog.start, jog.goal, _ZERO, _ZERO, jog.base_gripper,
                          jog.speed)
        index = PHYSICAL_JOINT_NAMES.index(jog.joint_name)
        measured = self._runner.measured
        outcome = await self._move(
            jog, call, lambda: float(measured.positions[index] - jog.target),
            (lambda: self.rules.joint_miss(measured.positions, jog),
             self.settings.joint_tolerance))
        if outcome.success:
            outcome.message = (
                f'{jog.joint_name} at {measured.positions[index]:.4f} rad, '
                f'{outcome.error * 1e3:+.2f} mrad from its target {jog.target:.4f} rad'
                f'{_corrections(outcome.corrections)}; settled {outcome.duration:.2f} s after '
                f'the start')
        return self._answer(response, outcome, 'jog_joint')

    async def _on_jog_tip(self, request: JogTip.Request, response: JogTip.Response):
        try:
            jog = self.rules.tip_jog(self._runner.teleop_situation(), list(request.delta),
                                     request.max_velocity)
        except TeleopRefusedError as error:
            return self._answer(response, _Outcome(False, str(error)), 'jog_tip')

        def error() -> float:
            return self.rules.tip_miss(self._runner.measured.positions, jog)

        tolerance = self._runner.settings.insertion_alignment
        call = self._call('jog_tip', jog.start, jog.start, jog.start_point, jog.goal_point,
                          jog.base_gripper, jog.speed)
        outcome = await self._move(jog, call, error, (error, tolerance))
        if outcome.success:
            beyond = (f', more than supervisor.insertion_alignment = {tolerance * 1e3:g} mm'
                      if outcome.error > tolerance else '')
            outcome.message = (f'gripper {jog.free_gripper} is {outcome.error * 1e3:.2f} mm from '
                               f'its target{beyond} (forward kinematics of the measured '
                               f'joints){_corrections(outcome.corrections)}; settled '
                               f'{outcome.duration:.2f} s after the start')
        return self._answer(response, outcome, 'jog_tip')

    async def _move(self, jog: JointJog | TipJog, call, error: Callable[[], float],
                    tolerance: tuple[Callable[[], float], float]) -> _Outcome:
        """Run a jog: stream it in FINE mode until the joints settle, then HOLD.

        ``error()`` is what the answer reports. A jog whose ``tolerance[0]()`` exceeds
        ``tolerance[1]`` once settled gets a correction move (from where it settled to its goal
        configuration) up to ``MAX_FINE_LINES`` times, as a step's fine motion gets fine lines.
        """
        off_target, tolerance = tolerance
        what = jog.describe()
        self._runner.teleop_operation, self._moving, self._stopped = what, True, ''
        try:
            self._runner.use_base(jog.base_gripper)
            links = self._links
            if not await self._ready(lambda: links.plan_client.service_is_ready()
                                     and links.follow_client.server_is_ready()):
                return _Outcome(False, f'{what}: the planner is not available; nothing moved')
            started = None
            corrections = 0
            while True:
                failure, started = await self._stream(what, jog.base_gripper, call, error,
                                                      started)
                if failure is not None:
                    return failure
                if off_target() <= tolerance or corrections >= MAX_FINE_LINES:
                    break
                try:
                    correction = self.rules.correction(self._runner.measured.positions, jog)
                except TeleopRefusedError as refusal:
                    self._log().warning(f'{what}: no correction: {refusal}')
                    break
                corrections += 1
                self._log().info(f'{what}: settled {off_target():.4g} from its goal '
                                 f'(tolerance {tolerance:g}): correction {corrections}')
                call = self._call('jog_joint', correction.start, correction.goal, _ZERO, _ZERO,
                                  correction.base_gripper, correction.speed)
            self._mode('hold', jog.base_gripper)
            return _Outcome(True, '', self._clocks.now() - started, error(), corrections)
        finally:
            self._runner.teleop_operation, self._moving, self._stopped = '', False, ''
            self._follow = None

    async def _stream(self, what: str, base: str, call, error: Callable[[], float],
                      started: float | None) -> tuple[_Outcome | None, float]:
        """Plan, stream in FINE mode and wait until the joints settle.

        Returns (None, start time) on success, or (the failure, start time); after a failure
        the controllers hold.
        """
        settings, clocks = self._runner.settings, self._clocks
        timeout = settings.phase_timeout
        planned = await self._waits.result(self._links.plan_client.call_async(call), timeout)
        nothing = ('nothing moved', 0.0, math.nan) if started is None else \
            ('holding', clocks.now() - started, error())
        if self._stopped:
            return _Outcome(False, f'{what} stopped: {self._stopped}; {nothing[0]}',
                            *nothing[1:]), started
        if planned is None or not planned.success:
            reason = 'no answer' if planned is None else planned.message
            self._mode('hold', base)
            return _Outcome(False, f'{what}: the planner refused it ({reason}); {nothing[0]}',
                            *nothing[1:]), started
        self._mode('fine', base)
        sent = self._links.follow_client.send_goal_async(
            FollowTrajectory.Goal(trajectory=planned.trajectory))
        handle = await self._waits.result(sent, timeout)
        if handle is None or not handle.accepted:
            sent.add_done_callback(_cancel_if_accepted)
            self._mode('hold', base)
            reason = (f'stopped: {self._stopped}' if self._stopped
                      else 'the planner did not stream it')
            return _Outcome(False, f'{what} {reason}; {nothing[0]}', *nothing[1:]), started
        self._follow = handle
        started = clocks.now() if started is None else started
        self._log().info(f'{what}: {planned.duration:.2f} s')
        wrapped = await self._waits.result(handle.get_result_async(), planned.duration + timeout)
        self._follow = None
        if self._stopped:  # hold has cancelled the stream and holds the controllers
            return _Outcome(False, f'{what} stopped: {self._stopped}',
                            clocks.now() - started, error()), started
        result = None if wrapped is None else wrapped.result
        if result is None or not result.success:
            handle.cancel_goal_async()
            self._mode('hold', base)
            reason = 'it did not end in time' if result is None else result.message
            return _Outcome(False, f'{what} failed: {reason}; holding', clocks.now() - started,
                            error()), started
        settle = SettleDetector(settings.settle_velocity, settings.settle_time)
        settled = await self._waits.until(
            lambda now: settle.update(now, self._runner.measured.velocities), timeout)
        if self._stopped:
            return _Outcome(False, f'{what} stopped: {self._stopped}',
                            clocks.now() - started, error()), started
        if not settled:
            self._mode('hold', base)
            return _Outcome(False, f'{what}: the joints did not settle within '
                                   f'supervisor.phase_timeout = {timeout:g} s; holding',
                            clocks.now() - started, error()), started
        return None, started

    # ------------------------------------------------------------------ grippers
    async def _on_operate_gripper(self, request: GripperCommand.Request,
                                  response: GripperCommand.Response):
        action = {GripperCommand.Request.SCREW_IN: 'screw_in',
                  GripperCommand.Request.UNSCREW: 'unscrew'}.get(request.command)
        if action is None:  # refused in the interface's words, as the plant does
            self._fill_state(response, request.gripper)
            return self._answer(response, _Outcome(False, unknown_choice(
                'gripper command', request.command, _GRIPPER_COMMANDS)), 'operate_gripper')
        try:
            operation = self.rules.gripper_operation(self._runner.teleop_situation(),
                                                     request.gripper, action)
        except TeleopRefusedError as error:
            self._fill_state(response, request.gripper)
            return self._answer(response, _Outcome(False, str(error)), 'operate_gripper')
        gripper, what = operation.gripper, operation.describe()
        self._runner.teleop_operation = what
        try:
            if not await self._ready(self._links.gripper_client.service_is_ready):
                outcome = _Outcome(False, f'{what}: the plant gripper_command service is not '
                                          f'available; nothing changed')
            else:
                outcome = await self._grip(operation, request.command)
        finally:
            self._runner.teleop_operation = ''
        self._fill_state(response, gripper)
        return self._answer(response, outcome, 'operate_gripper')

    async def _grip(self, operation: GripperOperation, command: int) -> _Outcome:
        runner = self._runner
        measured = runner.measured
        gripper, what = operation.gripper, operation.describe()
        timeout = runner.params.gripper.screw_time + runner.settings.phase_timeout
        attached = measured.grippers.get(gripper) == GripperState.ATTACHED
        if operation.action == 'unscrew' and attached:
            refusal = runner.release_refusal(gripper, self._clocks.steady())  # as for a step
            if refusal:
                return _Outcome(False, f'{what} refused: {refusal}')
        answer = await self._waits.result(self._links.gripper_client.call_async(
            GripperCommand.Request(gripper=gripper, command=command)), timeout)
        if answer is None:
            return _Outcome(False, f'{what}: no answer from the plant')
        # the stance is changing: an interrupted step can no longer be completed by resume,
        # nor taken up by a restarted supervisor
        self._execute(runner.stance_changed())
        if not answer.success:
            return _Outcome(False, f'{what} failed: {answer.message}')
        if operation.base_after != runner.sequencer.base_gripper:
            runner.use_base(operation.base_after)
            self._mode('hold', operation.base_after)
            self._log().info(f'gripper {operation.base_after} is the base now')
        done = await self._waits.until(
            lambda now: measured.grippers.get(gripper) in operation.expected, timeout)
        # hold where the arm is now: seated by the thread, or released from it
        base = runner.sequencer.base_gripper
        self._mode('hold', base)
        state = measured.grippers.get(gripper, 'unknown')
        if not done:
            return _Outcome(False, f'{what}: gripper {gripper} did not become '
                                   f'{" or ".join(operation.expected)} within {timeout:g} s '
                                   f'(it reports {state})')
        if state == GripperState.ATTACHED:
            return _Outcome(True, f'gripper {gripper} is attached at '
                                  f'{measured.nodes.get(gripper, "?")}; gripper {base} is the '
                                  f'base')
        return _Outcome(True, f'gripper {gripper} is free; gripper {base} is the base')

    def _fill_state(self, response: GripperCommand.Response, gripper: str) -> None:
        state = self._gripper_messages.get(gripper)
        measured = self._runner.measured
        if state is not None:
            response.state = state
        elif gripper in measured.grippers:
            response.state = GripperStateMessage(
                name=gripper, state=gripper_state_code(measured.grippers[gripper]),
                node=measured.nodes.get(gripper, ''))

    # ------------------------------------------------------------------ answers
    def _answer(self, response, outcome: _Outcome, service: str):
        response.success = outcome.success
        response.message = outcome.message
        if hasattr(response, 'duration'):
            response.duration = float(outcome.duration)
            response.position_error = float(outcome.error)
        if outcome.success:
            self._log().info(f'{service}: {outcome.message}')
        else:
            self._log().warning(f'{service}: {outcome.message}')
        return response


def _corrections(count: int) -> str:
    return f' after {count} correction move{"s" if count > 1 else ""}' if count else ''


def _cancel_if_accepted(future) -> None:
    """Cancel a follow goal that was accepted after its jog gave up on it."""
    handle = future.result()
    if handle is not None and handle.accepted:
        handle.cancel_goal_async()
