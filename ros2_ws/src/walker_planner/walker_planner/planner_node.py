"""The planner node: plans trajectories on request and streams them to the five controllers.

Interfaces (relative to the node's namespace, ``/walker`` by default; docs/architecture.md):

* service ``plan_trajectory`` (``walker_msgs/srv/PlanTrajectory``): plan one of the nine types;
  with ``execute`` true, also start streaming it;
* action ``follow_trajectory`` (``walker_msgs/action/FollowTrajectory``): stream a
  ``trajectory_msgs/JointTrajectory`` at the control rate, with feedback; cancelling stops
  the stream at once (no joint state needed) with a hold setpoint at the last position; a goal
  is rejected while a stream runs;
* service ``stop_trajectory`` (``std_srvs/srv/Trigger``): stop whatever stream runs, at once;
* ``controllers/joint_trajectory`` (``trajectory_msgs/msg/JointTrajectory``), published once
  per trajectory and once per cancel or stop (a hold) with ``planner.send_whole_trajectories``:
  the goal then succeeds when the clock (or a joint state) reaches the trajectory's end; else
  ``controllers/<joint>/setpoint`` (``walker_msgs/msg/JointCommand``) every period;
* ``planned_trajectory`` (``trajectory_msgs/msg/JointTrajectory``), latched;
* ``joint_states`` (``sensor_msgs/msg/JointState``), subscribed for the start check and errors
  (handed over by call in a composed sim-time graph: :meth:`PlannerNode.stream_by_call`).

All planning is in :mod:`walker_planner.core`, and every decision about streams in its
:class:`~walker_planner.core.streamer.TrajectoryStreamer`; this node converts messages,
parameters and clocks. The stream is paced by the plant's ``joint_states`` (one per control
period) and stamped from them, in real time and in sim time alike, as the controllers are.
"""

from __future__ import annotations

import threading

import rclpy
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.clock import Clock, ClockType
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger
from trajectory_msgs.msg import JointTrajectory
from walker_msgs.action import FollowTrajectory
from walker_msgs.msg import ControlMode
from walker_msgs.srv import PlanTrajectory

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_core.mode_command import mode_command_refusal
from walker_runtime.node_parameters import declare_section, guard_section_updates
from walker_runtime.qos import LATCHED_QOS, MODE_SUBSCRIPTION_QOS, SENSOR_QOS
from walker_runtime.realtime import log_realtime_request, request_thread_priority
from walker_runtime.core.resubscription import clock_ran_past
from walker_core.robot_parameters import WalkerParameters
from walker_runtime.node_main import run_node
from walker_runtime.watched_subscription import WatchedSubscription
from walker_runtime.spinning import destroy_actions, helper_node, spin_nodes
from walker_planner.conversions import (
    JointStateReader, plan_request, sampled_trajectory, to_time, trajectory_message)
from walker_planner.core.errors import PlanningError
from walker_planner.core.parameters import PREFIX, PlannerParameters
from walker_planner.core.planning import PlanningContext, plan
from walker_planner.core.streamer import ActiveStream, TrajectoryStreamer
from walker_planner.core.streaming import SampledTrajectory
from walker_planner.setpoints import SetpointPublishers, TrajectoryPublisher
from walker_planner.stream_goal import StreamGoal, goal_result

__all__ = ['PlannerNode', 'main']

_RESULT_TIMEOUT = 30  # [s] how long a finished follow_trajectory goal keeps its result

#: [s] how often the main thread completes ended streams and sends action feedback
_RELAY_PERIOD = 0.02

#: [s] steady time: joint states silent this long while the plant's clock runs on get their
#: subscription made anew (:class:`~walker_runtime.watched_subscription.WatchedSubscription`),
#: and every this long again while the silence lasts
_RESUBSCRIBE_AFTER = 1.0

#: control periods the ROS clock must have run past the newest joint state (or, none heard
#: yet in sim time, past zero) for a silence to be the subscription's, not a stopped plant's
_CLOCK_AHEAD_PERIODS = 10

#: [s] wall time to wait for the stream executor's first timer, or a stream for the first state
_STREAM_START_WAIT = 5.0


class PlannerNode(Node):
    """Plan trajectories (service), stream them (action), publish the current plan.

    Streaming runs on a helper node (``<name>_stream``) spun in a thread of its own, so that
    planning, which takes tens to hundreds of milliseconds for a long Cartesian path, never
    stalls the setpoints the controllers expect every period.

    Keyword arguments are passed to ``Node`` (``cli_args``, ``context``, ...), so that the node
    can also be built in a composed process (``walker_bringup.composition``).
    """

    def __init__(self, **kwargs) -> None:
        super().__init__('planner', **kwargs)
        self._robot = declare_section(self, WalkerParameters)
        self._planner = declare_section(self, PlannerParameters, PREFIX)
        guard_section_updates(self, PlannerParameters, PREFIX, lambda: self._planner,
                              self._apply_planner_parameters)
        self._planning = PlanningContext.from_parameters(self._robot, self._planner)
        self._period_ns = int(round(1e9 / self._robot.timing.control_rate))
        stream = self._planner.stream
        whole = TrajectoryPublisher(self) if self._planner.send_whole_trajectories else None
        self._streamer = TrajectoryStreamer(self._period_ns, stream.lookahead,
                                            stream.start_tolerance, self._send,
                                            None if whole is None else whole.send)
        self._reserved = False
        self._begun: tuple[ActiveStream | None, str] | None = None  # started at goal time
        self._lock = threading.Lock()  # the state shared by the stream thread and this one
        self._stream_node = helper_node(f'{self.get_name()}_stream', self.get_namespace(),
                                        self.context, use_global_arguments=False)
        self._stream_thread: threading.Thread | None = None
        self._state_reader = JointStateReader()
        self._setpoints = SetpointPublishers(self._stream_node)
        self._plan_publisher = self.create_publisher(JointTrajectory, 'planned_trajectory',
                                                     LATCHED_QOS)
        # on the stream node, whose thread it paces; a silence counts from the start (a plant
        # whose clock runs unheard), and only while the clock runs past the newest state
        self._states = WatchedSubscription(
            self._stream_node, JointState, 'joint_states', self._on_joint_state, SENSOR_QOS,
            after=_RESUBSCRIBE_AFTER, counts=self._clock_ran_past_the_states,
            count_from_start=True, logger=self.get_logger())
        self._stream_spinning = threading.Event()  # the stream thread has run a timer
        self._stream_node.create_timer(_RESUBSCRIBE_AFTER / 4, self._resubscribe_if_silent,
                                       clock=Clock(clock_type=ClockType.STEADY_TIME))
        self._stream_node.create_subscription(ControlMode, 'control_mode',
                                              self._on_control_mode, MODE_SUBSCRIPTION_QOS)
        self.create_timer(_RELAY_PERIOD, self._relay,
                          clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.create_service(PlanTrajectory, 'plan_trajectory', self._on_plan)
        self.create_service(Trigger, 'stop_trajectory', self._on_stop)
        # A finished goal is kept for its result request only briefly: each one holds its whole
        # trajectory, and rclpy's default (900 s of the node's clock) made the planner grow by
        # 9 MiB a minute of walking in the soak.
        self._action_server = ActionServer(
            self, FollowTrajectory, 'follow_trajectory', execute_callback=self._on_execute,
            goal_callback=self._on_goal, cancel_callback=self._on_cancel,
            result_timeout=_RESULT_TIMEOUT)
        self.get_logger().info(
            f'planner ready: {len(PHYSICAL_JOINT_NAMES)} controllers at '
            f'{self._robot.timing.control_rate:g} Hz')

    def start_streaming(self) -> None:
        """Spin the stream node in its own thread (until the context shuts down).

        Returns once that thread has run the node's first timer: its executor runs the timers
        in a thread of its own, started when the node is added, which the real-time scheduling
        asked for next (:meth:`request_realtime_scheduling`) must find (started after it, it
        was seen left at the default scheduler).
        """
        self._stream_thread = threading.Thread(
            target=spin_nodes, args=(self._stream_node,), kwargs={'context': self.context},
            name='setpoint-stream', daemon=True)
        self._stream_thread.start()
        self._stream_spinning.wait(_STREAM_START_WAIT)

    def request_realtime_scheduling(self) -> bool:
        """Ask for ``SCHED_FIFO`` on the wall clock: the process below the loop, the stream in it.

        Called by :func:`main` once the stream thread runs. Every thread of the process is
        moved to ``timing.decision_priority``: the plans a step waits for then come ahead of
        every ordinary process, below the control loop. The stream thread is then moved up to
        the loop's own ``timing.realtime_priority``: the controllers expect its setpoints
        every period, and below the loop it was starved (setpoints up to 45 periods late in a
        real-time walk, the controllers' references standing still meanwhile). Nothing is
        asked in sim time, nor when the loop itself asks for nothing
        (``timing.realtime_priority`` 0), nor for a node built inside another process.
        """
        if self.get_parameter('use_sim_time').value:
            self.get_logger().info('default scheduling (sim time: no deadlines to meet)')
            return False
        timing = self._robot.timing
        granted = log_realtime_request(self.get_logger(), timing.decision_scheduling_priority)
        if granted and self._stream_thread is not None:
            moved, report = request_thread_priority(self._stream_thread.native_id,
                                                    timing.realtime_priority)
            (self.get_logger().info if moved else self.get_logger().warning)(
                f'setpoint stream: {report}')
        return granted

    def destroy_node(self) -> None:
        """Stop the stream thread, then destroy both nodes."""
        if self._stream_thread is not None:
            rclpy.try_shutdown(context=self.context)
            self._stream_thread.join(timeout=5.0)
        self._stream_node.destroy_node()
        destroy_actions(self)
        super().destroy_node()

    def stream_by_call(self, setpoint_sink) -> None:
        """Take the plant's states by call (:meth:`take_state`); hand the setpoints to a sink.

        For a plant and controllers in this process, in sim time: each setpoint is still
        published, and also given to ``setpoint_sink(stamp, positions, velocities,
        accelerations)`` [ns, rad, rad/s, rad/s^2]; the ``joint_states`` subscription goes.
        """
        self._setpoints.sink = setpoint_sink
        self._states.destroy()

    def take_state(self, message: JointState) -> None:
        """Take a joint state handed over by the plant in this process (stream_by_call)."""
        self._on_joint_state(message)

    def _relay(self) -> None:
        """End whole trajectories by the clock, complete ended goals, send feedback."""
        now = self.get_clock().now().nanoseconds
        with self._lock:
            self._streamer.on_clock(now)
            ended = self._streamer.take_ended()
            active = self._streamer.active
            feedback = None
            if active is not None and active.owner.goal_handle is not None:
                every = round(self._robot.timing.control_rate
                              / self._planner.stream.feedback_rate)
                if self._streamer.feedback_due(every) is not None:
                    feedback = self._feedback(active)
        if feedback is not None:
            active.owner.goal_handle.publish_feedback(feedback)
        for stream in ended:
            stream.owner.done.set_result(True)

    # ------------------------------------------------------------------ parameters
    def _apply_planner_parameters(self, section: PlannerParameters) -> None:
        self._planner = section
        self._planning = PlanningContext.from_parameters(self._robot, section)
        with self._lock:
            self._streamer.lookahead = section.stream.lookahead
            self._streamer.start_tolerance = section.stream.start_tolerance

    # ------------------------------------------------------------------ subscriptions
    def _resubscribe_if_silent(self) -> None:
        """Make the joint states' subscription anew when it stopped receiving (stream thread).

        Seen in sim-time walks with the loop in one process: the stream, starved while the
        planner planned, heard no joint state again (or none at all after a slow start) while
        the plant's clock ran on, and the motion it streamed stood still. A silence while the
        clock stands still too is a plant stopped or held, not the subscription's: left alone.
        In real time the clock always runs, and a plant gone costs a new subscription a second.
        """
        self._stream_spinning.set()
        self._states.check()

    def _clock_ran_past_the_states(self) -> bool:
        """Say whether the ROS clock ran well past the newest joint state (clock_ran_past)."""
        measured = self._streamer.measured
        newest = measured[0] if measured is not None else None
        return clock_ran_past(self.get_clock().now().nanoseconds, newest,
                              _CLOCK_AHEAD_PERIODS * self._period_ns,
                              self.get_parameter('use_sim_time').value)

    def _on_joint_state(self, message: JointState) -> None:
        measured = self._state_reader.positions(message)
        if measured is not None:
            with self._lock:
                active = self._streamer.active
                if active is not None and active.owner.goal_handle is not None \
                        and active.owner.goal_handle.is_cancel_requested:
                    active.cancel()
                self._streamer.on_state(*measured)

    def _on_control_mode(self, message: ControlMode) -> None:
        if mode_command_refusal(message.commander, message.base_gripper,
                                self.get_namespace()):
            return  # the controllers refuse it too, and say so
        tracking = message.mode in (ControlMode.COARSE, ControlMode.FINE)
        with self._lock:
            self._streamer.on_control_mode(tracking)

    # ------------------------------------------------------------------ planning service
    def _on_plan(self, request, response):
        try:
            result = plan(plan_request(request), self._planning)
        except PlanningError as error:
            response.success, response.message = False, str(error)
            self.get_logger().warning(f'plan_trajectory refused: {error}')
            return response
        samples = result.samples
        response.trajectory = trajectory_message(result.times, *samples)
        response.duration = result.duration
        response.time_optimal_bound = result.time_optimal_bound or 0.0
        response.success = True
        if request.execute:
            trajectory = SampledTrajectory(result.times, *samples)
            with self._lock:
                error = self._start_stream(trajectory, response.trajectory, None)[1]
            if error:
                response.success = False
                response.message = f'planned but not executed: {error}'
                return response
        else:
            self._plan_publisher.publish(response.trajectory)
        return response

    def _on_stop(self, request, response):
        now = self.get_clock().now().nanoseconds
        with self._lock:
            stopped = self._streamer.stop(now)
        response.success = stopped
        response.message = 'stopping the stream' if stopped else 'no stream is running'
        return response

    # ------------------------------------------------------------------ action
    def _on_goal(self, goal) -> GoalResponse:
        with self._lock:
            busy = self._streamer.active is not None
        if busy or self._reserved:
            self.get_logger().warning('follow_trajectory goal rejected: a stream is '
                                      'already running (cancel it first)')
            return GoalResponse.REJECT
        self._reserved = True
        if self._planner.send_whole_trajectories:
            # sent before the acceptance, which a sim-time supervisor holds the clock for: the
            # controllers have it before the plant steps on (started in execute, it came late)
            self._begun = self._begin(goal.trajectory, None)
        return GoalResponse.ACCEPT

    def _on_cancel(self, goal_handle) -> CancelResponse:
        now = self.get_clock().now().nanoseconds
        with self._lock:
            active = self._streamer.active
            if active is not None and active.owner.goal_handle is goal_handle:
                self._streamer.end_now(active, 'cancelled', now)
        return CancelResponse.ACCEPT

    async def _on_execute(self, goal_handle):
        result = FollowTrajectory.Result()
        try:
            begun, self._begun = self._begun, None
            active, error = begun or self._begin(goal_handle.request.trajectory, goal_handle)
            with self._lock:
                if active is not None:
                    active.owner.goal_handle = goal_handle
        finally:
            self._reserved = False
        if error:
            result.message = error
            goal_handle.abort()
            return result
        return await goal_result(goal_handle, result, active, self._lock, self._streamer)

    # ------------------------------------------------------------------ streaming
    def _begin(self, message: JointTrajectory, goal_handle) -> tuple[ActiveStream | None, str]:
        """Check a goal's trajectory and start it; return the stream and '' or None and why."""
        self._streamer.wait_for_state(_STREAM_START_WAIT)
        try:
            trajectory = sampled_trajectory(message, self._robot)
        except PlanningError as refusal:
            return None, str(refusal)
        with self._lock:
            return self._start_stream(trajectory, message, goal_handle)

    def _start_stream(self, trajectory: SampledTrajectory, message: JointTrajectory,
                      goal_handle) -> tuple[ActiveStream | None, str]:
        """Start streaming (lock held); return the stream and '' or None and the refusal."""
        try:
            active = self._streamer.start(trajectory, StreamGoal(goal_handle),
                                          self.get_clock().now().nanoseconds)
        except PlanningError as error:
            return None, str(error)
        message.header.stamp = to_time(active.stream.origin)
        self._plan_publisher.publish(message)
        return active, ''

    def _send(self, stamp: int, positions, velocities, accelerations) -> None:
        self._setpoints.send(stamp, positions, velocities, accelerations)  # the lock is held

    def _feedback(self, active: ActiveStream) -> FollowTrajectory.Feedback:
        """Where the stream is (lock held): at the setpoint of the state after the newest."""
        elapsed, fraction = self._streamer.progress(active)
        return FollowTrajectory.Feedback(
            time_from_start=elapsed, fraction=fraction,
            max_position_error=self._streamer.tracking_error(active.stream))


def _start(node: PlannerNode) -> None:
    node.start_streaming()
    node.request_realtime_scheduling()


def main(args=None) -> int:
    """Run the planner node until interrupted; exit codes of :mod:`walker_runtime.node_main`.

    The default executor: a goal's execution awaits its stream's end, and under the events
    executor an awaited future makes every spin return at once (a core burnt for the whole
    stream). The stream node, the busy one, keeps the events executor.
    """
    return run_node(PlannerNode, 'planner', args, start=_start,
                    executor=SingleThreadedExecutor)


if __name__ == '__main__':
    raise SystemExit(main())
