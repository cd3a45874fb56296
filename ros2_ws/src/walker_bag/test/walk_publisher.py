"""Publishers of the walker's message types, run as a process by the recorder's tests.

Modes (``python walk_publisher.py <mode> [count]``), all in the namespace ``/walker`` with the
QoS of docs/architecture.md:

- ``latched``: publishes one ``walker_msgs/StepPhase`` on ``phase`` (reliable, transient
  local), prints ``published``, and keeps it available until interrupted.
- ``burst <n>``: waits until a subscriber (the recorder) is matched on every topic, then
  publishes ``n`` messages on each topic (best-effort ones at the 500 Hz control rate) and
  prints ``published <topic> <n>`` for each topic and ``done``. The reliable publishers keep
  ``n`` messages of history, so none is overwritten before it is delivered: every one reaches
  the recorder. Message ``i`` carries ``i`` in a field, so a test can check what arrived.
- ``stream``: publishes joint states at 500 Hz and controller states at 100 Hz until
  interrupted; prints ``streaming`` after the first of each.
- ``stall <seconds>``: waits until the recorder is matched on every topic, prints
  ``streaming``, then for ``seconds`` publishes joint states (best effort) at 500 Hz,
  controller states (reliable, a history of every message: none is ever overwritten) at
  100 Hz and gripper states (latched, depth 1, as the plant) at 10 Hz; then prints
  ``published <topic> <n>`` for each and ``done``.
- ``simclock``: publishes ``/clock`` from ``SIM_START`` seconds on, one control period per
  step, and joint states stamped with it, as the plant does in sim-time mode; prints
  ``streaming`` once it runs.
"""

import sys
import time

import rclpy
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from rclpy.time import Time
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
from walker_msgs.msg import ControllerState, GripperState, GripperStates, StepPhase

JOINTS = ['a_yaw_joint', 'a_pitch_joint', 'vertex_joint', 'b_pitch_joint', 'b_yaw_joint']
RELIABLE = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
MATCH_TIMEOUT = 30.0
CONTROL_PERIOD = 0.002
SIM_START = 1000.0


def joint_state(node, i):
    msg = JointState(name=JOINTS, position=[float(i)] * 5, velocity=[0.0] * 5,
                     effort=[0.0] * 5)
    msg.header.stamp = node.get_clock().now().to_msg()
    return msg


def controller_state(node, i):
    msg = ControllerState(joint_name='a_yaw_joint', role=1, mode=ControllerState.COARSE,
                          position_setpoint=float(i), effort=0.5)
    msg.header.stamp = node.get_clock().now().to_msg()
    return msg


def gripper_states(node, i):
    msg = GripperStates(grippers=[
        GripperState(name='a', state=GripperState.ATTACHED, node='n0_0'),
        GripperState(name='b', state=GripperState.FREE, position_error=float(i))])
    msg.header.stamp = node.get_clock().now().to_msg()
    return msg


def tip_pose(node, i):
    msg = PoseStamped()
    msg.header.frame_id = 'truss'
    msg.header.stamp = node.get_clock().now().to_msg()
    msg.pose.position.x = float(i)
    return msg


def trajectory(node, i):
    msg = JointTrajectory(joint_names=JOINTS, points=[
        JointTrajectoryPoint(positions=[float(i)] * 5)])
    msg.header.stamp = node.get_clock().now().to_msg()
    return msg


# topic: (type, QoS, message builder); best-effort topics first.
BURST_TOPICS = {
    'joint_states': (JointState, qos_profile_sensor_data, joint_state),
    'tip_pose': (PoseStamped, qos_profile_sensor_data, tip_pose),
    'controllers/a_yaw_joint/state': (ControllerState, RELIABLE, controller_state),
    'gripper_states': (GripperStates, LATCHED, gripper_states),
    'planned_trajectory': (JointTrajectory, LATCHED, trajectory),
}


def latched(node):
    pub = node.create_publisher(StepPhase, 'phase', LATCHED)
    msg = StepPhase(phase=StepPhase.COARSE, base_gripper='a', step_index=0, step_count=3,
                    from_node='n0_0', to_node='n1_0', reason='latched before recording')
    msg.header.stamp = node.get_clock().now().to_msg()
    pub.publish(msg)
    print('published', flush=True)
    rclpy.spin(node)


def burst(node, count):
    publishers = {}
    for topic, (msg_type, qos, build) in BURST_TOPICS.items():
        reliable = qos.reliability == ReliabilityPolicy.RELIABLE
        if reliable:
            qos = QoSProfile(depth=max(count, qos.depth), reliability=qos.reliability,
                             durability=qos.durability)
        publishers[topic] = (node.create_publisher(msg_type, topic, qos), build, reliable)
    deadline = time.monotonic() + MATCH_TIMEOUT
    while any(p.get_subscription_count() == 0 for p, _, _ in publishers.values()):
        if time.monotonic() > deadline:
            print('no subscriber matched', flush=True)
            return
        time.sleep(0.05)
    for topic, (pub, build, reliable) in publishers.items():
        for i in range(count):
            pub.publish(build(node, i))
            if not reliable:
                time.sleep(CONTROL_PERIOD)
        print(f'published {node.resolve_topic_name(topic)} {count}', flush=True)
    print('done', flush=True)
    rclpy.spin(node)


def stream(node):
    states = node.create_publisher(JointState, 'joint_states', qos_profile_sensor_data)
    controller = node.create_publisher(ControllerState, 'controllers/a_yaw_joint/state',
                                       RELIABLE)
    counter = {'states': 0}

    def publish_state():
        states.publish(joint_state(node, counter['states']))
        counter['states'] += 1
        if counter['states'] % 5 == 0:
            controller.publish(controller_state(node, counter['states'] // 5))
        if counter['states'] == 5:
            print('streaming', flush=True)

    node.create_timer(CONTROL_PERIOD, publish_state)
    rclpy.spin(node)


def stall(node, seconds):
    topics = {'joint_states': (JointState, qos_profile_sensor_data, joint_state, 1),
              'controllers/a_yaw_joint/state': (ControllerState, QoSProfile(
                  depth=int(seconds * 100) + 10, reliability=ReliabilityPolicy.RELIABLE),
                  controller_state, 5),
              'gripper_states': (GripperStates, LATCHED, gripper_states, 50)}
    publishers = {topic: node.create_publisher(msg_type, topic, qos)
                  for topic, (msg_type, qos, _, _) in topics.items()}
    deadline = time.monotonic() + MATCH_TIMEOUT
    while any(p.get_subscription_count() == 0 for p in publishers.values()):
        if time.monotonic() > deadline:
            print('no subscriber matched', flush=True)
            return
        time.sleep(0.05)
    counts = dict.fromkeys(topics, 0)
    tick = {'k': 0}
    end = time.monotonic() + seconds

    def publish():
        if time.monotonic() > end:
            return
        for topic, (_, _, build, every) in topics.items():
            if tick['k'] % every == 0:
                publishers[topic].publish(build(node, counts[topic]))
                counts[topic] += 1
        tick['k'] += 1
        if tick['k'] == 1:
            print('streaming', flush=True)

    timer = node.create_timer(CONTROL_PERIOD, publish)
    while time.monotonic() <= end + 0.1:
        rclpy.spin_once(node, timeout_sec=0.05)
    timer.cancel()
    for topic, count in counts.items():
        print(f'published {node.resolve_topic_name(topic)} {count}', flush=True)
    print('done', flush=True)
    rclpy.spin(node)


def simclock(node):
    clock = node.create_publisher(Clock, '/clock', QoSProfile(depth=1))
    states = node.create_publisher(JointState, 'joint_states', qos_profile_sensor_data)
    step = {'k': 0}

    def tick():
        now = Time(seconds=SIM_START + step['k'] * CONTROL_PERIOD).to_msg()
        clock.publish(Clock(clock=now))
        msg = joint_state(node, step['k'])
        msg.header.stamp = now
        states.publish(msg)
        step['k'] += 1
        if step['k'] == 5:
            print('streaming', flush=True)

    node.create_timer(CONTROL_PERIOD, tick)
    rclpy.spin(node)


def main():
    rclpy.init()
    mode = sys.argv[1]
    node = Node(f'walk_publisher_{mode}', namespace='/walker')
    try:
        if mode == 'latched':
            latched(node)
        elif mode == 'burst':
            burst(node, int(sys.argv[2]))
        elif mode == 'stall':
            stall(node, float(sys.argv[2]))
        elif mode == 'simclock':
            simclock(node)
        else:
            stream(node)
    except KeyboardInterrupt:
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == '__main__':
    main()
