"""Talk to a running walker graph from a script: readiness, walking, hold, step reports.

Used by ``run_all.py``, the tests and the benchmarks. Every wait takes a ``should_stop``
callable, checked several times a second, so a caller that supervises processes can interrupt
a wait the moment a child dies.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger
from walker_msgs.action import Step, WalkTo
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from walker_msgs.msg import GripperStates, StepPhase, StepReport
from walker_msgs.srv import GripperCommand, PlanTrajectory

from walker_bringup.loop_health import (
    PLANT_STATUS_SUFFIX, SUPERVISOR_STATUS_SUFFIX, LoopHealth, loop_health, sources_not_heard)
from walker_runtime.qos import COMMAND_QOS, LATCHED_QOS, latched_qos
from walker_runtime.spinning import (
    TopicSampler, destroy_actions, helper_node, hidden_name)
from walker_teleop.core.goal_answer import ACCEPTED
from walker_teleop.goal_monitor import GoalLostError, GoalMonitor
from walker_teleop.goal_rejections import GoalRejectedError, GoalRejections
from walker_teleop.goal_sender import GoalSender

__all__ = ['GraphClient', 'GraphNotReadyError', 'WalkInterruptedError', 'GoalRejectedError',
           'Readiness', 'init_context']

_POLL = 0.1  # [s]
_REPORTS = latched_qos(100)


class GraphNotReadyError(RuntimeError):
    """The graph did not come up in time; the message lists what is missing."""


class WalkInterruptedError(RuntimeError):
    """A wait was interrupted by ``should_stop`` (a child died, or the user pressed Ctrl-C)."""


@dataclasses.dataclass
class Readiness:
    """What is up and what is still missing."""

    ready: list[str]
    missing: list[str]

    @property
    def complete(self) -> bool:
        """True when nothing is missing."""
        return not self.missing


class GraphClient:
    """A client node in the robot's namespace.

    Parameters
    ----------
    namespace : str
        The robot's namespace, e.g. ``/walker``.
    context : rclpy.context.Context, optional
        The rclpy context (initialised by the caller).
    """

    def __init__(self, namespace: str = '/walker', context=None) -> None:
        self.namespace = namespace
        self.node = helper_node('walker_graph_client', namespace, context)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.rejections = GoalRejections(self.node)
        self.walk_goals = GoalSender(self.node, WalkTo, 'walk_to', self.rejections)
        self.step_goals = GoalSender(self.node, Step, 'step', self.rejections)
        self.walk_client, self.step_client = self.walk_goals.client, self.step_goals.client
        self.hold_client = self.node.create_client(Trigger, 'hold')
        self.resume_client = self.node.create_client(Trigger, 'resume')
        self.gripper_client = self.node.create_client(GripperCommand, 'gripper_command')
        self.plan_client = self.node.create_client(PlanTrajectory, 'plan_trajectory')
        self.reports: list[StepReport] = []
        self.phase: StepPhase | None = None
        self.grippers: GripperStates | None = None
        self.joint_stamps: list[int] = []  # [ns] stamps of the last joint states received
        # The 500 Hz joint states are only looked at to see the loop closed: sampled on demand
        # (a callback per message would cost this process a good part of a core).
        self._sampler = TopicSampler('walker_graph_client_sampler', namespace, context)
        self._joint_states = self._sampler.subscribe(JointState, 'joint_states',
                                                     qos_profile_sensor_data)
        self.node.create_subscription(StepReport, 'step_reports', self.reports.append, _REPORTS)
        self.node.create_subscription(StepPhase, 'phase', self._on_phase, LATCHED_QOS)
        self.node.create_subscription(GripperStates, 'gripper_states', self._on_grippers,
                                      LATCHED_QOS)
        # the plant's record of the loop's timing, at 1 Hz (see loop_health)
        self.loop: LoopHealth | None = None
        self._plant_status = f'{namespace.rstrip("/")}/plant{PLANT_STATUS_SUFFIX}'
        # the supervisor's sources it has not heard from yet (None: no status of it yet); it
        # refuses a walk until it has heard from every one
        self.unheard: list[str] | None = None
        self._supervisor_status = f'{namespace.rstrip("/")}/supervisor{SUPERVISOR_STATUS_SUFFIX}'
        self.node.create_subscription(DiagnosticArray, '/diagnostics', self._on_diagnostics,
                                      COMMAND_QOS)
        self._process_status = None  # the /diagnostics publisher of report_process

    def _on_phase(self, msg: StepPhase) -> None:
        self.phase = msg

    def _on_grippers(self, msg: GripperStates) -> None:
        self.grippers = msg

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        for status in msg.status:
            if status.name == self._plant_status:
                health = loop_health(status.message, {v.key: v.value for v in status.values})
                self.loop = health or self.loop
            elif status.name == self._supervisor_status:
                self.unheard = sources_not_heard({v.key: v.value for v in status.values})

    @property
    def plant_stepping(self) -> bool:
        """True once joint states arrive with advancing stamps (the control loop is closed)."""
        taken = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec
                 for m in self._sampler.take(self._joint_states)]
        self.joint_stamps = (self.joint_stamps + taken)[-10:]
        stamps = self.joint_stamps
        return len(stamps) >= 2 and stamps[-1] > stamps[0]

    def report_process(self, node: str, level: int, message: str) -> None:
        """Publish a node process's status on ``/diagnostics`` (its death, its restart).

        ``level`` as ``diagnostic_msgs/DiagnosticStatus`` (0 OK, 1 WARN, 2 ERROR); the status
        is named ``<node> (process)``, so that the bag records which node died and when.
        """
        if self._process_status is None:
            self._process_status = self.node.create_publisher(DiagnosticArray, '/diagnostics',
                                                              COMMAND_QOS)
        array = DiagnosticArray(status=[DiagnosticStatus(
            level=bytes([level]), name=f'{node} (process)', message=message,
            hardware_id='walker_bringup')])
        array.header.stamp = self.node.get_clock().now().to_msg()
        self._process_status.publish(array)

    def close(self) -> None:
        """Destroy the client node."""
        self.executor.remove_node(self.node)
        destroy_actions(self.node)
        self.node.destroy_node()
        self._sampler.destroy()

    # ------------------------------------------------------------------ waiting
    def spin_for(self, seconds: float) -> None:
        """Process callbacks for a while (wall time)."""
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=min(_POLL, max(0.0, deadline - time.monotonic())))

    def _wait(self, future, timeout: float, should_stop: Callable[[], bool] | None, what: str,
              answered_otherwise: Callable[[], bool] | None = None):
        """Spin until ``future`` is done (its result) or ``answered_otherwise()`` (None)."""
        done = self._wait_until(future.done, timeout, should_stop, what, answered_otherwise)
        return future.result() if done else None

    def _wait_until(self, done: Callable[[], object], timeout: float,
                    should_stop: Callable[[], bool] | None, what: str,
                    answered_otherwise: Callable[[], bool] | None = None) -> bool:
        """Spin until ``done()`` (True) or ``answered_otherwise()`` (False).

        Raises
        ------
        WalkInterruptedError
            ``should_stop()`` said so first.
        TimeoutError
            Neither within ``timeout`` [s].
        """
        deadline = time.monotonic() + timeout
        while not done():
            if should_stop is not None and should_stop():
                raise WalkInterruptedError(f'interrupted while waiting for {what}')
            if answered_otherwise is not None and answered_otherwise():
                return False
            if time.monotonic() > deadline:
                raise TimeoutError(f'no answer to {what} within {timeout:.0f} s')
            self.executor.spin_once(timeout_sec=_POLL)
        return True

    def readiness(self, node_names: list[str]) -> Readiness:
        """Which expected nodes and servers of the walker graph are up now."""
        present = {f'{ns.rstrip("/")}/{name}' for name, ns
                   in self.node.get_node_names_and_namespaces()}
        ready, missing = [], []
        for name in node_names:
            (ready if name in present else missing).append(name)
        servers = {'walk_to action': self.walk_client.server_is_ready(),
                   'step action': self.step_client.server_is_ready(),
                   'hold service': self.hold_client.service_is_ready(),
                   'gripper_command service': self.gripper_client.service_is_ready(),
                   'plan_trajectory service': self.plan_client.service_is_ready(),
                   'joint states advancing': self.plant_stepping,
                   'gripper states': self.grippers is not None,
                   'the supervisor hearing '
                   + (', '.join(self.unheard) if self.unheard else 'every source'):
                   self.unheard == []}
        for name, up in servers.items():
            (ready if up else missing).append(name)
        return Readiness(ready, missing)

    def live_nodes(self, wait: float = 1.5, confirm: float = 6.0) -> list[str]:
        """Names of the nodes of a live graph already in this namespace (empty: none).

        Nodes are discovered within a fraction of a second; a graph counts as live only when
        one of them speaks (joint states, or the latched phase or gripper states), since DDS
        remembers the nodes of a process killed by force until their lease runs out (up to
        20 s). Spins up to ``wait`` seconds (wall time) for nodes, less when a live graph is
        found: on a loaded machine discovery took longer than the 0.5 s first looked for, and
        a live graph went unseen. Once nodes are seen, it waits up to ``confirm`` seconds in
        all for one of them to speak: a graph running flat out in sim time on a loaded
        machine matched the probe's subscriptions later than 1.5 s, and was taken for dead.
        """
        start = time.monotonic()
        while True:
            self.spin_for(_POLL)
            names = sorted(name for name, ns in self.node.get_node_names_and_namespaces()
                           if ns.rstrip('/') == self.namespace.rstrip('/')
                           and name != hidden_name(name))  # a tool's or helper's node
            live = self.phase is not None or self.grippers is not None \
                or bool(self._sampler.take(self._joint_states))
            if names and live:
                return names
            if time.monotonic() - start > (max(wait, confirm) if names else wait):
                return []

    def wait_until_ready(self, node_names: list[str], timeout: float,
                         progress: Callable[[Readiness], None] | None = None,
                         should_stop: Callable[[], bool] | None = None) -> Readiness:
        """Wait until every expected node and server is up (checked, not slept).

        Raises
        ------
        GraphNotReadyError
            After ``timeout`` [s], naming what is still missing.
        WalkInterruptedError
            When ``should_stop`` returns True.
        """
        deadline = time.monotonic() + timeout
        while True:
            self.spin_for(_POLL)
            state = self.readiness(node_names)
            if progress is not None:
                progress(state)
            if state.complete:
                return state
            if should_stop is not None and should_stop():
                raise WalkInterruptedError('interrupted while bringing the graph up')
            if time.monotonic() > deadline:
                raise GraphNotReadyError('the graph did not come up within '
                                    f'{timeout:.0f} s; missing: {", ".join(state.missing)}')

    # ------------------------------------------------------------------ commands
    def walk_to(self, target: str, timeout: float,
                feedback: Callable[[WalkTo.Feedback], None] | None = None,
                should_stop: Callable[[], bool] | None = None) -> tuple[int, WalkTo.Result]:
        """Send a ``walk_to`` goal and wait for its result; return (status, result).

        On interruption the goal is cancelled (the step under way finishes) before
        :class:`WalkInterruptedError` propagates. A goal the supervisor rejects raises
        :class:`GoalRejectedError` with its reason.
        """
        goal = WalkTo.Goal(target_node=target)
        return self._run_goal(self.walk_goals, goal, timeout, feedback, should_stop,
                              f'the walk to {target}')

    def step(self, target: str, timeout: float,
             feedback: Callable[[Step.Feedback], None] | None = None,
             should_stop: Callable[[], bool] | None = None) -> tuple[int, Step.Result]:
        """Send a ``step`` goal and wait for its result; return (status, result)."""
        return self._run_goal(self.step_goals, Step.Goal(target_node=target), timeout,
                              feedback, should_stop, f'the step to {target}')

    def _run_goal(self, sender: GoalSender, goal, timeout, feedback, should_stop, what):
        if not sender.client.wait_for_server(timeout_sec=min(timeout, 10.0)):
            raise GraphNotReadyError(f'no action server for {what}')
        deadline = time.monotonic() + min(timeout, 2.0)
        while not self.rejections.matched and time.monotonic() < deadline:
            self.spin_for(_POLL)  # the reason of a rejection is heard only once matched
        sent = sender.send(goal, feedback)
        self._wait_until(sent.answer, timeout, should_stop, f'acceptance of {what}')
        if sent.answer() != ACCEPTED:
            raise GoalRejectedError(sender.action, goal.target_node, self.rejections.reason(
                sender.action, goal.target_node, sent.sent_at, self.spin_for))
        handle = sent.handle()
        result = handle.get_result_async()
        monitor = GoalMonitor(self.node, self.namespace, what)
        probed: list = []

        def stop() -> bool:  # a supervisor dead or started again cannot answer: stop waiting
            end = None if result.done() else monitor.check(handle, result)
            if end is not None:
                probed.append(end)
            return should_stop is not None and should_stop()

        try:
            wrapped = self._wait(result, timeout, stop, what, lambda: bool(probed))
        except GoalLostError as error:
            raise GraphNotReadyError(str(error)) from None
        except (WalkInterruptedError, TimeoutError):
            handle.cancel_goal_async()
            self.spin_for(0.2)
            raise
        finally:
            monitor.close()
        wrapped = wrapped if wrapped is not None else probed[0]
        return wrapped.status, wrapped.result

    def call_trigger(self, which: str, timeout: float = 5.0) -> Trigger.Response:
        """Call the supervisor's ``hold`` or ``resume`` service."""
        client = {'hold': self.hold_client, 'resume': self.resume_client}[which]
        if not client.wait_for_service(timeout_sec=timeout):
            raise GraphNotReadyError(f'the {which} service is not available')
        return self._wait(client.call_async(Trigger.Request()), timeout, None, which)


def init_context(domain_id: int | None = None):
    """Create and initialise an rclpy context (optionally in a given domain)."""
    context = rclpy.context.Context()
    kwargs = {} if domain_id is None else {'domain_id': domain_id}
    rclpy.init(context=context, **kwargs)
    return context
