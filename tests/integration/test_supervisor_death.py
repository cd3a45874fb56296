"""A walk whose supervisor dies: its clients stop waiting within seconds, and say why.

``walkerctl walk-to`` waited for the result of its goal with no limit: with the supervisor
killed it kept a stale progress line and never exited. Now it watches the supervisor's status
and asks again for the result (:mod:`walker_teleop.goal_monitor`): a dead supervisor ends the
wait within seconds with exit code 3 and a message naming it. A supervisor started again
answers the result of a goal its dead predecessor accepted with the goal ABORTED and the
reason, not rclpy's UNKNOWN (the goal ids it ran are kept in a file beside its step-state
file). The graph is the fault graph (every node a process, sim time, a ROS domain of its own,
discovery on loopback), which keeps a gripper attached throughout.
"""

import subprocess
import sys
import time
from pathlib import Path

import pytest

from fault_graph import TEST_TIMEOUT, TIMEOUT, FaultGraph
from ros_test_support import REPO_ROOT, running_graph

pytestmark = [pytest.mark.integration, pytest.mark.timeout(TEST_TIMEOUT)]

# [s] wall time walkerctl may take to give up once the supervisor died: the silence it waits
# for (walker_teleop.core.goal_watch.SILENCE_LIMIT, 5 s) and a loaded machine's delays. It only
# guards against the hang: without the watch walkerctl never exits.
GIVE_UP = 60.0
# asks for a result, and the wall time each may take, on a loaded machine
ORPHAN_ASKS, ORPHAN_WAIT = 4, 20.0


@pytest.fixture(scope='module')
def graph(tmp_path_factory):
    with running_graph(lambda tmp, domain: FaultGraph(tmp, domain, grouped=True),
                       tmp_path_factory.mktemp('supervisor_death')) as running:
        yield running


def _in_insertion(graph, since: float) -> bool:
    """Say whether the walk's first step has reached its insertion since ``since``.

    The supervisor is killed there, as in the fault suite: its restart takes the step up.
    """
    from walker_msgs.msg import StepPhase

    return any(t >= since and m.phase == StepPhase.INSERTION for t, m in graph.phases)


def test_walkerctl_exits_3_naming_the_dead_supervisor_instead_of_waiting_forever(graph):
    step = graph.one_step()
    since = time.monotonic()
    walk = subprocess.Popen(
        [sys.executable, str(REPO_ROOT / 'scripts' / 'walkerctl'), 'walk-to', step.to_node],
        env=graph.group.env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        cwd=REPO_ROOT)
    try:
        graph.wait_until(lambda: _in_insertion(graph, since), TIMEOUT, 'the walk in insertion')
        graph.kill('supervisor')
        out, err = walk.communicate(timeout=GIVE_UP)
    finally:
        if walk.poll() is None:
            walk.kill()
            walk.wait()
    assert walk.returncode == 3, f'exit code {walk.returncode}\n{out}\n{err}'
    assert '/walker/supervisor has been silent for' in err, err
    assert f'the walk to {step.to_node} is unknown' in err, err
    assert 'reached' not in out and 'cancelling' not in err, (out, err)


def _orphan_answer(graph, goal_id: str):
    """Ask the supervisor for the result of goal ``goal_id`` (32 hex digits), as a client would."""
    from rclpy.action.client import ClientGoalHandle
    from unique_identifier_msgs.msg import UUID

    walk_client = graph.client.walk_client
    graph.wait_until(walk_client.server_is_ready, TIMEOUT, "the restarted supervisor's walk_to")
    # a request sent before the new server's reply writer matched this client is lost (the
    # dead server's endpoints may still count as matched): asking again is harmless
    for attempt in range(ORPHAN_ASKS):
        handle = ClientGoalHandle(walk_client, UUID(uuid=list(bytes.fromhex(goal_id))), None)
        try:
            return graph.client._wait(handle.get_result_async(), ORPHAN_WAIT, None,
                                      "the orphan's result")
        except TimeoutError:
            if attempt == ORPHAN_ASKS - 1:
                raise


def test_a_supervisor_started_again_aborts_the_goal_its_predecessor_left(graph):
    """The walk goal of the killed supervisor, asked for again, ends ABORTED with the reason."""
    import yaml
    from action_msgs.msg import GoalStatus

    ledger = Path(graph.group.env['ROS_HOME']) / 'walker' / 'walker_goals.yaml'
    if 'supervisor' not in graph.killed:  # run alone: a walk whose supervisor dies
        step = graph.one_step()
        since = time.monotonic()
        graph.start_walk(step.to_node)
        graph.wait_until(lambda: _in_insertion(graph, since), TIMEOUT, 'the walk in insertion')
        graph.kill('supervisor')
    running = yaml.safe_load(ledger.read_text())['running']
    assert [goal['action'] for goal in running] == ['walk_to'], running
    graph.restart('supervisor')
    graph.wait_until(lambda: 'orphaned' in (yaml.safe_load(ledger.read_text()) or {})
                     and not yaml.safe_load(ledger.read_text())['running'], TIMEOUT,
                     'the restarted supervisor reading its ledger')
    answer = _orphan_answer(graph, running[0]['goal_id'])
    assert answer.status == GoalStatus.STATUS_ABORTED, answer.status
    assert not answer.result.success
    assert 'died and was started again' in answer.result.message, answer.result.message
    assert running[0]['target_node'] in answer.result.message
    unknown = _orphan_answer(graph, '0' * 32)  # a goal nobody accepted stays unknown
    assert unknown.status == GoalStatus.STATUS_UNKNOWN, unknown.status
