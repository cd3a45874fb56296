"""Two real nodes in separate processes exchange a walker_msgs message over Fast DDS.

Each test runs in a ROS domain of its own with discovery on loopback; a listener in another
domain must hear nothing, which is what keeps parallel runs apart.
"""

import pytest

from ros_test_support import NodeProcess, isolated_domain, ros_environment

pytestmark = pytest.mark.integration

TALKER = """
import rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile, DurabilityPolicy, ReliabilityPolicy
from walker_msgs.msg import StepPhase
rclpy.init()
node = Node('phase_talker')
qos = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                 reliability=ReliabilityPolicy.RELIABLE)
pub = node.create_publisher(StepPhase, 'walker/phase', qos)
msg = StepPhase(phase=StepPhase.FINE, base_gripper='b', from_node='n1_1', to_node='n2_1',
                phase_progress=0.25, reason='integration test')
msg.header.stamp = node.get_clock().now().to_msg()
pub.publish(msg)
print('published', flush=True)
try:
    rclpy.spin(node)
except KeyboardInterrupt:
    pass
finally:
    node.destroy_node()
    rclpy.try_shutdown()
"""

LISTENER = """
import rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile, DurabilityPolicy, ReliabilityPolicy
from walker_msgs.msg import StepPhase
rclpy.init()
node = Node('phase_listener')
qos = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                 reliability=ReliabilityPolicy.RELIABLE)
got = []
node.create_subscription(StepPhase, 'walker/phase', got.append, qos)
print('listening', flush=True)
while rclpy.ok() and not got:
    rclpy.spin_once(node, timeout_sec=0.1)
m = got[0]
print(f'received phase={m.phase} base={m.base_gripper} {m.from_node}->{m.to_node} '
      f'progress={m.phase_progress} reason={m.reason!r}', flush=True)
node.destroy_node()
rclpy.try_shutdown()
"""


def test_latched_phase_message_crosses_processes(ros_env):
    with NodeProcess.python(TALKER, ros_env, 'talker') as talker:
        assert talker.wait_for_output('published', 20), talker.output
        # The listener joins late: transient-local durability must still deliver the phase.
        with NodeProcess.python(LISTENER, ros_env, 'listener') as listener:
            assert listener.wait_for_output('received', 20), listener.output
            listener.process.wait(timeout=10)
            assert ("received phase=3 base=b n1_1->n2_1 progress=0.25 "
                    "reason='integration test'") in listener.output
            assert listener.process.returncode == 0


def test_another_domain_hears_nothing(ros_env):
    with isolated_domain() as other_domain:
        other_env = ros_environment(other_domain)
        assert other_env['ROS_DOMAIN_ID'] != ros_env['ROS_DOMAIN_ID']
        with NodeProcess.python(TALKER, ros_env, 'talker') as talker, \
                NodeProcess.python(LISTENER, other_env, 'listener') as listener:
            assert talker.wait_for_output('published', 20), talker.output
            assert listener.wait_for_output('listening', 20), listener.output
            assert not listener.wait_for_output('received', 3.0), listener.output
