"""A robot host and an operator's ground host apart, over a link that is cut and degraded.

The test makes two network namespaces joined by a veth pair (``walker_bringup.host_link``),
named after its process id, and removes them however it ends. On the "robot" host,
``run_all.py --serve --sim-time`` runs the graph (recording its bag) and a monitor prints
every phase and gripper state the robot publishes; on the "ground" host, a recorder records
what the operator sees and ``walkerctl`` drives. Discovery crosses the link as a ground
station's would: LOCALHOST on each host, the other end named in ``ROS_STATIC_PEERS``.

The operator starts a step from the ground; in its coarse motion the link is cut. The ground
client notices within seconds that the supervisor has gone silent and exits with code 3; the
robot finishes the step on its own (its monitor sees the step end, with the link still down);
the link comes back; the operator reconnects (``walkerctl status`` shows the step done) and
the re-sent goal is answered as reached. Then the link is slowed to a thin one (a token
bucket: ``tc netem`` is not in every kernel) and the operator walks one more step over it. Each
host has a ``/dev/shm`` of its own, as two machines do. Throughout, the robot's bag has a
gripper attached in every gripper state, the ground's bag holds nothing from while the link was
down, and both bags are readable.
"""

import os
import subprocess
import sys
import time

import pytest

from ros_test_support import REPO_ROOT, NodeProcess, isolated_domain, ros_environment

pytestmark = [pytest.mark.ground_station, pytest.mark.integration, pytest.mark.timeout(600)]

TIMEOUT = 180.0  # [s] wall clock, for a loaded shared machine
#: [s] wall clock from the cut until walkerctl has exited: the supervisor's status is judged
#: silent after walker_teleop.core.goal_watch.SILENCE_LIMIT (5 s); the rest is for the load
NOTICE_LIMIT = 25.0
PREFIX = 'wkn'  # the test's namespaces: wkn<pid>-robot, wkn<pid>-ground
FIRST, SECOND = 'n1_2', 'n1_3'  # one step from the start, and one step on
#: The thin link: 1 Mbit/s each way, a packet that would wait over 0.3 s is dropped.
THIN_RATE, THIN_LATENCY = 1e6, 0.3

#: Prints every phase and gripper state the robot publishes (run on the robot host).
MONITOR = """
import sys, rclpy
from walker_msgs.msg import GripperStates, StepPhase
from walker_runtime.qos import LATCHED_QOS
from walker_teleop.core.status import GRIPPER_STATE_NAMES, PHASE_NAMES, name_of
rclpy.init()
node = rclpy.create_node('ground_link_monitor', namespace=sys.argv[1])
node.create_subscription(StepPhase, 'phase', lambda m: print(
    'phase', name_of(m.phase, PHASE_NAMES), m.base_gripper, flush=True), LATCHED_QOS)
node.create_subscription(GripperStates, 'gripper_states', lambda m: print('grippers', ' '.join(
    f'{g.name}={name_of(g.state, GRIPPER_STATE_NAMES)}@{g.node}' for g in m.grippers),
    flush=True), LATCHED_QOS)
try:
    rclpy.spin(node)
except KeyboardInterrupt:
    pass
"""


@pytest.fixture
def hosts():
    """Make the robot and ground hosts of this test; remove them however it ends."""
    from walker_bringup.core.host_link import plan_host_link
    from walker_bringup.host_link import LinkedHosts, remove_stale

    if os.geteuid() != 0:
        pytest.skip('making network namespaces needs root (CAP_NET_ADMIN)')
    remove_stale(PREFIX)  # what a killed earlier run of this test left, never another's
    with LinkedHosts(plan_host_link(f'{PREFIX}{os.getpid()}')) as linked:
        yield linked


#: Lists the nodes a participant on a host discovers in 10 s.
NODE_LISTER = """
import time, rclpy
rclpy.init()
node = rclpy.create_node('ground_link_lister')
end = time.monotonic() + 10.0
while time.monotonic() < end:
    rclpy.spin_once(node, timeout_sec=0.2)
print('nodes heard:', sorted(node.get_node_names_and_namespaces()))
"""


def _link_report(hosts, env) -> str:
    """Say what each host has: addresses, link state, UDP sockets, the nodes it hears."""
    lines = []
    for role in ('robot', 'ground'):
        for argv in (['ip', '-o', 'addr'], ['ip', '-o', 'link'], ['ss', '-ulpn'],
                     [sys.executable, '-c', NODE_LISTER]):
            done = subprocess.run(hosts.command(role, argv), env=hosts.environment(role, env),
                                  capture_output=True, text=True, timeout=60)
            lines.append(f'--- {role}: {" ".join(argv[:3])}\n{done.stdout}{done.stderr}')
    return '\n'.join(lines)


def _walkerctl(hosts, env, namespace: str, *args: str) -> list[str]:
    return hosts.command('ground', [sys.executable, str(REPO_ROOT / 'scripts' / 'walkerctl'),
                                    '--namespace', namespace, '--timeout', '60', *args])


def _run(hosts, env, namespace: str, *args: str) -> tuple[int, str]:
    with NodeProcess(_walkerctl(hosts, env, namespace, *args), env, 'walkerctl') as ctl:
        code = ctl.process.wait(timeout=TIMEOUT)
        return code, ctl.output


def _ground_recorder(hosts, env, namespace: str, bag) -> NodeProcess:
    from walker_bringup.graph import NodeSpec
    from walker_core.robot_parameters import default_parameter_file

    topics = "['phase', 'gripper_states', 'step_reports', '/diagnostics']"
    spec = NodeSpec('walker_bag', 'recorder_node', 'ground_recorder', namespace,
                    str(default_parameter_file()),
                    (('use_sim_time', 'false'), ('recorder.directory', str(bag.parent)),
                     ('recorder.bag_name', bag.name), ('recorder.topics', topics)))
    return NodeProcess(hosts.command('ground', spec.command()), env, 'ground_recorder')


def _own_status(recorded) -> bool:
    """Tell whether a recorded message is the ground recorder's own status (made on ground)."""
    return recorded.topic == '/diagnostics' and all(
        'ground_recorder' in status.name for status in recorded.message.status)


def _since(process: NodeProcess, mark: int, text: str, timeout: float) -> bool:
    """Wait until ``text`` appears in the output after its first ``mark`` characters."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if text in process.output[mark:]:
            return True
        time.sleep(0.1)
    return False


def test_the_robot_finishes_its_step_alone_when_the_link_is_cut_and_the_operator_goes_on(
        hosts, tmp_path):
    from walker_msgs.msg import GripperState

    from walker_bag.core.bag_reader import read_messages
    from walker_bringup.core.host_link import TokenBucket

    namespace = f'/walker_link_{os.getpid()}'
    out, ground_bag = tmp_path / 'run', tmp_path / 'ground' / 'bag'
    with isolated_domain() as domain:
        env = ros_environment(domain)
        robot_env, ground_env = hosts.environment('robot', env), hosts.environment('ground', env)
        run_all = [sys.executable, str(REPO_ROOT / 'scripts' / 'run_all.py'), '--serve',
                   '--sim-time', '--no-report', '--namespace', namespace, '--out', str(out)]
        with NodeProcess(hosts.command('robot', run_all), robot_env, 'run_all') as run:
            assert run.wait_for_output('[walker] serving in namespace', TIMEOUT), run.output
            # the ground named in ROS_STATIC_PEERS: not the loopback-only profile
            assert 'the graph runs on shm' in run.output, run.output
            # two machines share no memory: the robot's shared-memory ports are its own
            ground_memory = subprocess.run(hosts.command('ground', ['ls', '-A', '/dev/shm']),
                                           capture_output=True, text=True, check=True).stdout
            assert ground_memory == '', ground_memory
            monitor = NodeProcess(hosts.command('robot', [sys.executable, '-c', MONITOR,
                                                          namespace]), robot_env, 'monitor')
            recorder = _ground_recorder(hosts, ground_env, namespace, ground_bag)
            with monitor, recorder:
                code, said = _run(hosts, ground_env, namespace, 'status')
                assert code == 0 and 'IDLE' in said, f'{said}\n{_link_report(hosts, env)}'

                # the step starts from the ground; in its coarse motion the link is cut
                step = NodeProcess(_walkerctl(hosts, ground_env, namespace, 'step', FIRST),
                                   ground_env, 'walkerctl step')
                with step:
                    assert step.wait_for_output(': coarse', TIMEOUT), step.output
                    mark = len(monitor.output)
                    hosts.cut()
                    cut_at, cut_ns = time.monotonic(), time.time_ns()
                    try:
                        code = step.process.wait(timeout=NOTICE_LIMIT)
                    except Exception:
                        raise AssertionError(f'walkerctl still waiting {NOTICE_LIMIT:g} s after '
                                             f'the cut:\n{step.output}') from None
                    noticed = time.monotonic() - cut_at
                    assert code == 3, step.output
                    assert 'has been silent for' in step.output, step.output
                    # on its own, the robot completes the step, the link still down
                    assert _since(monitor, mark, 'phase IDLE b', TIMEOUT), monitor.output[mark:]
                    assert f'b=attached@{FIRST}' in monitor.output[mark:], monitor.output[mark:]
                    assert 'SAFE_HOLD' not in monitor.output[mark:], monitor.output[mark:]
                    hosts.restore()
                    restored_ns = time.time_ns()
                # the operator reconnects and sees the step done; the goal re-sent is reached
                code, said = _run(hosts, ground_env, namespace, 'status')
                assert code == 0, said
                assert 'IDLE, base gripper b' in said and f'attached at {FIRST}' in said, said
                code, said = _run(hosts, ground_env, namespace, 'walk-to', FIRST)
                assert code == 0 and f'reached {FIRST} in 0 steps' in said, said

                # over a thin link (a token bucket: netem's delay and loss are not in every
                # kernel, and not in this one's)
                hosts.degrade(TokenBucket(THIN_RATE, latency=THIN_LATENCY))
                started = time.monotonic()
                code, said = _run(hosts, ground_env, namespace, 'walk-to', SECOND)
                thin = time.monotonic() - started
                queues = hosts.queue_counts()
                hosts.clear()
                assert code == 0 and f'reached {SECOND} in 1 steps' in said, said
                # the bucket did slow the link: what the robot sent had to wait for the rate
                assert queues['robot'].overlimits > 0, queues
                recorder.stop(timeout=30.0)
            assert run.stop(timeout=60.0) == 0, run.output
    print(f'walkerctl noticed the cut after {noticed:.1f} s; a step over the thin link took '
          f'{thin:.1f} s from the start of walkerctl to its answer; the queues: {queues}')
    robot_states = [m.message for m in read_messages(out / 'bag', [f'{namespace}/gripper_states'])]
    assert robot_states, 'the robot bag holds no gripper states'
    for states in robot_states:
        assert any(g.state == GripperState.ATTACHED for g in states.grippers), states
    reports = [m.message.to_node for m in read_messages(out / 'bag',
                                                        [f'{namespace}/step_reports'])]
    assert reports == [FIRST, SECOND], reports
    ground = list(read_messages(ground_bag))
    assert ground, 'the ground bag is empty'
    # nothing reached the ground while the link was down (half a second for what was in flight)
    during = [m for m in ground if cut_ns + 500_000_000 < m.log_time_ns < restored_ns
              and not _own_status(m)]
    assert not during, [(m.topic, m.log_time_ns - cut_ns) for m in during[:5]]
    assert any(m.log_time_ns > restored_ns and m.topic == f'{namespace}/step_reports'
               for m in ground), 'the ground bag missed the step walked after the link came back'
