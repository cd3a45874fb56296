"""The UDP-on-loopback profile: selected in an environment, and taking effect in a node."""

import subprocess
import sys
from pathlib import Path

import pytest

from walker_bringup.run import parse_arguments
from walker_bringup.transport import (DEFAULT_TRANSPORT, PROFILES_VARIABLE, default_transport,
                                      graph_environment, udp_loopback_environment,
                                      udp_loopback_profile)

# A node that prints "ready" once its participant is up, then lives until its stdin closes.
_NODE = """
import sys
import rclpy
from rclpy.node import Node
from std_msgs.msg import Float64
rclpy.init()
node = Node('transport_probe')
node.create_subscription(Float64, 'probe', lambda message: None, 10)
print('ready', flush=True)
sys.stdin.read()
node.destroy_node()
rclpy.try_shutdown()
"""


def _receive_threads(env) -> set[str]:
    """Return the names of the Fast DDS receive threads of a node started in ``env``.

    Fast DDS names each listening thread after its transport and port: ``dds.udp.<port>``,
    ``dds.shm.<port>`` (``dds.shm.wdog`` is the shared-memory watchdog, no port).
    """
    child = subprocess.Popen([sys.executable, '-c', _NODE], env=env, stdin=subprocess.PIPE,
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        assert child.stdout.readline().strip() == 'ready'
        names = {(task / 'comm').read_text().strip()
                 for task in Path(f'/proc/{child.pid}/task').iterdir()}
    finally:
        child.stdin.close()
        child.wait(timeout=20)
    return {name for name in names
            if name.startswith(('dds.udp.', 'dds.shm.')) and name.split('.')[-1].isdigit()}


def test_the_profile_is_installed_and_selected_without_replacing_another():
    profile = udp_loopback_profile()
    assert profile.is_file() and '127.0.0.1' in profile.read_text()
    env = udp_loopback_environment({'ROS_DOMAIN_ID': '3'})
    assert env == {'ROS_DOMAIN_ID': '3', PROFILES_VARIABLE: str(profile)}
    assert udp_loopback_environment(env) == env  # selected twice: the same
    with pytest.raises(ValueError, match=PROFILES_VARIABLE):
        udp_loopback_environment({PROFILES_VARIABLE: '/etc/other_profiles.xml'})


def test_a_graph_runs_over_udp_on_loopback_unless_told_otherwise():
    """run_all.py's graph and --serve: a node restarted after a crash is heard as before."""
    assert DEFAULT_TRANSPORT == 'udp' and default_transport({'ROS_DOMAIN_ID': '3'}) == 'udp'
    # none asked for: chosen from the environment the graph starts in
    assert parse_arguments([]).transport is None
    assert parse_arguments(['--serve']).transport is None
    assert parse_arguments(['--transport', 'shm']).transport == 'shm'
    env = {'ROS_DOMAIN_ID': '3'}
    assert graph_environment(env) == udp_loopback_environment(env)
    assert graph_environment(env, 'shm') == env and graph_environment(env, 'shm') is not env
    own = {PROFILES_VARIABLE: '/etc/other_profiles.xml'}
    assert graph_environment(own, 'shm') == own  # the user's profile kept on shared memory
    with pytest.raises(ValueError, match=PROFILES_VARIABLE):
        graph_environment(own)
    with pytest.raises(ValueError, match="unknown transport 'tcp'"):
        graph_environment(env, 'tcp')
    with pytest.raises(SystemExit):
        parse_arguments(['--transport', 'tcp'])


def test_a_graph_with_peers_on_other_hosts_stays_reachable_from_them():
    """A ground station named in ROS_STATIC_PEERS: readers on 127.0.0.1 alone would not do."""
    ground = {'ROS_DOMAIN_ID': '3', 'ROS_STATIC_PEERS': '10.77.0.2'}
    assert default_transport(ground) == 'shm'
    assert graph_environment(ground, default_transport(ground)) == ground
    # the UDP-on-loopback profile inherited from a graph started before is not kept
    inherited = udp_loopback_environment(ground)
    assert graph_environment(inherited, default_transport(inherited)) == ground
    assert default_transport({**ground, 'ROS_STATIC_PEERS': ' '}) == 'udp'  # names none
    with pytest.raises(ValueError, match=r'ROS_STATIC_PEERS names peers on other hosts \(10.77'):
        graph_environment(ground, 'udp')


def test_a_node_with_the_profile_is_reached_over_udp_only(ros_env):
    """Without it the node also listens on shared memory (which LOCALHOST discovery keeps on)."""
    default = _receive_threads({k: v for k, v in ros_env.items() if k != PROFILES_VARIABLE})
    assert any(name.startswith('dds.shm.') for name in default), default
    chosen = _receive_threads(udp_loopback_environment(ros_env))
    assert chosen and all(name.startswith('dds.udp.') for name in chosen), chosen


# Sends 20 trajectories as large as a long coarse motion's (1,500 points of five joints, about
# 190 kB: fragments over UDP), each waited for as the planner waits
# (walker_planner.setpoints.ACK_WAIT), and prints how many were not acknowledged in time.
_TALKER = """
import sys, time
import rclpy
from rclpy.duration import Duration
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
from walker_runtime.qos import COMMAND_QOS
from walker_planner.setpoints import ACK_WAIT
rclpy.init()
node = rclpy.create_node('transport_trajectory_probe')
publisher = node.create_publisher(JointTrajectory, 'probe_trajectory', COMMAND_QOS)
deadline = time.monotonic() + 30.0
while publisher.get_subscription_count() < 1 and time.monotonic() < deadline:
    time.sleep(0.05)
time.sleep(0.5)
late = 0
for k in range(20):
    message = JointTrajectory(joint_names=['j1', 'j2', 'j3', 'j4', 'j5'])
    message.points = [JointTrajectoryPoint(positions=[0.001 * k] * 5, velocities=[0.1] * 5,
                                           accelerations=[0.2] * 5) for _ in range(1500)]
    publisher.publish(message)
    late += not publisher.wait_for_all_acked(Duration(seconds=ACK_WAIT))
    time.sleep(0.2)
print('late', late, flush=True)
node.destroy_node()
rclpy.try_shutdown()
"""
_LISTENER = """
import rclpy
from trajectory_msgs.msg import JointTrajectory
from walker_runtime.qos import COMMAND_QOS
rclpy.init()
node = rclpy.create_node('transport_trajectory_listener')
node.create_subscription(JointTrajectory, 'probe_trajectory', lambda message: None, COMMAND_QOS)
print('ready', flush=True)
rclpy.spin(node)
"""


def test_a_whole_trajectory_over_udp_is_acknowledged_within_the_planners_wait(ros_env):
    """A fragment lost on loopback is sent again at the next heartbeat: 0.1 s, not 3 s."""
    env = udp_loopback_environment(ros_env)
    listener = subprocess.Popen([sys.executable, '-c', _LISTENER], env=env,
                                stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                stderr=subprocess.STDOUT, text=True)
    try:
        assert listener.stdout.readline().strip() == 'ready'
        talker = subprocess.run([sys.executable, '-c', _TALKER], env=env, timeout=120,
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    finally:
        listener.kill()
        listener.wait(timeout=20)
    assert talker.stdout.strip().splitlines()[-1] == 'late 0', talker.stdout
