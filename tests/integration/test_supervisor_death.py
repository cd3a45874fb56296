"""A walk whose supervisor dies: its clients stop waiting within seconds, and say why.

``walkerctl walk-to`` waited for the result of its goal with no limit: with the supervisor
killed it kept a stale progress line and never exited. Now it watches the supervisor's status
and asks again for the result (:mod:`walker_teleop.goal_monitor`): a dead supervisor ends the
wait within seconds with exit code 3 and a message naming it, and a supervisor started again
answers for a goal it does not own (it has ended: its outcome is unknown to it) instead of
leaving its client waiting. The graph is the fault graph (every node a process, sim time, a
ROS domain of its own, discovery on loopback), which keeps a gripper attached throughout.
"""

import subprocess
import sys
import time

import pytest

from fault_graph import TEST_TIMEOUT, TIMEOUT, FaultGraph
from ros_test_support import REPO_ROOT, running_graph

pytestmark = [pytest.mark.integration, pytest.mark.timeout(TEST_TIMEOUT)]

# [s] wall time walkerctl may take to give up once the supervisor died: the silence it waits
# for (walker_teleop.core.goal_watch.SILENCE_LIMIT, 5 s) and a loaded machine's delays. It only
# guards against the hang: without the watch walkerctl never exits.
GIVE_UP = 60.0


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
