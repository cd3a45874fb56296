"""A goal whose answer is lost is still known accepted (or rejected) and followed to its result.

Over a slow link the server's response to a goal request can be dropped by Fast DDS while the
goal runs (walker_teleop.core.goal_answer); a client waiting for that response alone gives up
with exit code 3 after printing the walk's progress to its end. Here the client's executor
discards every goal response while a stand-in supervisor in the same process runs or rejects
the goal; everything else travels over DDS in the test's own domain.
"""

import threading
import time

import pytest
from action_msgs.msg import GoalStatus
from rclpy.action import ActionServer, GoalResponse
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from walker_msgs.action import WalkTo
from walker_msgs.msg import GoalRejection

from walker_runtime.qos import LATCHED_QOS
from walker_runtime.spinning import destroy_actions
from walker_teleop.core.goal_answer import ACCEPTED, REJECTED, goal_answer

NAMESPACE, TARGET, PATH = '/walker', 'n1_3', ['n1_3']
REFUSAL = "n1_3 is not reachable from gripper b's node"
WAIT = 20.0  # [s] the client's timeout: generous for a loaded machine (run_goal raises at it)


@pytest.mark.parametrize('response, seen_running, rejection_heard, answer', [
    (True, False, False, ACCEPTED), (False, True, False, REJECTED),  # the response wins
    (None, True, False, ACCEPTED), (None, True, True, ACCEPTED),
    (None, False, True, REJECTED), (None, False, False, '')])
def test_the_answer_is_the_response_else_the_goal_seen_running_else_a_rejection_heard(
        response, seen_running, rejection_heard, answer):
    assert goal_answer(response, seen_running, rejection_heard) == answer


class _StandInSupervisor:
    """A ``walk_to`` server that publishes feedback and succeeds, or rejects with the reason."""

    def __init__(self, context, reject: bool, feedback: bool, duration: float = 0.5) -> None:
        self.node = Node('supervisor', namespace=NAMESPACE, context=context,
                         start_parameter_services=False)
        self._reject, self._feedback, self._duration = reject, feedback, duration
        self._rejections = self.node.create_publisher(GoalRejection, 'goal_rejections',
                                                      LATCHED_QOS)
        ActionServer(self.node, WalkTo, 'walk_to', self._execute,
                     goal_callback=self._on_goal)
        self._executor = SingleThreadedExecutor(context=context)
        self._executor.add_node(self.node)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        while not self._stop.is_set():
            self._executor.spin_once(timeout_sec=0.05)

    def _on_goal(self, goal) -> GoalResponse:
        if not self._reject:
            return GoalResponse.ACCEPT
        self._rejections.publish(GoalRejection(action='walk_to', target_node=goal.target_node,
                                               reason=REFUSAL))
        return GoalResponse.REJECT

    def _execute(self, handle) -> WalkTo.Result:
        for phase in range(3 if self._feedback else 0):
            handle.publish_feedback(WalkTo.Feedback(step_count=1, phase=phase, from_node='n0_3',
                                                    to_node=TARGET))
            time.sleep(0.1)
        end = time.monotonic() + self._duration
        while time.monotonic() < end:
            if self._feedback:
                handle.publish_feedback(WalkTo.Feedback(step_count=1, phase=2,
                                                        from_node='n0_3', to_node=TARGET))
            time.sleep(0.2)
        handle.succeed()
        return WalkTo.Result(success=True, steps_taken=1, duration=0.5, path=PATH)

    def close(self) -> None:
        self._stop.set()
        self._thread.join()
        self._executor.remove_node(self.node)
        destroy_actions(self.node)
        self.node.destroy_node()


@pytest.fixture
def teleop(rclpy_context):
    from walker_teleop.client import TeleopClient

    client = TeleopClient(NAMESPACE, rclpy_context, timeout=WAIT)
    yield client
    client.close()


def _lose_goal_responses(monkeypatch, teleop) -> None:
    action_client = teleop.goals['walk_to'].client
    take = action_client.take_data

    def take_without_goal_responses():
        data = take()
        data.pop('goal', None)
        return data

    monkeypatch.setattr(action_client, 'take_data', take_without_goal_responses)


@pytest.mark.parametrize('feedback', [True, False], ids=['with feedback', 'status alone'])
def test_a_walk_whose_goal_response_is_lost_is_followed_to_its_result(
        monkeypatch, rclpy_context, teleop, feedback):
    _lose_goal_responses(monkeypatch, teleop)
    supervisor = _StandInSupervisor(rclpy_context, reject=False, feedback=feedback)
    heard = []
    try:
        status, result = teleop.run_goal('walk_to', TARGET, heard.append, lambda: None)
    finally:
        supervisor.close()
    assert status == GoalStatus.STATUS_SUCCEEDED
    assert (result.success, list(result.path)) == (True, PATH)
    assert [f.phase for f in heard][:3] == ([0, 1, 2] if feedback else [])


def test_a_rejected_walk_whose_goal_response_is_lost_says_why(monkeypatch, rclpy_context,
                                                                teleop):
    from walker_teleop.client import GoalRejectedError

    _lose_goal_responses(monkeypatch, teleop)
    supervisor = _StandInSupervisor(rclpy_context, reject=True, feedback=False)
    try:
        with pytest.raises(GoalRejectedError) as rejection:
            teleop.run_goal('walk_to', TARGET, lambda f: None, lambda: None)
    finally:
        supervisor.close()
    assert rejection.value.reason == REFUSAL


def test_a_walk_answered_normally_still_runs_to_its_result(rclpy_context, teleop):
    supervisor = _StandInSupervisor(rclpy_context, reject=False, feedback=True)
    try:
        status, result = teleop.run_goal('walk_to', TARGET, lambda f: None, lambda: None)
    finally:
        supervisor.close()
    assert (status, result.steps_taken) == (GoalStatus.STATUS_SUCCEEDED, 1)


@pytest.mark.parametrize('feedback', [True, False], ids=['with feedback', 'silent'])
def test_a_walk_is_followed_while_its_feedback_comes_without_the_supervisors_status(
        monkeypatch, rclpy_context, teleop, feedback):
    """The goal's feedback is the supervisor's own voice: as good a sign of life as its status.

    Over a thin link the client's ``/diagnostics`` reader can take longer to be matched than
    the silence allowed; the stand-in publishes no status at all. Silent as well, it is lost.
    """
    import functools

    from walker_teleop import goal_monitor
    from walker_teleop.client import ServerLostError

    silence = 1.0  # [s]: the walk lasts 2.5 times as long
    monkeypatch.setattr(goal_monitor, 'GoalWatch',
                        functools.partial(goal_monitor.GoalWatch, silence_limit=silence))
    supervisor = _StandInSupervisor(rclpy_context, reject=False, feedback=feedback,
                                    duration=2.5 * silence)
    try:
        if feedback:
            status, result = teleop.run_goal('walk_to', TARGET, lambda f: None, lambda: None)
            assert (status, result.steps_taken) == (GoalStatus.STATUS_SUCCEEDED, 1)
        else:
            with pytest.raises(ServerLostError, match='has been silent for'):
                teleop.run_goal('walk_to', TARGET, lambda f: None, lambda: None)
    finally:
        supervisor.close()
