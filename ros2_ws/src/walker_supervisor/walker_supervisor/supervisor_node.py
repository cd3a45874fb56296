"""The step-phase supervisor node: walks the robot across the truss, step by step.

It owns the step's phases (:mod:`walker_supervisor.core.sequencer`) and the walk's route
(:mod:`walker_supervisor.core.route`), and carries out their commands over ROS: the controllers'
mode on ``control_mode``, trajectories through the planner (``plan_trajectory`` then
``follow_trajectory``), screw-in and release through the plant (``gripper_command``).

Interfaces (relative to the node's namespace):

* actions ``step`` (walker_msgs/action/Step), ``walk_to`` (walker_msgs/action/WalkTo); a goal sent
  while a walk runs is refused (aborted at once with the reason); cancelling a walk lets the step
  under way finish, so the walker ends with both grippers attached;
* services ``hold`` and ``resume`` (std_srvs/srv/Trigger); ``hold`` also stops a jog;
* the teleoperation services ``jog_joint``, ``jog_tip`` and ``operate_gripper``
  (:mod:`walker_supervisor.teleop_server`);
* publishes ``phase`` (walker_msgs/StepPhase, latched), ``control_mode`` (latched) and
  ``step_reports`` (walker_msgs/StepReport, one per step, latched history).
"""

from __future__ import annotations

import math
import time

import numpy as np
import rclpy
from geometry_msgs.msg import PoseStamped
from rclpy.action import ActionClient, ActionServer, CancelResponse, GoalResponse
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.task import Future
from rosgraph_msgs.msg import Clock as RosClock
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory
from std_srvs.srv import Trigger
from walker_msgs.action import FollowTrajectory, Step, WalkTo
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.clock import Clock, ClockType
from walker_msgs.msg import (
    ControllerState, ControlMode, GripperState, GripperStates, StepPhase, StepReport)
from walker_msgs.srv import GripperCommand, PlanTrajectory

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES, physical_to_roles
from walker_core.kinematics import KinematicsError, WalkerKinematics
from walker_core.node_parameters import declare_section, guard_section_updates
from walker_core.parameter_schema import ParameterError
from walker_core.mode_command import mode_command_refusal
from walker_core.qos import (
    COMMAND_QOS, LATCHED_QOS, MODE_QOS, MODE_SUBSCRIPTION_QOS, SENSOR_QOS, latched_qos)
from walker_core.realtime import log_realtime_request
from walker_core.resubscription import Resubscription
from walker_core.robot_parameters import WalkerParameters
from walker_core.spinning import TopicSampler, destroy_actions, init_node_process, spin_nodes
from walker_core.truss import Truss, UnknownNodeError
from walker_planner.conversions import chained_message
from walker_planner.core.errors import PlanningError
from walker_supervisor.core.decision_clock import DecisionClock
from walker_supervisor.core.health import (
    HealthMonitor, Level, ModeRepetition, SourceStatus, controller_trouble,
    reason_naming_silent_sources, tell_mode_again, tracking_expected)
from walker_supervisor.core.route import (
    PlannedStep, Stance, UnreachableTargetError, plan_route, possible_steps, step_sweep)
from walker_supervisor.core.sequencer import (
    CancelTrajectory, GripperRequest, Notice, Phase, PrepareTrajectory, SequencerError,
    SetControlMode, StepOutcome, StepSequencer, SupervisorParameters, TrajectoryRequest)
from walker_supervisor.core.step_geometry import (
    BaseFrame, StepTargets, measure_step_targets, recovery_targets)
from walker_supervisor.core.unanswered import GIVE_UP, WAIT, UnansweredRequest
from walker_supervisor.core.walk import VibrationMeter, Walk
from walker_supervisor.prepared_motions import PreparedMotions, plan_answer, stream_lead
from walker_supervisor.step_state import (
    clear_step_state, read_step_state, step_state_path, write_step_state)
from walker_supervisor.teleop_server import TeleopServer
from walker_supervisor.trajectory_requests import plan_request

__all__ = ['SupervisorNode', 'main']

# The phase is latched with a history: a subscriber that matches late (a recorder matching a
# supervisor restarted after a SIGKILL, seen to take from one to about 30 s over UDP, about
# 20 phase messages of a walk in sim time) still receives the phases it missed, a safe hold
# among them, and its newest message is the phase now. 100 messages are about five steps.
_PHASE_QOS = latched_qos(100)
#: [s] steady clock: least time between two mode commands re-sent to controllers that fell
#: back to HOLD on a stall (one command serves all five)
_TELL_MODE_AGAIN_PERIOD = 0.25
_REPORTS = latched_qos(100)
# Poses are kept between two decisions (at 100 Hz, two or three per 50 Hz tick) for the
# vibration figures.
_POSES = QoSProfile(depth=50, reliability=ReliabilityPolicy.BEST_EFFORT,
                    durability=DurabilityPolicy.VOLATILE, history=HistoryPolicy.KEEP_LAST)
#: [s] shortest window of the residual vibration figures (five poses at 100 Hz)
_MIN_VIBRATION_WINDOW = 0.05


def _vibration_window(settings: SupervisorParameters) -> float:
    """Window [s] of the figures at the mouth: the settle time there, the joints still."""
    return max(settings.mouth_settle_time, _MIN_VIBRATION_WINDOW)


_GRIPPER_STATES = {GripperState.FREE: 'free', GripperState.SCREWING: 'screwing',
                   GripperState.ATTACHED: 'attached', GripperState.UNSCREWING: 'unscrewing',
                   GripperState.JAMMED: 'jammed'}
_MODES = {'off': ControlMode.OFF, 'hold': ControlMode.HOLD, 'coarse': ControlMode.COARSE,
          'fine': ControlMode.FINE}
#: [s] the supervisor's decision period (ROS clock). It also decides at once when a gripper's
#: state changes and when a motion ends: the step goes on without waiting up to a period
#: (about 50 ms a step in sim time, measured from the bag of a walk).
TICK_PERIOD = 0.02
# The sources the watchdog names after the plant's streams (a controller's: 'controller <joint>')
_PLANT_JOINT_STATES = 'plant joint states'
_PLANT_GRIPPER_STATES = 'plant gripper states'
_FIRST_STATE_WAIT = 5.0  # [s] (wall) a goal waits this long for the first measurements
_SERVER_WAIT = 5.0  # [s] (wall) a request waits this long for its server to be discovered
#: [s] (wall) a plan or follow request the planner has not answered this long is sent again,
#: over a new client; unanswered _ANSWER_GIVE_UP after it was first sent, its motion fails and
#: the step holds (core.unanswered)
_ANSWER_WAIT = 4.0
_ANSWER_GIVE_UP = 20.0
_WATCHDOG_PERIOD = 0.1  # [s] steady clock
# A source silent for this many watchdog timeouts has its subscription made anew, and again as
# often while the silence lasts (see Resubscription): the walker is in safe hold after one
# timeout; a second tells a dead or restarted publisher from a stall of a loaded machine.
_RESUBSCRIBE_AFTER_TIMEOUTS = 2.0
_DIAGNOSTICS_PERIOD = 1.0  # [s] steady clock
_CONTROLLER_STATES = QoSProfile(depth=20, reliability=ReliabilityPolicy.RELIABLE,
                                durability=DurabilityPolicy.VOLATILE,
                                history=HistoryPolicy.KEEP_LAST)
#: The motions whose planner bounds make up a step's time-optimal bound.
_BOUNDED = frozenset({'extraction', 'coarse', 'insertion'})
FEEDBACK_PERIOD = 0.1  # [s]
#: The phase is published again, within a phase, each time its progress has grown this much
#: (and when it reaches 1): a few messages per phase on the latched topic.
PROGRESS_STEP = 0.25


class SupervisorNode(TeleopServer, Node):
    """ROS front of the step sequencer, the walk and teleoperation."""

    def __init__(self, **kwargs) -> None:
        super().__init__('supervisor', **kwargs)
        self.params = declare_section(self, WalkerParameters)
        self.settings = declare_section(self, SupervisorParameters, 'supervisor.')
        self._check_alignment(self.settings)
        guard_section_updates(self, SupervisorParameters, 'supervisor.', lambda: self.settings,
                              self._apply_settings, check=self._check_alignment)
        self.kinematics = WalkerKinematics.from_parameters(self.params)
        self.truss = Truss.from_parameters(self.params)
        self.sequencer = StepSequencer(self.settings, self.kinematics, 'a',
                                       self.params.gripper.screw_time)
        self.vibration = VibrationMeter(window=_vibration_window(self.settings))
        self.walk: Walk | None = None
        self._walk_stance: Stance | None = None
        self._goal_handle = None
        self._goal_done = None
        self._positions: np.ndarray | None = None
        self._velocities = np.zeros(5)
        self._grippers: dict[str, str] = {}
        self._gripper_nodes: dict[str, str] = {}
        self._gripper_errors: dict[str, float] = {}
        self._base_known = False
        self._trajectory_generation = 0
        self._follow_handle = None
        self._step_bound = 0.0
        self._true_insertion_error = math.nan
        self._last_feedback = -math.inf
        self._last_phase: tuple | None = None
        self._published_progress = 0.0
        self._residual_vibration = math.nan
        self._bounded: set[str] = set()
        self._measurement_waiters: list[tuple[float, rclpy.task.Future]] = []
        self._waiting_requests: list[tuple] = []  # requests whose server is not yet discovered
        self._pending_adoption = False

        self.mode_pub = self.create_publisher(ControlMode, 'control_mode', MODE_QOS)
        self.phase_pub = self.create_publisher(StepPhase, 'phase', _PHASE_QOS)
        self.report_pub = self.create_publisher(StepReport, 'step_reports', _REPORTS)
        # The joint states (500 Hz) and the tip pose are sampled at the decision rate, not
        # handled message by message: a Python callback per message would cost more CPU than
        # every decision the supervisor makes.
        self._sampler = TopicSampler(f'{self.get_name()}_sampler', self.get_namespace(),
                                     self.context)
        self._joint_states = self._sampler.subscribe(JointState, 'joint_states', SENSOR_QOS)
        self._tip_poses = self._sampler.subscribe(PoseStamped, 'tip_pose', _POSES)
        self._gripper_states = self._subscribe_gripper_states()
        self.create_subscription(ControlMode, 'control_mode', self._on_control_mode,
                                 MODE_SUBSCRIPTION_QOS)
        self._state_file = step_state_path(self.get_namespace())
        self.plan_client = self.create_client(PlanTrajectory, 'plan_trajectory')
        self.gripper_client = self.create_client(GripperCommand, 'gripper_command')
        self.follow_client = ActionClient(self, FollowTrajectory, 'follow_trajectory')
        # the planner request waiting for its answer: (its sendings, service, future, send again)
        self._awaited: tuple[UnansweredRequest, str, object, object] | None = None
        self._sending_again: UnansweredRequest | None = None  # while a request is sent again
        # motions planned ahead (PrepareTrajectory), with their plan_trajectory answers
        self._prepared = PreparedMotions(_join)
        self.stop_client = self.create_client(Trigger, 'stop_trajectory')
        self.step_server = ActionServer(
            self, Step, 'step', execute_callback=self._execute_step,
            goal_callback=lambda _: GoalResponse.ACCEPT, cancel_callback=self._on_cancel)
        self.walk_server = ActionServer(
            self, WalkTo, 'walk_to', execute_callback=self._execute_walk,
            goal_callback=lambda _: GoalResponse.ACCEPT, cancel_callback=self._on_cancel)
        self.create_service(Trigger, 'hold', self._on_hold)
        self.create_service(Trigger, 'resume', self._on_resume)
        self._init_teleop()
        self._tick_timer = self.create_timer(TICK_PERIOD, self._tick)
        # Sim time: how far the plant may run before this node has decided again (the plant
        # waits for it with sim.wait_for_decisions); gripper commands still unanswered
        self._sim_time = bool(self.get_parameter('use_sim_time').value)
        self._held_at: int | None = None  # [ns] ROS time this node began holding the clock
        self._decided_pub = self.create_publisher(RosClock, '~/decided_until', COMMAND_QOS) \
            if self._sim_time else None
        # gripper commands unanswered, which hold that time (for _ANSWER_WAIT at most)
        self._decision_clock = DecisionClock(_ANSWER_WAIT)
        # Health: a steady-clock watchdog, which fires even when a dead plant stops /clock.
        timeout = self.settings.watchdog_timeout
        self._commanded_mode = self._commanded_base = ''  # the last mode command sent
        self._mode_commanded_at = -math.inf  # [s] ROS clock, when it was sent
        self._mode_told_again = -math.inf  # [s] steady clock
        self._mode_repetition = ModeRepetition()
        self._controller_states = {
            joint: self._sampler.subscribe(ControllerState, f'controllers/{joint}/state',
                                           _CONTROLLER_STATES)
            for joint in PHYSICAL_JOINT_NAMES}
        self.health = HealthMonitor({_PLANT_JOINT_STATES: timeout,
                                     _PLANT_GRIPPER_STATES: timeout,
                                     **{f'controller {j}': timeout
                                        for j in PHYSICAL_JOINT_NAMES}},
                                    trouble_grace=timeout)
        self._resubscriptions = {name: Resubscription(_RESUBSCRIBE_AFTER_TIMEOUTS * timeout)
                                 for name in self.health.names}
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._diagnostics = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self.create_timer(_WATCHDOG_PERIOD, self._watch, clock=self._steady)
        self.create_timer(_DIAGNOSTICS_PERIOD, self._publish_diagnostics, clock=self._steady)

    # ------------------------------------------------------------------ parameters
    def request_realtime_scheduling(self) -> bool:
        """Ask for ``SCHED_FIFO`` at ``timing.decision_priority`` on the wall clock; log it.

        Called by :func:`main`, for the process the node owns: a step's decisions then come
        ahead of every ordinary process (the recorder, an operator's tools), below the control
        loop. Nothing is asked in sim time, nor when the loop itself asks for nothing
        (``timing.realtime_priority`` 0), nor for a node built inside another process.
        """
        if self.get_parameter('use_sim_time').value:
            self.get_logger().info('default scheduling (sim time: no deadlines to meet)')
            return False
        return log_realtime_request(self.get_logger(),
                                    self.params.timing.decision_scheduling_priority)

    def _check_alignment(self, settings: SupervisorParameters) -> None:
        tolerance = self.params.gripper.insertion_position_tolerance
        if settings.insertion_alignment >= tolerance:
            raise ParameterError(
                f'supervisor.insertion_alignment ({settings.insertion_alignment} m) must be '
                f'smaller than gripper.insertion_position_tolerance ({tolerance} m)')
        if settings.descent_region > tolerance:
            raise ParameterError(
                f'supervisor.descent_region ({settings.descent_region} m) must not exceed '
                f'gripper.insertion_position_tolerance ({tolerance} m): the descent starts '
                f'only with the tip inside it')

    def _apply_settings(self, settings: SupervisorParameters) -> None:
        self.settings = settings
        self.sequencer.parameters = settings
        self.vibration.window = _vibration_window(settings)
        # the watchdog and the resubscriptions follow a new watchdog_timeout at once
        timeout = settings.watchdog_timeout
        self.health.set_timeouts(timeout, trouble_grace=timeout)
        for resubscription in self._resubscriptions.values():
            resubscription.after = _RESUBSCRIBE_AFTER_TIMEOUTS * timeout

    # ------------------------------------------------------------------ measurements
    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _on_joint_states(self, msg: JointState) -> None:
        index = {name: i for i, name in enumerate(msg.name)}
        if not all(name in index for name in PHYSICAL_JOINT_NAMES):
            return
        order = [index[name] for name in PHYSICAL_JOINT_NAMES]
        positions = np.array([msg.position[i] for i in order])
        if not np.all(np.isfinite(positions)):
            return
        self._positions = positions
        if len(msg.velocity) == len(msg.name):
            self._velocities = np.array([msg.velocity[i] for i in order])

    def _steady_now(self) -> float:
        return self._steady.now().nanoseconds * 1e-9

    def _subscribe_gripper_states(self):
        return self.create_subscription(GripperStates, 'gripper_states',
                                        self._on_gripper_states, LATCHED_QOS)

    def _on_gripper_states(self, msg: GripperStates) -> None:
        self.health.seen(_PLANT_GRIPPER_STATES, self._steady_now())
        first = not self._grippers
        before = dict(self._grippers)
        for state in msg.grippers:
            self._grippers[state.name] = _GRIPPER_STATES.get(state.state, 'unknown')
            self._gripper_nodes[state.name] = state.node
            self._gripper_errors[state.name] = state.position_error
        free = sorted(g for g in ('a', 'b') if self._grippers.get(g) != 'attached')
        if first and free and self.sequencer.phase == Phase.IDLE:
            # a supervisor restarted in the middle of a step: nothing may move by itself
            self._execute(self.sequencer.hold(
                f'started with gripper {", ".join(free)} not attached', self._now()))
            self._pending_adoption = True
            # a motion an earlier incarnation started may still be streaming: in safe hold
            # nothing moves, so stop it (the controllers hold where it stops)
            self._when_ready(self.stop_client.service_is_ready, self._stop_orphan_stream,
                             lambda: None)
        elif not first and self._grippers != before:
            self._tick()  # a gripper done unscrewing or screwing in: decide now, not next tick

    def _stop_orphan_stream(self) -> None:
        self.get_logger().warning('stopping any trajectory still streaming for an earlier '
                                  'supervisor')
        self.stop_client.call_async(Trigger.Request())

    def _on_tip_pose(self, msg: PoseStamped) -> None:
        p = msg.pose.position
        stamp = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
        self.vibration.add(stamp, np.array([p.x, p.y, p.z]))

    def _on_control_mode(self, msg: ControlMode) -> None:
        # A restarted supervisor takes the base back from the latched mode (its own only).
        if mode_command_refusal(msg.commander, msg.base_gripper, self.get_namespace()):
            return
        if not self._base_known and not self.sequencer.busy and msg.base_gripper in ('a', 'b'):
            self.sequencer.base_gripper = msg.base_gripper
            self._base_known = True

    def _yaws(self) -> tuple[float, float]:
        return float(self._positions[0]), float(self._positions[4])

    def _yaw_limits(self) -> tuple[float, float]:
        drive = self.params.robot.drive.yaw
        return drive.position_min, drive.position_max

    def _adopt_interrupted_step(self) -> bool:
        """Take up the step an earlier incarnation left unfinished, if its gripper is free."""
        previous = read_step_state(self._state_file)
        if previous is None or self._positions is None:
            return False
        base = previous.base_gripper
        moving = 'b' if base == 'a' else 'a'
        if self._grippers.get(base) != 'attached' or self._grippers.get(moving) == 'attached' \
                or self._gripper_nodes.get(base) != previous.base_node:
            # not the situation the file describes (another run's, or a step completed by
            # hand): forget it, so that it cannot be taken up later by mistake
            self.get_logger().info(f'step state file {self._state_file} does not describe the '
                                   f'walker now: ignored and removed')
            clear_step_state(self._state_file)
            return False
        try:
            sweep = step_sweep(self.truss, previous.base_node, previous.from_node,
                               previous.to_node)
            step = PlannedStep(base, previous.base_node, previous.from_node, previous.to_node,
                               sweep)
            frame = BaseFrame(self.truss.position(previous.base_node), previous.heading)
            theta = physical_to_roles(self._positions, base)
            targets = recovery_targets(self.kinematics, frame, step,
                                       self.truss.position(step.from_node),
                                       self.truss.position(step.to_node), theta,
                                       self.params.gripper.approach_height)
        except (ValueError, KinematicsError) as error:
            self.get_logger().error(f'cannot take up the interrupted step: {error}')
            return False
        self.sequencer.adopt(step, targets, f'restarted in the middle of the step '
                             f'{step.from_node} -> {step.to_node}: resume to complete it')
        self.get_logger().warning(self.sequencer.reason)
        return True

    def _theta_roles(self) -> np.ndarray:
        return physical_to_roles(self._positions, self.sequencer.base_gripper)

    def _current_stance(self) -> Stance:
        base = self.sequencer.base_gripper
        other = 'b' if base == 'a' else 'a'
        if self._grippers.get(base) != 'attached' or self._grippers.get(other) != 'attached':
            raise SequencerError('a walk starts only with both grippers attached (now: '
                                 + ', '.join(f'{g}: {self._grippers.get(g, "unknown")}'
                                             for g in ('a', 'b')) + ')')
        stance = Stance(base, self._gripper_nodes[base], self._gripper_nodes[other])
        if stance.other_node not in self.truss.neighbors(stance.base_node):
            # an operator may have screwed a gripper in elsewhere
            raise SequencerError(f'the grippers are in {stance.base_node} and '
                                 f'{stance.other_node}, which are not neighbouring nodes')
        return stance

    # ------------------------------------------------------------------ actions
    def _on_cancel(self, goal_handle) -> CancelResponse:
        return CancelResponse.ACCEPT

    async def _measurements_ready(self) -> None:
        """Wait (at most ``_FIRST_STATE_WAIT`` seconds) for the first measurements.

        A goal may arrive before this node's own subscriptions have matched the plant's and
        every controller's: the joint and gripper states, and a state from each controller.
        """
        if self._measured():
            return
        waiter = rclpy.task.Future()
        self._measurement_waiters.append((time.monotonic() + _FIRST_STATE_WAIT, waiter))
        await waiter

    def _measured(self) -> bool:
        return self._positions is not None and len(self._grippers) == 2 \
            and not self.health.unheard()

    def _release_measurement_waiters(self) -> None:
        ready = self._measured()
        now = time.monotonic()
        for entry in list(self._measurement_waiters):
            deadline, waiter = entry
            if ready or now > deadline:
                self._measurement_waiters.remove(entry)
                waiter.set_result(ready)

    async def _execute_walk(self, goal_handle):
        target = goal_handle.request.target_node
        result = WalkTo.Result()
        await self._measurements_ready()
        try:
            stance = self._start_checks()
            route = plan_route(self.truss, stance, target, yaws=self._yaws(),
                               yaw_limits=self._yaw_limits())
        except (SequencerError, UnknownNodeError, UnreachableTargetError) as error:
            self.get_logger().warning(f'walk to {target!r} refused: {error}')
            result.message = str(error)
            goal_handle.abort()
            return result
        self.get_logger().info(f'walking to {target}: {len(route)} steps '
                               + ' -> '.join(s.to_node for s in route))
        walk = await self._run_walk(goal_handle, target, route, stance)
        result.success = walk.reached
        result.steps_taken = sum(1 for o in walk.outcomes if o.success)
        result.duration = float(sum(o.duration for o in walk.outcomes))
        result.path = walk.path
        result.message = self._walk_message(walk)
        self._finish_goal(goal_handle, walk)
        return result

    async def _execute_step(self, goal_handle):
        target = goal_handle.request.target_node
        result = Step.Result()
        await self._measurements_ready()
        try:
            stance = self._start_checks()
            self.truss.index(target)
            reachable = possible_steps(self.truss, stance, self._yaws(), self._yaw_limits())
            steps = [s for s in reachable if s.to_node == target][:1]
            if not steps:
                raise UnreachableTargetError(
                    f'{target!r} is not one step away: from the base in {stance.base_node} a '
                    f'step reaches ' + (', '.join(sorted({s.to_node for s in reachable}))
                                        or "no node within the yaw joints' limits"))
        except (SequencerError, UnknownNodeError, UnreachableTargetError) as error:
            self.get_logger().warning(f'step to {target!r} refused: {error}')
            result.message = str(error)
            goal_handle.abort()
            return result
        walk = await self._run_walk(goal_handle, target, steps, stance)
        outcome = walk.outcomes[-1] if walk.outcomes else None
        result.success = walk.reached
        result.message = self._walk_message(walk)
        result.base_gripper = self.sequencer.base_gripper
        result.base_node = self._gripper_nodes.get(self.sequencer.base_gripper, '')
        if outcome is not None:
            result.duration = outcome.duration
            result.insertion_error = self._true_insertion_error
            result.time_optimal_bound = self._step_bound
        self._finish_goal(goal_handle, walk)
        return result

    def _start_checks(self) -> Stance:
        if self.walk is not None:
            raise SequencerError(self.walk.refusal(step_running=self.sequencer.busy))
        if self.sequencer.phase == Phase.SAFE_HOLD:
            raise SequencerError(f'the walker is in safe hold ({self.sequencer.reason}): call '
                                 f'resume first')
        if self._positions is None:
            raise SequencerError('no joint states received from the plant yet')
        self._sample_measurements()
        faults = self.health.faults(self._steady_now(), include_trouble=False)
        if faults:
            raise SequencerError('cannot start while ' + '; '.join(faults))
        self._teleop_check_idle()
        return self._current_stance()

    async def _run_walk(self, goal_handle, target: str, route: list[PlannedStep],
                        stance: Stance) -> Walk:
        self.walk = Walk(target, route)
        self._walk_stance = stance
        self._goal_handle = goal_handle
        self._goal_done = rclpy.task.Future()
        await self._goal_done
        walk, self.walk, self._goal_handle = self.walk, None, None
        return walk

    def _finish_goal(self, goal_handle, walk: Walk) -> None:
        if walk.reached:
            goal_handle.succeed()
        elif walk.cancel_requested and not walk.failed:
            goal_handle.canceled()
        else:
            goal_handle.abort()

    @staticmethod
    def _walk_message(walk: Walk) -> str:
        if walk.reached:
            return ''
        if walk.failed:
            return walk.outcomes[-1].message
        if walk.cancel_requested:
            return f'cancelled after {walk.step_index} of {len(walk.route)} steps'
        return 'the walk did not finish'

    # ------------------------------------------------------------------ the decision loop
    def _sample_measurements(self) -> None:
        now = self._steady_now()
        states = self._sampler.take(self._joint_states)
        if states:
            self.health.seen(_PLANT_JOINT_STATES, now)
            self._on_joint_states(states[-1])
        for pose in self._sampler.take(self._tip_poses):
            self._on_tip_pose(pose)
        fell_back = []
        for joint, subscription in self._controller_states.items():
            reports = self._sampler.take(subscription)
            if reports:
                stamp = reports[-1].header.stamp
                tracking = tracking_expected(self.sequencer.busy, self._commanded_mode,
                                             stamp.sec + 1e-9 * stamp.nanosec,
                                             self._mode_commanded_at)
                stale, holding = reports[-1].stale, reports[-1].mode == ControllerState.HOLD
                self.health.seen(f'controller {joint}', now,
                                 controller_trouble(stale, holding, tracking))
                if tell_mode_again(stale, holding, tracking):
                    fell_back.append(joint)
        if not fell_back:
            self._mode_repetition.heard()
        elif now - self._mode_told_again >= _TELL_MODE_AGAIN_PERIOD:
            self._mode_told_again = now
            if self._mode_repetition.repeat():
                self.destroy_publisher(self.mode_pub)
                self.mode_pub = self.create_publisher(ControlMode, 'control_mode', MODE_QOS)
                self.get_logger().warning(
                    f'controller {", ".join(fell_back)} still in HOLD after the mode was '
                    f'repeated {self._mode_repetition.renew_after} times: control_mode '
                    'publisher made anew')
            self.get_logger().warning(
                f'controller {", ".join(fell_back)} fell back to HOLD on a stall of its inputs, '
                f'which are fresh again: mode {self._commanded_mode.upper()} commanded again')
            self._publish_mode(self._commanded_mode, self._commanded_base)

    # ------------------------------------------------------------------ health
    def _faults(self) -> list[str]:
        """Faults now: a silent source, or a controller holding on stale inputs in a step."""
        now = self._steady_now()
        return self.health.faults(now, include_trouble=self.sequencer.busy)

    def _watch(self) -> None:
        """Steady-clock watchdog: a source that falls silent stops the walker in safe hold.

        It also keeps the wall-clock deadlines of the requests in flight (a server not yet
        discovered, a planner request unanswered): in sim time a request holds the clock, and
        so the ticks, until it is answered or given up on, which the ticks alone never did (a
        request waiting for its server froze the simulation for good). And it releases the
        sim-time clock again (:meth:`_release_clock`): an answer that came by a path that did
        not (a refusal) holds the plant for one watch period at most.
        """
        self._send_waiting_requests()
        self._ask_again_if_unanswered()
        self._release_clock()
        self._sample_measurements()
        if self._holding_the_clock():
            # the plant waits for this node's request, and nothing its states drive speaks:
            # no fault, and no subscription to renew (the gripper heartbeat, on the steady
            # clock, still tells a dead plant; the hold itself is bounded by its deadlines)
            self.health.excuse([name for name in self.health.names
                                if name != _PLANT_GRIPPER_STATES], self._steady_now())
        self._resubscribe_silent_sources()
        faults = [fault for fault in self.health.faults(self._steady_now(),
                                                        include_trouble=self.sequencer.busy)
                  if not fault.endswith(': not heard from yet')]
        if faults:
            self._teleop_stop('fault: ' + '; '.join(faults))
        # Between steps no step moves (an operator's jog was stopped just above): a fault is
        # reported on /diagnostics and refuses new goals while it lasts (_start_checks), and
        # needs no resume.
        if faults and self.sequencer.busy:
            reason = 'fault: ' + '; '.join(faults)
            self.get_logger().error(reason)
            self._execute(self.sequencer.hold(reason, self._now()))
            self._publish_phase()
        elif self.sequencer.phase == Phase.SAFE_HOLD:
            # the hold's first reason may be a consequence (controllers holding on stale
            # inputs): name the dead source behind it as soon as the watchdog sees it
            reason = reason_naming_silent_sources(self.sequencer.reason,
                                                  self.health.status(self._steady_now()))
            if reason != self.sequencer.reason:
                self.get_logger().error(f'in safe hold: {reason}')
                self._execute(self.sequencer.hold(reason, self._now()))
                self._publish_phase()

    def _resubscribe_silent_sources(self) -> None:
        """Make anew the subscription of a source silent for long (see Resubscription).

        A controller process restarted after a crash, or a graph frozen and resumed, can leave
        a subscription that no longer receives while its publisher lives on; the walker would
        then stay in safe hold with the whole graph healthy.
        """
        now = self._steady_now()
        for name, resubscription in self._resubscriptions.items():
            last_heard = self.health.last_heard(name)
            if not resubscription.due(now, last_heard):
                continue
            if name == _PLANT_JOINT_STATES:
                self._joint_states = self._sampler.renew(self._joint_states)
            elif name == _PLANT_GRIPPER_STATES:
                self.destroy_subscription(self._gripper_states)
                self._gripper_states = self._subscribe_gripper_states()
            else:
                joint = name.removeprefix('controller ')
                self._controller_states[joint] = self._sampler.renew(
                    self._controller_states[joint])
            self.get_logger().warning(
                f'{name}: silent for {now - last_heard:.1f} s, subscription made anew '
                '(a restarted or resumed publisher is matched again)')

    def _publish_diagnostics(self) -> None:
        message = DiagnosticArray()
        message.header.stamp = self.get_clock().now().to_msg()
        overall = DiagnosticStatus(name=f'{self.get_fully_qualified_name()}: walker',
                                   hardware_id=self.get_namespace())
        statuses = self.health.status(self._steady_now()) + self._server_statuses()
        if self.sequencer.phase == Phase.SAFE_HOLD:
            level = Level.ERROR
            overall.message = f'safe hold: {self.sequencer.reason}'
        else:
            level = max((s.level for s in statuses), default=Level.OK)
            overall.message = f'phase {self.sequencer.phase.name}'
        overall.level = bytes([int(level)])  # a one-byte field in rclpy
        overall.values = [KeyValue(key='phase', value=self.sequencer.phase.name),
                          KeyValue(key='base gripper', value=self.sequencer.base_gripper)]
        overall.values += [KeyValue(key=s.name, value=f'{s.level.name}: {s.message}')
                           for s in statuses]
        message.status = [overall]
        self._diagnostics.publish(message)

    def _server_statuses(self) -> list[SourceStatus]:
        """Whether this node's clients have discovered their servers (planner, plant).

        A step's first requests wait for their servers: on a loaded machine discovery has
        taken seconds, and in sim time a request waiting for its server holds the clock. A
        server not discovered yet is reported as not heard from, so ``run_all.py`` counts the
        graph ready only once every one is.
        """
        servers = (('planner plan_trajectory service', self.plan_client.service_is_ready),
                   ('planner follow_trajectory action', self.follow_client.server_is_ready),
                   ('plant gripper_command service', self.gripper_client.service_is_ready))
        return [SourceStatus(name, Level.OK, 'discovered') if ready()
                else SourceStatus(name, Level.WARN, 'not heard from yet')
                for name, ready in servers]

    def destroy_node(self) -> None:
        """Destroy the node with its action servers and clients, and its sampler."""
        self._sampler.destroy()
        destroy_actions(self)
        super().destroy_node()

    def _tick(self) -> None:
        now = self._now()
        self._sample_measurements()
        self._teleop_tick(now)
        if self._pending_adoption and self._positions is not None and len(self._grippers) == 2:
            self._pending_adoption = False
            self._adopt_interrupted_step()
        self._release_measurement_waiters()
        self._send_waiting_requests()
        self._ask_again_if_unanswered()
        if self._positions is not None:
            self._execute(self.sequencer.tick(now, self._theta_roles(),
                                              physical_to_roles(self._velocities,
                                                                self.sequencer.base_gripper),
                                              dict(self._grippers)))
        walk = self.walk
        if walk is not None:
            if self._goal_handle is not None and self._goal_handle.is_cancel_requested:
                walk.cancel_requested = True
            if not self.sequencer.busy:
                self._advance_walk(walk, now)
            if now - self._last_feedback >= FEEDBACK_PERIOD:
                self._publish_feedback(walk)
                self._last_feedback = now
        else:
            self._end_step_outside_walk()
        self._publish_phase()
        self._release_clock()

    def _release_clock(self) -> None:
        """Sim time: let the plant run up to this node's next tick, or hold it here.

        Held while a request to the planner or a gripper command is unanswered (a gripper
        command for ``_ANSWER_WAIT`` at most: :class:`DecisionClock`), or a freed gripper waits
        for the sweep's plan: the motion it starts then begins at the same simulated time
        however long the answer takes. The plant waits for it only with
        ``sim.wait_for_decisions``. A request still waiting for its server to be discovered
        (a planner restarted: seconds on a loaded machine) does not hold it: a clock held that
        long starved the controllers of states, and they held on stale inputs.
        """
        if self._decided_pub is None:
            return
        wall = time.monotonic()
        clock = self._decision_clock
        busy = self._awaited is not None \
            or clock.plan_awaited(self.sequencer.awaiting_plan, wall)
        now = self.get_clock().now().nanoseconds
        until = clock.decided_until(now, self._tick_timer.time_until_next_call(), busy, wall)
        if until > now:
            self._held_at = None
        elif self._held_at is None:
            self._held_at = now
        message = RosClock()
        message.clock.sec, message.clock.nanosec = divmod(until, 1_000_000_000)
        self._decided_pub.publish(message)

    def _holding_the_clock(self) -> bool:
        """Sim time: True while this node holds the clock and it has stood still since.

        The plant steps no further than the time released (with ``sim.wait_for_decisions``),
        so its joint states and the controllers' answers stop: their silence is this node's
        doing. A clock that runs on (the plant does not wait) is not held.
        """
        return self._held_at is not None \
            and self.get_clock().now().nanoseconds == self._held_at

    def _advance_walk(self, walk: Walk, now: float) -> None:
        """Between steps: record the step that ended, then start the next or end the walk."""
        outcome = self.sequencer.take_outcome()
        if outcome is not None:
            self._record_outcome(walk, outcome)
        if self.sequencer.phase == Phase.SAFE_HOLD and not walk.failed:
            walk.outcomes.append(StepOutcome(False, self.sequencer.reason, {}, 0.0,
                                             math.nan, 0))
        if walk.finished:
            # a walk ends relaxed: a stance measured after it is not bent by its last seat
            if now >= self.sequencer.relaxed_at and not self._goal_done.done():
                self._goal_done.set_result(True)
            return
        if not self.sequencer.can_start(now):  # it would measure its stance bent
            return
        step = walk.next_step()
        self._prepared.clear()
        try:
            targets = self._measure_targets(step, self._theta_roles())
            commands = self.sequencer.start(step, targets, now, dict(self._grippers),
                                            lambda theta: self._measure_again(step, theta,
                                                                              targets))
        except (KinematicsError, SequencerError) as error:
            walk.outcomes.append(StepOutcome(False, f'step to {step.to_node} refused: {error}',
                                             {}, 0.0, math.nan, 0))
            self.get_logger().error(walk.outcomes[-1].message)
            return
        write_step_state(self._state_file, step, targets.frame.heading)
        self._step_bound = 2.0 * self.params.gripper.screw_time
        self._bounded: set[str] = set()
        self._true_insertion_error = math.nan
        self.get_logger().info(f'step {walk.step_index + 1}/{len(walk.route)}: gripper '
                               f'{step.moving_gripper} {step.from_node} -> {step.to_node} '
                               f'({math.degrees(targets.sweep):+.0f} deg about {step.base_node})')
        self._execute(commands)

    def _measure_targets(self, step: PlannedStep, theta_roles: np.ndarray) -> StepTargets:
        """Return the step's targets from the stance ``theta_roles`` [rad] (role order)."""
        return measure_step_targets(self.kinematics, step, self.truss.position(step.base_node),
                                    self.truss.position(step.from_node),
                                    self.truss.position(step.to_node), theta_roles,
                                    self.params.gripper.approach_height)

    def _measure_again(self, step: PlannedStep, theta_roles: np.ndarray,
                       first: StepTargets) -> StepTargets:
        """Measure the targets from the relaxed stance (the sequencer's remeasure); file them."""
        targets = self._measure_targets(step, theta_roles)
        write_step_state(self._state_file, step, targets.frame.heading)
        change = math.remainder(targets.frame.heading - first.frame.heading, 2 * math.pi)
        self.get_logger().info(f'stance measured again after the relaxation: the base heading '
                               f'moved by {change * 1e3:+.3f} mrad')
        return targets

    def _end_step_outside_walk(self) -> None:
        """Log a step resumed after its walk ended, once it has ended; forget its file.

        Its outcome is taken here so that the next walk does not count it as its own first
        step.
        """
        outcome = self.sequencer.take_outcome()
        if outcome is None:
            return
        step = self.sequencer.step
        if outcome.success:
            clear_step_state(self._state_file)
            self.get_logger().info(f'step {step.from_node} -> {step.to_node} completed after '
                                   f'resume in {outcome.duration:.2f} s')
        else:
            self.get_logger().error(f'step {step.from_node} -> {step.to_node} failed after '
                                    f'resume: {outcome.message}')

    def _record_outcome(self, walk: Walk, outcome: StepOutcome) -> None:
        if outcome.success:
            clear_step_state(self._state_file)
        walk.outcomes.append(outcome)
        step = walk.route[len(walk.outcomes) - 1]
        report = StepReport()
        report.header.stamp = self.get_clock().now().to_msg()
        report.step_index = len(walk.outcomes) - 1
        report.step_count = len(walk.route)
        report.base_gripper = step.base_gripper
        report.moving_gripper = step.moving_gripper
        report.base_node, report.from_node, report.to_node = (step.base_node, step.from_node,
                                                              step.to_node)
        report.sweep = float(step.sweep)
        report.success = outcome.success
        report.message = outcome.message
        report.phase_names = list(outcome.phase_durations)
        report.phase_durations = [float(v) for v in outcome.phase_durations.values()]
        report.duration = float(outcome.duration)
        report.time_optimal_bound = float(self._step_bound)
        report.bound_ratio = (float(outcome.duration / self._step_bound)
                              if self._step_bound > 0 else 0.0)
        report.insertion_error = float(self._true_insertion_error)
        report.insertion_error_estimated = float(outcome.insertion_error)
        report.residual_vibration = float(self._residual_vibration)
        report.insertion_attempts = outcome.insertion_attempts
        self.report_pub.publish(report)
        text = (f'step {report.step_index + 1} {"done" if outcome.success else "failed"} in '
                f'{outcome.duration:.2f} s' + (f': {outcome.message}' if outcome.message else ''))
        if outcome.success:
            self.get_logger().info(text)
        else:
            self.get_logger().error(text)

    # ------------------------------------------------------------------ commands
    def _execute(self, commands: list) -> None:
        for command in commands:
            if isinstance(command, SetControlMode):
                self._publish_mode(command.mode, command.base_gripper)
            elif isinstance(command, GripperRequest):
                self._request_gripper(command)
            elif isinstance(command, TrajectoryRequest):
                self._request_trajectory(command)
            elif isinstance(command, PrepareTrajectory):
                self._prepare_trajectory(command.request)
            elif isinstance(command, CancelTrajectory):
                self._cancel_trajectory()
            elif isinstance(command, Notice):
                self.get_logger().warning(command.message)

    def _publish_mode(self, mode: str, base: str) -> None:
        self._commanded_mode, self._commanded_base = mode, base
        msg = ControlMode(mode=_MODES[mode], base_gripper=base,
                          commander=self.get_fully_qualified_name())
        stamp = self.get_clock().now()
        self._mode_commanded_at = stamp.nanoseconds * 1e-9
        msg.header.stamp = stamp.to_msg()
        self.mode_pub.publish(msg)

    def _request_gripper(self, request: GripperRequest) -> None:
        if request.action == 'screw_in' and self.sequencer.phase == Phase.INSERTION:
            self._residual_vibration = self.vibration.amplitude()
            # where the tip is as the screw-in starts (what the plant's thread checks), not a
            # mean over the settle window, which the ring biases when the window is short
            tip = self.vibration.latest()
            hole = self.truss.position(self.sequencer.step.to_node)
            self._true_insertion_error = float(np.linalg.norm(tip[:2] - hole[:2]))
        self._when_ready(self.gripper_client.service_is_ready,
                         lambda: self._send_gripper_request(request),
                         lambda: self._execute(self.sequencer.gripper_done(
                             False, 'the plant gripper_command service is not available',
                             self._now())))

    def _release_interlock(self, gripper: str) -> str:
        """Why releasing ``gripper`` is unsafe now ('' when it is not).

        Independent of the sequencer's rules (it starts a step only with both grippers
        attached) and of the plant's own interlock: the other gripper must be reported
        attached in a gripper state heard within the watchdog timeout.
        """
        other = 'b' if gripper == 'a' else 'a'
        fresh = not any(f.startswith(_PLANT_GRIPPER_STATES)
                        for f in self.health.faults(self._steady_now(), False))
        if not fresh:
            return 'interlock: the gripper states are not fresh'
        if self._grippers.get(other) != 'attached':
            return (f'interlock: gripper {other} is {self._grippers.get(other, "unknown")}, '
                    f'not attached')
        return ''

    def _send_gripper_request(self, request: GripperRequest) -> None:
        if request.action == 'unscrew':
            refusal = self._release_interlock(request.gripper)
            if refusal:
                self.get_logger().error(f'unscrewing gripper {request.gripper} refused: '
                                        f'{refusal}')
                self._execute(self.sequencer.gripper_done(False, refusal, self._now()))
                return
        call = GripperCommand.Request(
            gripper=request.gripper,
            command=GripperCommand.Request.SCREW_IN if request.action == 'screw_in'
            else GripperCommand.Request.UNSCREW)
        future = self.gripper_client.call_async(call)
        self._decision_clock.command_sent(future, time.monotonic())
        future.add_done_callback(self._on_gripper_response)

    def _on_gripper_response(self, future) -> None:
        self._decision_clock.command_answered(future)
        try:
            self._take_gripper_response(future)
        finally:
            self._release_clock()

    def _take_gripper_response(self, future) -> None:
        response = future.result()
        success, message = ((False, 'no response from the plant') if response is None
                            else (response.success, response.message))
        try:
            commands = self.sequencer.gripper_done(success, message, self._now())
        except SequencerError as error:  # an answer nobody waits for: say so, keep running
            self.get_logger().error(f'gripper answer ignored: {error}')
            return
        self._execute(commands)

    def _request_trajectory(self, request: TrajectoryRequest) -> None:
        self._trajectory_generation += 1
        generation = self._trajectory_generation
        if request.purpose in ('fine', 'insertion'):
            self.vibration.clear()
        def ready() -> bool:
            return self.plan_client.service_is_ready() and self.follow_client.server_is_ready()

        def send() -> None:
            if generation != self._trajectory_generation:
                return  # cancelled while waiting
            future = self._plan(request)
            if request.then is not None:  # streamed with it: both plans, then one goal
                future = self._both(future, self._plan(request.then))
            self._await_answer('plan_trajectory', future, send)
            future.add_done_callback(lambda f: self._on_planned(f, request, generation))

        def unavailable() -> None:
            if generation == self._trajectory_generation:
                self._execute(self.sequencer.trajectory_done(
                    False, 'the planner is not available', self._now()))

        self._when_ready(ready, send, unavailable)

    @staticmethod
    def _both(first, second) -> Future:
        """Return a future done with both answers, ``(first, second)``, once both are in."""
        both = Future()

        def answered(_) -> None:
            if first.done() and second.done() and not both.done():
                both.set_result((first.result(), second.result()))
        first.add_done_callback(answered)
        second.add_done_callback(answered)
        return both

    def _plan(self, request: TrajectoryRequest):
        """Return the planner's answer (future) to a motion: the one asked ahead, or a new one."""
        return self._prepared.take(request) \
            or self.plan_client.call_async(plan_request(request, self.kinematics))

    def _prepare_trajectory(self, request: TrajectoryRequest) -> None:
        """Ask the planner now for a motion the sequencer will request later (if it is up)."""
        if not self.plan_client.service_is_ready():
            self.sequencer.motion_not_planned(request.purpose)
            return
        future = self.plan_client.call_async(plan_request(request, self.kinematics))
        batch = self._prepared.batch
        future.add_done_callback(lambda f: self._on_prepared(f, request, batch))
        self._prepared.add(request, future)

    def _on_prepared(self, future, request: TrajectoryRequest, batch: int) -> None:
        """Tell the sequencer a motion asked ahead is planned (or will not be).

        A freed gripper waiting for it lifts now, not at the next tick (in sim time the clock
        is held while it waits).
        """
        if batch != self._prepared.batch:
            return  # asked for a step since ended or cancelled
        response = plan_answer(future)
        waiting = self.sequencer.awaiting_plan
        if response is not None and response.success:
            self.sequencer.motion_planned(request.purpose, response.duration)
            self._prepared.join_ahead()
        else:
            self.sequencer.motion_not_planned(request.purpose)
        if waiting:
            self._tick()

    def _when_ready(self, ready, send, unavailable) -> None:
        """Send a request now, or once its server is discovered (within _SERVER_WAIT s)."""
        if ready():
            send()
        else:
            self._waiting_requests.append((time.monotonic() + _SERVER_WAIT, ready, send,
                                           unavailable))

    def _send_waiting_requests(self) -> None:
        now = time.monotonic()
        for entry in list(self._waiting_requests):
            deadline, ready, send, unavailable = entry
            if ready():
                self._waiting_requests.remove(entry)
                send()
            elif now > deadline:
                self._waiting_requests.remove(entry)
                unavailable()

    def _await_answer(self, service: str, future, send_again) -> None:
        """Watch a request to the planner; unanswered after _ANSWER_WAIT, it is sent again."""
        now = time.monotonic()
        sendings = (self._sending_again.sent_again(now) if self._sending_again is not None
                    else UnansweredRequest(now, now, _ANSWER_WAIT, _ANSWER_GIVE_UP))
        self._awaited = (sendings, service, future, send_again)

    def _answered(self, future) -> bool:
        """Return True for the answer awaited (and stop awaiting it); False for a stale one."""
        if self._awaited is None or self._awaited[2] is not future:
            return False
        self._awaited = None
        return True

    def _ask_again_if_unanswered(self) -> None:
        """Send an unanswered planner request again, over a new client (see _ANSWER_WAIT).

        Unanswered for _ANSWER_GIVE_UP since it was first sent, the motion fails instead.
        """
        if self._awaited is None:
            return
        sendings, service, future, send_again = self._awaited
        now = time.monotonic()
        action = sendings.action(now)
        if future.done() or action == WAIT:
            return
        self._awaited = None
        if action == GIVE_UP:
            reason = (f'the planner answered no {service} request in '
                      f'{now - sendings.first_sent:.0f} s, asked again every '
                      f'{_ANSWER_WAIT:g} s over a new connection')
            self.get_logger().error(reason)
            self._execute(self.sequencer.trajectory_done(False, reason, self._now()))
            return
        self.get_logger().warning(f'no answer from the planner to {service} within '
                                  f'{_ANSWER_WAIT:g} s: asking again over a new connection')
        if service == 'plan_trajectory':
            self.destroy_client(self.plan_client)
            self.plan_client = self.create_client(PlanTrajectory, 'plan_trajectory')
            ready = self.plan_client.service_is_ready
        else:
            self.follow_client.destroy()
            self.follow_client = ActionClient(self, FollowTrajectory, 'follow_trajectory')
            ready = self.follow_client.server_is_ready
        generation = self._trajectory_generation

        def unavailable() -> None:
            if generation == self._trajectory_generation:
                self._execute(self.sequencer.trajectory_done(
                    False, f'the planner {service} is not available', self._now()))

        def send_again_since_first() -> None:
            self._sending_again = sendings
            try:
                send_again()
            finally:
                self._sending_again = None

        self._when_ready(ready, send_again_since_first, unavailable)

    def _on_planned(self, future, request: TrajectoryRequest, generation: int) -> None:
        """Stream a planned motion; with ``request.then``, both (``future`` has both answers)."""
        if not self._answered(future) or generation != self._trajectory_generation:
            return
        if request.then is None:
            answers = [(request, future.result())]
        else:
            answers = list(zip((request, request.then), future.result(), strict=True))
        for motion, response in answers:
            if response is None or not response.success:
                reason = 'no response' if response is None else response.message
                self._planning_failed(motion, reason)
                return
        for motion, response in answers:
            if motion.purpose in _BOUNDED and motion.purpose not in self._bounded:
                # the step's bound: its extraction, coarse motion and insertion at their
                # limits, plus the two screw actions (fine corrections and retries are not in it)
                self._bounded.add(motion.purpose)
                self._step_bound += response.time_optimal_bound
        response = answers[0][1]
        trajectory, duration, first_duration = response.trajectory, response.duration, None
        if request.then is not None:
            following = answers[1][1]
            try:
                trajectory = self._prepared.joined(response, following, request.lead)
            except PlanningError as error:
                self._planning_failed(request, f'it cannot stream with the {request.then.purpose} '
                                      f'motion: {error}')
                return
            first_duration = response.duration
            duration = response.duration + following.duration - stream_lead(
                response, following, request.lead)
        goal = FollowTrajectory.Goal(trajectory=trajectory)
        self._publish_mode(request.mode, request.base_gripper)  # clears a latched hold

        def send_goal() -> None:
            if generation != self._trajectory_generation:
                return  # cancelled while waiting
            sent = self.follow_client.send_goal_async(goal)
            self._await_answer('follow_trajectory', sent, send_goal)
            sent.add_done_callback(lambda f: self._on_follow_accepted(
                f, generation, duration, request.purpose, first_duration))

        send_goal()

    def _planning_failed(self, request: TrajectoryRequest, reason: str) -> None:
        self.get_logger().error(f'planning the {request.purpose} motion failed: {reason}')
        self._execute(self.sequencer.trajectory_done(
            False, f'planning the {request.purpose} motion failed: {reason}', self._now()))
        self._release_clock()

    def _on_follow_accepted(self, future, generation: int, duration: float,
                            purpose: str, first_duration: float | None = None) -> None:
        handle = future.result()
        if not self._answered(future):
            if handle is not None and handle.accepted:  # a late answer to a request sent again
                handle.cancel_goal_async()
            return
        if generation != self._trajectory_generation:
            if handle is not None and handle.accepted:
                handle.cancel_goal_async()
            return
        if handle is None or not handle.accepted:
            self._execute(self.sequencer.trajectory_done(
                False, 'the planner refused to stream the trajectory', self._now()))
            return
        self._follow_handle = handle
        self.get_logger().info(f'{purpose} motion: {duration:.2f} s' + (
            '' if first_duration is None else f' (the first {first_duration:.2f} s, the coarse '
            f'motion streaming with their end)'))
        self.sequencer.trajectory_started(duration, self._now(), first_duration)
        handle.get_result_async().add_done_callback(
            lambda f: self._on_follow_done(f, generation))
        self._release_clock()

    def _on_follow_done(self, future, generation: int) -> None:
        if generation != self._trajectory_generation:
            return
        self._follow_handle = None
        wrapped = future.result()
        result = None if wrapped is None else wrapped.result
        success = result is not None and result.success
        message = 'no result' if result is None else result.message
        self._execute(self.sequencer.trajectory_done(success, message, self._now()))
        if self.sequencer.phase == Phase.INSERTION and self.sequencer.stage == 'settling':
            # at the mouth: the residual vibration and the true error are of the arm at rest
            # there, not of the descent's last centimetres
            self.vibration.clear()
        self._tick()  # the next motion or phase is decided now, not at the next tick

    def _cancel_trajectory(self) -> None:
        self._trajectory_generation += 1
        self._awaited = None
        self._prepared.clear()
        if self._follow_handle is not None:
            self._follow_handle.cancel_goal_async()
            self._follow_handle = None

    # ------------------------------------------------------------------ hold / resume
    def _on_hold(self, request: Trigger.Request, response: Trigger.Response):
        self._execute(self.sequencer.hold('hold requested by an operator', self._now()))
        self._teleop_stop('hold requested by an operator')
        self._publish_phase()  # at once: the decision timer runs on the graph's clock
        response.success = True
        response.message = 'holding: trajectories stopped, controllers hold, grippers unchanged'
        return response

    def _on_resume(self, request: Trigger.Request, response: Trigger.Response):
        """Leave safe hold: the request and a healthy graph, two independent conditions.

        Outside SAFE_HOLD there is nothing to resume, and that is the answer whatever the
        graph's health (a controller not heard from yet at start-up, say).
        """
        try:
            self.sequencer.require_safe_hold()
        except SequencerError as error:
            response.success, response.message = False, str(error)
            return response
        self._sample_measurements()
        faults = self.health.faults(self._steady_now(), include_trouble=False)
        if faults:
            response.success = False
            response.message = 'cannot resume while ' + '; '.join(faults)
            return response
        if self._positions is None:
            response.success, response.message = False, 'no joint states from the plant'
            return response
        try:
            commands = self.sequencer.resume(self._now(), self._theta_roles(),
                                             dict(self._grippers), dict(self._gripper_nodes))
        except SequencerError as error:
            response.success = False
            response.message = str(error)
            return response
        self._execute(commands)
        # at once, before anything can end the motion again: the decision timer runs on the
        # graph's clock, which stands still while the plant does, and every resume must show
        # on the phase topic as the phase it entered
        self._publish_phase()
        response.success = True
        response.message = ('resumed: completing the step to '
                            f'{self.sequencer.step.to_node}' if self.sequencer.busy else
                            'resumed: ready for a step or a walk')
        return response

    # ------------------------------------------------------------------ publishing
    def _publish_phase(self) -> None:
        if not self._grippers:
            # Nothing is said before the grippers are known: a supervisor restarted in the
            # middle of a step would announce IDLE, then hold once it saw a gripper free.
            return
        walk = self.walk
        step = self.sequencer.step if self.sequencer.busy else None
        key = (self.sequencer.phase, self.sequencer.reason, self.sequencer.base_gripper,
               walk.step_index if walk else 0, walk is not None, self.sequencer.step)
        progress = self.sequencer.phase_progress(self._now())
        advanced = progress > self._published_progress \
            and progress >= min(1.0, self._published_progress + PROGRESS_STEP)
        if key == self._last_phase and not advanced:
            return
        if self._last_phase is not None and key[0] != self._last_phase[0]:
            text = (f'phase {self.sequencer.phase.name}'
                    + (f': {self.sequencer.reason}' if self.sequencer.reason else ''))
            if self.sequencer.phase == Phase.SAFE_HOLD:
                self.get_logger().warning(text)
            else:
                self.get_logger().info(text)
        self._last_phase, self._published_progress = key, progress
        msg = StepPhase(phase=int(self.sequencer.phase),
                        base_gripper=self.sequencer.base_gripper,
                        reason=self.sequencer.reason, phase_progress=progress)
        msg.header.stamp = self.get_clock().now().to_msg()
        if walk is not None:
            msg.step_index, msg.step_count = walk.step_index, len(walk.route)
        held = self.sequencer.phase == Phase.SAFE_HOLD and self.sequencer.step is not None \
            and self._grippers.get(self.sequencer.step.moving_gripper) != 'attached'
        if step is not None or held:
            step = self.sequencer.step
            msg.from_node, msg.to_node = step.from_node, step.to_node
            msg.base_node = step.base_node
            msg.base_heading = float(self.sequencer.targets.frame.heading)
        self.phase_pub.publish(msg)

    def _publish_feedback(self, walk: Walk) -> None:
        handle = self._goal_handle
        if handle is None:
            return
        step = self.sequencer.step if self.sequencer.busy else None
        error = self.sequencer.tip_error() if self.sequencer.busy else 0.0
        if isinstance(handle.request, WalkTo.Goal):
            feedback = WalkTo.Feedback(step_index=walk.step_index, step_count=len(walk.route),
                                       phase=int(self.sequencer.phase),
                                       tip_position_error=float(error))
            if step is not None:
                feedback.from_node, feedback.to_node = step.from_node, step.to_node
        else:
            feedback = Step.Feedback(phase=int(self.sequencer.phase),
                                     tip_position_error=float(error))
        handle.publish_feedback(feedback)


def _join(first, second, lead: float) -> JointTrajectory:
    """Return two ``plan_trajectory`` answers as one trajectory.

    The second starts ``lead`` [s] before the first ends, within both
    (:func:`walker_planner.conversions.chained_message`).
    """
    return chained_message(first.trajectory, second.trajectory,
                           stream_lead(first, second, lead))


def main(args: list[str] | None = None) -> None:
    """Run the supervisor node."""
    stop = init_node_process(args)
    node = None
    try:
        node = SupervisorNode()
        node.request_realtime_scheduling()
        # The default executor: the supervisor's asynchronous service and action calls have
        # shown a failure inside the events executor, and it handles few messages (its high-rate
        # inputs are sampled).
        spin_nodes(node, stop=stop, executor=SingleThreadedExecutor())
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except ParameterError as error:
        rclpy.logging.get_logger('supervisor').fatal(f'invalid parameters: {error}')
        raise SystemExit(2) from None
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()


if __name__ == '__main__':
    main()

