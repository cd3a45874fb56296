"""The supervisor's clients of the planner and the plant (ROS layer of the walk runner).

:class:`SupervisorLinks` carries out the runner's requests to other nodes and hands their
answers back to it: :class:`~walker_supervisor.core.commands.PlanMotion` on
``plan_trajectory``, :class:`~walker_supervisor.core.commands.FollowMotion` and
:class:`~walker_supervisor.core.commands.CancelFollow` on ``follow_trajectory``,
:class:`~walker_supervisor.core.commands.RenewPlannerClient`,
:class:`~walker_supervisor.core.commands.GripperRequest` on the plant's ``gripper_command``,
:class:`~walker_supervisor.core.commands.StopOrphanStream` on ``stop_trajectory``. A request
waits up to :data:`SERVER_WAIT` for its server to be discovered (on a loaded machine discovery
has taken seconds; a planner restarted after a crash too), and is reported as failed after
that. In sim time (``sim.wait_for_decisions``) it also tells the plant how far it may run:
:class:`SimTimeRelease`.
"""

from __future__ import annotations

from collections.abc import Callable

from rclpy.action import ActionClient
from rclpy.node import Node
from rosgraph_msgs.msg import Clock as RosClock
from std_srvs.srv import Trigger
from walker_msgs.action import FollowTrajectory
from walker_msgs.srv import GripperCommand, PlanTrajectory

from walker_runtime.qos import COMMAND_QOS
from walker_supervisor.clocks import Clocks
from walker_supervisor.core.commands import (
    CancelFollow, FollowMotion, GripperRequest, PlanMotion, RenewPlannerClient,
    StopOrphanStream)
from walker_supervisor.core.decision_clock import DecisionClock
from walker_supervisor.core.health import Level, SourceStatus
from walker_supervisor.core.runner import ANSWER_WAIT, WalkRunner
from walker_supervisor.messages import plan_answer, plan_request_message

__all__ = ['SupervisorLinks', 'SimTimeRelease', 'SERVER_WAIT']

SERVER_WAIT = 5.0  # [s] steady: a request waits this long for its server to be discovered
_COMMANDS = (PlanMotion, FollowMotion, CancelFollow, RenewPlannerClient, GripperRequest,
             StopOrphanStream)


class SupervisorLinks:
    """The clients of the planner and the plant; answers go to ``runner``.

    ``answer(commands)`` carries out the commands the runner gives back for an answer.
    """

    def __init__(self, node: Node, runner: WalkRunner, clocks: Clocks,
                 answer: Callable[[list], None]) -> None:
        self._node, self._runner, self._clocks, self._answer = node, runner, clocks, answer
        self.plan_client = node.create_client(PlanTrajectory, 'plan_trajectory')
        self.follow_client = ActionClient(node, FollowTrajectory, 'follow_trajectory')
        self.gripper_client = node.create_client(GripperCommand, 'gripper_command')
        self._stop_client = node.create_client(Trigger, 'stop_trajectory')
        self._waiting: list[tuple] = []  # (deadline, ready, send, unavailable)
        self._streams: dict[int, object] = {}  # ticket -> accepted goal handle
        #: How far the plant may run in sim time: gripper commands unanswered hold it.
        self.decision_clock = DecisionClock(ANSWER_WAIT)

    def handles(self, command) -> bool:
        """Return True for a command this object carries out."""
        return isinstance(command, _COMMANDS)

    def execute(self, command) -> None:
        """Carry out a request of the runner (one :meth:`handles` says True of)."""
        if isinstance(command, PlanMotion):
            self._plan(command)
        elif isinstance(command, FollowMotion):
            self.when_ready(self.follow_client.server_is_ready, lambda: self._follow(command),
                            lambda: self._failed(command.ticket))
        elif isinstance(command, CancelFollow):
            handle = self._streams.pop(command.ticket, None)
            if handle is not None:
                handle.cancel_goal_async()
        elif isinstance(command, RenewPlannerClient):
            self._renew(command.service)
        elif isinstance(command, GripperRequest):
            self.when_ready(self.gripper_client.service_is_ready,
                            lambda: self._grip(command),
                            lambda: self._answer(self._runner.gripper_answered(
                                False, 'the plant gripper_command service is not available',
                                self._clocks.now())))
        elif isinstance(command, StopOrphanStream):
            self.when_ready(self._stop_client.service_is_ready, self._stop_orphan, lambda: None)

    # ------------------------------------------------------------------ waiting for servers
    def when_ready(self, ready: Callable[[], bool], send: Callable[[], None],
                   unavailable: Callable[[], None]) -> None:
        """Send a request now, or once its server is discovered (within SERVER_WAIT)."""
        if ready():
            send()
        else:
            self._waiting.append((self._clocks.steady() + SERVER_WAIT, ready, send,
                                  unavailable))

    def send_waiting(self) -> None:
        """Send the requests whose server is discovered; give up those waited for too long."""
        now = self._clocks.steady()
        for entry in list(self._waiting):
            deadline, ready, send, unavailable = entry
            if ready():
                self._waiting.remove(entry)
                send()
            elif now > deadline:
                self._waiting.remove(entry)
                unavailable()

    def statuses(self) -> list[SourceStatus]:
        """Whether the clients have discovered their servers (planner, plant).

        A server not discovered yet is reported as not heard from, so ``run_all.py`` counts the
        graph ready only once every one is.
        """
        servers = (('planner plan_trajectory service', self.plan_client.service_is_ready),
                   ('planner follow_trajectory action', self.follow_client.server_is_ready),
                   ('plant gripper_command service', self.gripper_client.service_is_ready))
        return [SourceStatus(name, Level.OK, 'discovered') if ready()
                else SourceStatus(name, Level.WARN, 'not heard from yet')
                for name, ready in servers]

    # ------------------------------------------------------------------ the planner
    def _plan(self, command: PlanMotion) -> None:
        def send() -> None:
            future = self.plan_client.call_async(plan_request_message(command.call))
            self._runner.request_sent(command.ticket, self._clocks.steady())
            future.add_done_callback(lambda f: self._answer(self._runner.plan_answered(
                command.ticket, plan_answer(f), self._clocks.now())))

        if command.ahead:  # planned ahead only with the planner there now: nothing waits
            if self.plan_client.service_is_ready():
                send()
            else:
                self._failed(command.ticket)
            return
        self.when_ready(lambda: self.plan_client.service_is_ready()
                        and self.follow_client.server_is_ready(), send,
                        lambda: self._failed(command.ticket))

    def _failed(self, ticket: int) -> None:
        self._answer(self._runner.request_failed(ticket, self._clocks.now()))

    def _follow(self, command: FollowMotion) -> None:
        sent = self.follow_client.send_goal_async(
            FollowTrajectory.Goal(trajectory=command.trajectory))
        self._runner.request_sent(command.ticket, self._clocks.steady())
        sent.add_done_callback(lambda f: self._accepted(command.ticket, f))

    def _accepted(self, ticket: int, future) -> None:
        handle = future.result()
        accepted = handle is not None and handle.accepted
        if accepted:
            self._streams[ticket] = handle
            handle.get_result_async().add_done_callback(lambda f: self._ended(ticket, f))
        self._answer(self._runner.follow_accepted(ticket, accepted, self._clocks.now()))

    def _ended(self, ticket: int, future) -> None:
        self._streams.pop(ticket, None)
        wrapped = future.result()
        result = None if wrapped is None else wrapped.result
        success = result is not None and result.success
        message = 'no result' if result is None else result.message
        self._answer(self._runner.follow_done(ticket, success, message, self._clocks.now()))

    def _renew(self, service: str) -> None:
        if service == 'plan_trajectory':
            self._node.destroy_client(self.plan_client)
            self.plan_client = self._node.create_client(PlanTrajectory, 'plan_trajectory')
        else:
            self.follow_client.destroy()
            self.follow_client = ActionClient(self._node, FollowTrajectory, 'follow_trajectory')

    def _stop_orphan(self) -> None:
        self._node.get_logger().warning('stopping any trajectory still streaming for an earlier '
                                        'supervisor')
        self._stop_client.call_async(Trigger.Request())

    # ------------------------------------------------------------------ the plant
    def _grip(self, request: GripperRequest) -> None:
        call = GripperCommand.Request(
            gripper=request.gripper,
            command=GripperCommand.Request.SCREW_IN if request.action == 'screw_in'
            else GripperCommand.Request.UNSCREW)
        future = self.gripper_client.call_async(call)
        self.decision_clock.command_sent(future, self._clocks.steady())
        future.add_done_callback(self._gripped)

    def _gripped(self, future) -> None:
        self.decision_clock.command_answered(future)
        response = future.result()
        success, message = ((False, 'no response from the plant') if response is None
                            else (response.success, response.message))
        self._answer(self._runner.gripper_answered(success, message, self._clocks.now()))


class SimTimeRelease:
    """Sim time: let the plant run up to the supervisor's next tick, or hold it where it is.

    Published on ``~/decided_until`` for a plant with ``sim.wait_for_decisions``. Held while
    a planner request is unanswered (:attr:`WalkRunner.awaiting_answer`) or a gripper command
    (for ``ANSWER_WAIT`` at most: :class:`DecisionClock`), or while a freed gripper waits for
    the sweep's plan: the motion it starts then begins at the same simulated time however long
    the answer takes. A request still waiting for its server to be discovered (a planner
    restarted: seconds on a loaded machine) does not hold it: a clock held that long starved
    the controllers of states, and they held on stale inputs.
    """

    def __init__(self, node: Node, runner: WalkRunner, links: SupervisorLinks,
                 clocks: Clocks, tick_timer) -> None:
        self._node, self._runner, self._links, self._clocks = node, runner, links, clocks
        self._timer = tick_timer
        self._publisher = node.create_publisher(RosClock, '~/decided_until', COMMAND_QOS)
        self._held_at: int | None = None  # [ns] ROS time the clock was first held at

    def release(self) -> None:
        """Publish how far the plant may run now."""
        wall = self._clocks.steady()
        clock = self._links.decision_clock
        busy = self._runner.awaiting_answer or clock.plan_awaited(self._runner.awaiting_plan,
                                                                  wall)
        now = self._node.get_clock().now().nanoseconds
        until = clock.decided_until(now, self._timer.time_until_next_call(), busy, wall)
        if until > now:
            self._held_at = None
        elif self._held_at is None:
            self._held_at = now
        message = RosClock()
        message.clock.sec, message.clock.nanosec = divmod(until, 1_000_000_000)
        self._publisher.publish(message)

    @property
    def holding(self) -> bool:
        """True while the clock is held and has stood still since.

        The plant steps no further than the time released, so its joint states and the
        controllers' answers stop: their silence is this node's doing. A clock that runs on
        (the plant does not wait) is not held.
        """
        return self._held_at is not None \
            and self._node.get_clock().now().nanoseconds == self._held_at
