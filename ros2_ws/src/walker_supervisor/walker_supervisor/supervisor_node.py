"""The step-phase supervisor node: the ROS shell of the walk runner.

Every decision is :class:`~walker_supervisor.core.runner.WalkRunner`'s; this node converts
messages, parameters and clocks, carries out the runner's commands over ROS and publishes what
it reports. Interfaces (relative to the node's namespace):

* actions ``step`` (walker_msgs/action/Step), ``walk_to`` (walker_msgs/action/WalkTo): a goal
  that cannot be taken (a target that is not a node name, not on the truss or out of reach, a
  goal while another runs, in safe hold, ...) is rejected at goal time, with the reason in the
  log and on ``goal_rejections`` (walker_msgs/GoalRejection, latched); cancelling a walk lets the
  step under way finish, so the walker ends with both grippers attached;
* services ``hold`` and ``resume`` (std_srvs/srv/Trigger); ``hold`` also stops a jog;
* the teleoperation services ``jog_joint``, ``jog_tip`` and ``operate_gripper``
  (:mod:`walker_supervisor.teleop_server`);
* publishes ``phase`` (walker_msgs/StepPhase, latched: the phase now), ``phase_history`` (the
  same messages, a latched history), ``control_mode`` (latched), ``step_reports``
  (walker_msgs/StepReport, one per step, latched history) and
  ``/diagnostics``; subscriptions: :mod:`walker_supervisor.inputs`; clients of the planner and
  the plant: :mod:`walker_supervisor.links`; the wrist cameras' triggers and images (a look of
  the runner): :mod:`walker_supervisor.camera_link`;
* the truss map starts from ``supervisor.truss_survey_file`` where that file exists and is
  written to it as it changes, at the latest before a goal's result is sent.
"""

from __future__ import annotations

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.action import CancelResponse, GoalResponse
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from std_srvs.srv import Trigger
from walker_msgs.action import Step, WalkTo
from walker_msgs.msg import ControlMode, GoalRejection, StepPhase, StepReport

from walker_core.robot_parameters import WalkerParameters
from walker_runtime.node_main import run_node
from walker_runtime.node_parameters import declare_section, guard_section_updates
from walker_runtime.qos import LATCHED_QOS, MODE_QOS, latched_qos
from walker_runtime.realtime import log_realtime_request
from walker_runtime.spinning import destroy_actions
from walker_runtime.watched_subscription import RenewablePublisher
from walker_supervisor.camera_link import CameraLink
from walker_supervisor.clocks import Clocks
from walker_supervisor.core.commands import (
    DecideNow, Feedback, ForgetRecordedStep, GoalEnded, Notice, PhaseRecord, RecordStep,
    RenewModePublisher, SetControlMode, StepRecord, StopJog)
from walker_supervisor.core.goals import GoalRefusedError
from walker_supervisor.core.parameters import SupervisorParameters, check_with_gripper
from walker_supervisor.core.phases import SequencerError
from walker_supervisor.core.runner import TICK_PERIOD, WATCH_PERIOD, WalkRunner
from walker_supervisor.core.survey_file import SurveyKeeper
from walker_supervisor.core.truss_map import SurveyFileError
from walker_supervisor.inputs import SupervisorInputs
from walker_supervisor.links import SimTimeRelease, SupervisorLinks
from walker_supervisor.map_frames import MapFrames
from walker_supervisor.owned_goal_server import (
    GoalLedgerFile, OwnedGoalServer, goal_ledger_path)
from walker_supervisor.messages import (
    diagnostics_message, feedback_message, join_answers, mode_message, phase_message,
    report_message, result_message)
from walker_supervisor.step_state import (
    clear_step_state, read_step_state, step_state_path, write_step_state)
from walker_supervisor.teleop_server import TeleopServer

__all__ = ['SupervisorNode', 'main', 'MODE_QOS']

# The phase history: a subscriber that matches late (a recorder matching a supervisor restarted
# after a SIGKILL, seen to take from one to about 30 s over UDP, about 20 phase messages of a
# walk in sim time) still receives the phases it missed, a safe hold among them, the newest
# last. 100 messages are about five steps. ``phase`` itself gives a late joiner the phase now.
_PHASE_HISTORY_QOS = latched_qos(100)
_REPORTS = latched_qos(100)
_FIRST_STATE_WAIT = 5.0  # [s] steady: a goal waits this long for the first measurements
_DIAGNOSTICS_PERIOD = 1.0  # [s] steady clock
_GOALS = {'walk_to': (WalkTo, 'walk'), 'step': (Step, 'step')}


class SupervisorNode(Node):
    """ROS shell of the walk runner: the step sequencer, the walk and teleoperation."""

    def __init__(self, **kwargs) -> None:
        super().__init__('supervisor', **kwargs)
        self.params = declare_section(self, WalkerParameters)
        settings = declare_section(self, SupervisorParameters, 'supervisor.')
        check_with_gripper(settings, self.params.gripper)
        self._state_file = step_state_path(self.get_namespace())
        self.runner = WalkRunner(self.params, settings, join_answers,
                                 read_step_state(self._state_file))
        # the map starts from supervisor.truss_survey_file where it exists, and is kept in it
        try:
            self._survey_file = SurveyKeeper(self.runner.mapped.map, settings.truss_survey_file)
        except SurveyFileError as error:  # a refusal to start, in one line (node_main)
            raise SurveyFileError(f'supervisor.truss_survey_file: {error}') from None
        guard_section_updates(self, SupervisorParameters, 'supervisor.',
                              lambda: self.runner.settings, self._apply_settings,
                              check=lambda s: check_with_gripper(s, self.params.gripper))
        self.clocks = Clocks(self)
        # made anew when controllers do not take its commands (RenewModePublisher)
        self.mode_pub = RenewablePublisher(self, ControlMode, 'control_mode', MODE_QOS)
        self.phase_pub = self.create_publisher(StepPhase, 'phase', LATCHED_QOS)
        self.phase_history_pub = self.create_publisher(StepPhase, 'phase_history',
                                                       _PHASE_HISTORY_QOS)
        self.rejection_pub = self.create_publisher(GoalRejection, 'goal_rejections',
                                                   LATCHED_QOS)
        self.report_pub = self.create_publisher(StepReport, 'step_reports', _REPORTS)
        self._diagnostics = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self.links = SupervisorLinks(self, self.runner, self.clocks, self._answer)
        self.cameras = CameraLink(self, self.runner, self.clocks, self._answer,
                                  self.params.gripper.camera.enabled)
        self.inputs = SupervisorInputs(self, self.runner, self.clocks, self._execute)
        self._goal_handle = None
        self._goal_ended: rclpy.task.Future | None = None  # the result of the walk under way
        self._accepted: list[rclpy.task.Future] = []  # of goals accepted, not yet executed
        self._measurement_waiters: list[tuple[float, rclpy.task.Future]] = []
        self._ticking = self._tick_due = False
        # goals a dead predecessor accepted are answered ABORTED, not UNKNOWN
        self._ledger = GoalLedgerFile(goal_ledger_path(self.get_namespace()))
        for name, (action, _) in _GOALS.items():
            OwnedGoalServer(self, action, name, execute_callback=self._run_goal,
                            goal_callback=self._accept, cancel_callback=self._on_cancel,
                            ledger=self._ledger)
        self.create_service(Trigger, 'hold', self._on_hold)
        self.create_service(Trigger, 'resume', self._on_resume)
        self.teleop = TeleopServer(self, self.runner, self.links, self.clocks, self._execute,
                                   self.inputs.gripper_messages)
        self._tick_timer = self.create_timer(TICK_PERIOD, self._tick)
        # Sim time: how far the plant may run before this node has decided again (the plant
        # waits for it with sim.wait_for_decisions)
        self._sim_time = bool(self.get_parameter('use_sim_time').value)
        self._release = SimTimeRelease(self, self.runner, self.links, self.clocks,
                                       self._tick_timer) if self._sim_time else None
        # Health: a steady-clock watchdog, which fires even when a dead plant stops /clock.
        steady = self.clocks.steady_clock
        self.create_timer(WATCH_PERIOD, self._watch, clock=steady)
        self.create_timer(_DIAGNOSTICS_PERIOD, self._publish_diagnostics, clock=steady)
        # the truss map for people: node frames on /tf_static, latched again as it changes
        self._map_frames = MapFrames(self, self.runner.mapped.map)
        self.create_timer(_DIAGNOSTICS_PERIOD, self._map_frames.publish_if_changed,
                          clock=steady)

    # ------------------------------------------------------------------ parameters
    def request_realtime_scheduling(self) -> bool:
        """Ask for ``SCHED_FIFO`` at ``timing.decision_priority`` on the wall clock; log it.

        Called by :func:`main`, for the process the node owns: a step's decisions then come
        ahead of every ordinary process (the recorder, an operator's tools), below the control
        loop. Nothing is asked in sim time, nor when the loop itself asks for nothing
        (``timing.realtime_priority`` 0), nor for a node built inside another process.
        """
        if self._sim_time:
            self.get_logger().info('default scheduling (sim time: no deadlines to meet)')
            return False
        return log_realtime_request(self.get_logger(),
                                    self.params.timing.decision_scheduling_priority)

    def _apply_settings(self, settings: SupervisorParameters) -> None:
        self.runner.set_settings(settings)
        self.inputs.set_watchdog_timeout(settings.watchdog_timeout)

    # ------------------------------------------------------------------ commands
    def _execute(self, commands: list) -> None:
        """Carry out the runner's commands, in order."""
        for command in commands:
            if self.links.handles(command):
                self.links.execute(command)
            elif self.cameras.handles(command):
                self.cameras.execute(command)
            elif isinstance(command, SetControlMode):
                self.mode_pub.publish(mode_message(command, self.clocks.stamp(),
                                                    self.get_fully_qualified_name()))
            elif isinstance(command, PhaseRecord):
                message = phase_message(command, self.clocks.stamp())
                self.phase_pub.publish(message)
                self.phase_history_pub.publish(message)
            elif isinstance(command, StepRecord):
                self.report_pub.publish(report_message(command, self.clocks.stamp()))
            elif isinstance(command, Feedback):
                if self._goal_handle is not None:
                    self._goal_handle.publish_feedback(feedback_message(command))
            elif isinstance(command, GoalEnded):
                self._keep_survey()  # before the result: the walk's client reads it
                ended, self._goal_ended = self._goal_ended, None
                if ended is not None and not ended.done():
                    ended.set_result(command)
            elif isinstance(command, RecordStep):
                write_step_state(self._state_file, command.step, command.heading,
                                 command.survey)
            elif isinstance(command, ForgetRecordedStep):
                clear_step_state(self._state_file)
            elif isinstance(command, StopJog):
                self.teleop.stop(command.reason)
            elif isinstance(command, RenewModePublisher):
                self.mode_pub.renew()  # the runner's Notice says why
            elif isinstance(command, DecideNow):
                self._tick()
            elif isinstance(command, Notice):
                self._log(command)

    def _log(self, notice: Notice) -> None:
        # one call site per severity: rclpy refuses a call site whose severity changes
        if notice.level == 'info':
            self.get_logger().info(notice.message)
        elif notice.level == 'error':
            self.get_logger().error(notice.message)
        else:
            self.get_logger().warning(notice.message)

    def _answer(self, commands: list) -> None:
        """Carry out the commands of an answer; the sim-time clock may then run on."""
        self._execute(commands)
        self._release_clock()

    def _release_clock(self) -> None:
        if self._release is not None:
            self._release.release()

    # ------------------------------------------------------------------ goals
    def _on_cancel(self, goal_handle) -> CancelResponse:
        self.runner.cancel_goal()  # one goal runs at a time: the step under way finishes
        return CancelResponse.ACCEPT

    async def _measurements_ready(self) -> None:
        """Wait (at most ``_FIRST_STATE_WAIT`` seconds) for the first measurements.

        A goal may arrive before this node's own subscriptions have matched the plant's and
        every controller's: the joint and gripper states, and a state from each controller.
        """
        if self.runner.measured_enough:
            return
        waiter = rclpy.task.Future()
        self._measurement_waiters.append((self.clocks.steady() + _FIRST_STATE_WAIT, waiter))
        await waiter

    def _release_measurement_waiters(self) -> None:
        ready, steady = self.runner.measured_enough, self.clocks.steady()
        for entry in list(self._measurement_waiters):
            if ready or steady > entry[0]:
                self._measurement_waiters.remove(entry)
                entry[1].set_result(ready)

    async def _accept(self, goal) -> GoalResponse:
        """Take a goal, or reject it at goal time with the reason (log, ``goal_rejections``).

        A rejected goal has no result in ROS 2 actions: its reason travels on the topic.
        """
        kind = 'walk_to' if isinstance(goal, WalkTo.Goal) else 'step'
        await self._measurements_ready()
        self.inputs.sample()
        try:
            commands = self.runner.start_goal(kind, goal.target_node, self.clocks.now(),
                                              self.clocks.steady())
        except GoalRefusedError as error:
            self.get_logger().warning(f'{_GOALS[kind][1]} to {goal.target_node!r} rejected: '
                                      f'{error}')
            rejection = GoalRejection(action=kind, target_node=goal.target_node,
                                      reason=str(error))
            rejection.header.stamp = self.clocks.stamp()
            self.rejection_pub.publish(rejection)
            return GoalResponse.REJECT
        self._goal_ended = rclpy.task.Future()
        self._accepted.append(self._goal_ended)
        self._execute(commands)
        return GoalResponse.ACCEPT

    async def _run_goal(self, goal_handle):
        """Follow an accepted goal to its end (the runner walks it); return its result."""
        ended_future = self._accepted.pop(0)  # goals are executed in the order accepted
        self._goal_handle = goal_handle
        kind = 'walk_to' if isinstance(goal_handle.request, WalkTo.Goal) else 'step'
        self._ledger.started(goal_handle, kind)
        ended = await ended_future
        self._ledger.ended(goal_handle)
        if self._goal_handle is goal_handle:
            self._goal_handle = None
        {'succeeded': goal_handle.succeed, 'canceled': goal_handle.canceled,
         'aborted': goal_handle.abort}[ended.status]()
        return result_message(ended)

    # ------------------------------------------------------------------ hold / resume
    def _on_hold(self, request: Trigger.Request, response: Trigger.Response):
        reason = self.inputs.deaths.hold_reason(self.clocks.steady())
        self._execute(self.runner.hold(reason, self.clocks.now()))
        response.success = True
        response.message = 'holding: trajectories stopped, controllers hold, grippers unchanged'
        return response

    def _on_resume(self, request: Trigger.Request, response: Trigger.Response):
        self.inputs.sample()
        try:
            answer, commands = self.runner.resume(self.clocks.now(), self.clocks.steady())
        except SequencerError as error:
            response.success, response.message = False, str(error)
            return response
        self._execute(commands)
        response.success, response.message = True, answer
        return response

    # ------------------------------------------------------------------ time
    def _tick(self) -> None:
        """Decide (every TICK_PERIOD, and at once when the runner asks: DecideNow)."""
        if self._ticking:  # asked from within a decision: decide again once it is over
            self._tick_due = True
            return
        self._ticking = True
        try:
            self._tick_due = True
            while self._tick_due:
                self._tick_due = False
                now_ns = self.clocks.now_ns()
                now = now_ns * 1e-9
                self.inputs.sample(now_ns if self._sim_time else None)
                self.teleop.tick(now)
                self._release_measurement_waiters()
                self.links.send_waiting()
                self._execute(self.runner.tick(now, self.clocks.steady()))
        finally:
            self._ticking = False
        self._release_clock()

    def _watch(self) -> None:
        """Steady-clock watchdog: a source that falls silent stops the walker in safe hold.

        It also keeps the wall-clock deadlines of the requests in flight (a server not yet
        discovered, a planner request unanswered): in sim time a request holds the clock, and
        so the ticks, until it is answered or given up on.
        """
        self.links.send_waiting()
        self._release_clock()
        self.inputs.sample()
        held = self._release is not None and self._release.holding
        self._execute(self.runner.watch(self.clocks.now(), self.clocks.steady(), held))
        self._release_clock()
        self.inputs.resubscribe_silent()

    def _keep_survey(self) -> None:
        failure = self._survey_file.write_if_changed()
        if failure is not None:
            self.get_logger().warning(failure)

    def _publish_diagnostics(self) -> None:
        self._keep_survey()
        level, summary, statuses = self.runner.diagnostics(self.clocks.steady(),
                                                           self.links.statuses())
        sequencer = self.runner.sequencer
        values = [('phase', sequencer.phase.name), ('base gripper', sequencer.base_gripper)]
        values += [(s.name, f'{s.level.name}: {s.message}') for s in statuses]
        current = self.inputs.current_state
        values += [('decisions that waited for their joint state', str(current.waits)),
                   ('of them, waits that ran out', str(current.timeouts))]
        self._diagnostics.publish(diagnostics_message(
            f'{self.get_fully_qualified_name()}: walker', self.get_namespace(), level, summary,
            values, self.clocks.stamp()))

    def destroy_node(self) -> None:
        """Destroy the node with its action servers and clients, and its sampler."""
        self.inputs.destroy()
        destroy_actions(self)
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    """Run the supervisor node; exit codes of :mod:`walker_runtime.node_main`.

    The default executor: the supervisor's asynchronous service and action calls have shown a
    failure inside the events executor, and it handles few messages (its high-rate inputs are
    sampled).
    """
    return run_node(SupervisorNode, 'supervisor', args,
                    start=SupervisorNode.request_realtime_scheduling,
                    executor=SingleThreadedExecutor)


if __name__ == '__main__':
    raise SystemExit(main())
