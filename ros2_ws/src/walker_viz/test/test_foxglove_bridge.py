"""The Foxglove bridge serves the graph live: a client decodes TF and joint states.

A WebSocket client subscribes and decodes TF and joint states from the advertised ros2msg
schemas alone, as the Foxglove app does.

The graph is the viz node (a real process) fed with a recorded-style stream from the test: the
plant's joint states (the five, and with the links' bends) and its gripper states. The client
speaks the Foxglove WebSocket protocol with the ``websockets`` package: server info, advertised
channels, subscribe, binary message data (opcode 1: subscription id, log time, the CDR bytes),
decoded with ``mcap_ros2``'s decoder from the schema text the server advertised.
"""

from __future__ import annotations

import asyncio
import json
import struct
import time

import pytest

from ros_test_support import REPO_ROOT, NodeProcess
from walker_core.robot_parameters import load_walker_parameters
from walker_core.truss import Truss
from walker_core.urdf import flex_joints

pytestmark = pytest.mark.integration

INSTALL = REPO_ROOT / 'ros2_ws' / 'install' / 'walker_viz' / 'lib' / 'walker_viz'
WAIT = 60.0  # [s] for the nodes to start and the channels to appear, on a loaded machine
_MESSAGE_DATA = 1  # binary opcode of the Foxglove protocol's message data


def _publish_stream(context):
    """Publish joint states at 100 Hz and the gripper states: a recorded-style stream."""
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from sensor_msgs.msg import JointState

    from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
    from walker_runtime.qos import LATCHED_QOS, SENSOR_QOS
    from walker_msgs.msg import GripperState, GripperStates

    node = Node('fake_plant', namespace='/walker', context=context)
    states = node.create_publisher(JointState, 'joint_states', SENSOR_QOS)
    flexible = node.create_publisher(JointState, 'flexible_joint_states', SENSOR_QOS)
    bends = [j.name for j in flex_joints(
        load_walker_parameters().robot.flexibility.segments_per_link)]
    grippers = node.create_publisher(GripperStates, 'gripper_states', LATCHED_QOS)
    grippers.publish(GripperStates(grippers=[
        GripperState(name='a', state=GripperState.ATTACHED, node='n1_1'),
        GripperState(name='b', state=GripperState.FREE)]))
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)

    def tick():
        message = JointState(name=list(PHYSICAL_JOINT_NAMES),
                             position=[-1.57, 0.6, 1.5, 0.6, 0.3])
        message.header.stamp = node.get_clock().now().to_msg()
        states.publish(message)
        flexible.publish(JointState(header=message.header,
                                    name=[*message.name, *bends],
                                    position=[*message.position, *[0.001] * len(bends)]))

    node.create_timer(0.01, tick)
    return node, executor


async def _receive(port: int, wanted: dict[str, int], deadline: float) -> dict[str, list]:
    """Subscribe to the ``wanted`` topics; decode until each has its count of messages."""
    import websockets
    from mcap.records import Schema
    from mcap_ros2.decoder import DecoderFactory

    decoded: dict[str, list] = {topic: [] for topic in wanted}
    factory = DecoderFactory()
    async with websockets.connect(f'ws://127.0.0.1:{port}',
                                  subprotocols=['foxglove.sdk.v1', 'foxglove.websocket.v1'],
                                  max_size=None) as socket:
        channels, decoders, subscribed = {}, {}, {}
        while time.monotonic() < deadline and not all(
                len(decoded[t]) >= n for t, n in wanted.items()):
            try:
                frame = await asyncio.wait_for(socket.recv(), 1.0)
            except TimeoutError:
                continue
            if isinstance(frame, str):
                message = json.loads(frame)
                if message.get('op') != 'advertise':
                    continue
                for channel in message['channels']:
                    channels[channel['id']] = channel
                    if channel['topic'] in wanted and channel['topic'] not in subscribed.values():
                        assert channel['encoding'] == 'cdr'
                        assert channel['schemaEncoding'] == 'ros2msg'
                        decoders[channel['id']] = factory.decoder_for('cdr', Schema(
                            id=channel['id'], name=channel['schemaName'],
                            encoding=channel['schemaEncoding'],
                            data=channel['schema'].encode()))
                        subscription = len(subscribed) + 1
                        subscribed[subscription] = channel['topic']
                        await socket.send(json.dumps({'op': 'subscribe', 'subscriptions': [
                            {'id': subscription, 'channelId': channel['id']}]}))
                continue
            if frame[0] != _MESSAGE_DATA:
                continue
            subscription, _log_time = struct.unpack_from('<IQ', frame, 1)
            topic = subscribed[subscription]
            channel_id = next(c for c, info in channels.items() if info['topic'] == topic)
            decoded[topic].append(decoders[channel_id](frame[13:]))
    return decoded


def test_a_websocket_client_decodes_tf_and_joint_states(rclpy_context, ros_env):
    viz = NodeProcess([str(INSTALL / 'viz_node'), '--ros-args', '-r', '__ns:=/walker'],
                      ros_env, 'viz')
    bridge = NodeProcess([str(INSTALL / 'foxglove_bridge'), '--ros-args', '-r',
                          '__ns:=/walker', '-p', 'port:=0'], ros_env, 'foxglove_bridge')
    node, executor = _publish_stream(rclpy_context)
    with viz, bridge:
        assert bridge.wait_for_output('to Foxglove at ws://127.0.0.1:', WAIT), bridge.output
        port = int(bridge.output.split('to Foxglove at ws://127.0.0.1:')[1].split()[0])
        assert viz.wait_for_output('publishing TF', WAIT), viz.output
        executor.spin_once(timeout_sec=0.01)
        for topic in ('/tf', '/walker/joint_states'):
            assert bridge.wait_for_output(f'serving {topic} ', WAIT), bridge.output
        loop = asyncio.new_event_loop()
        deadline = time.monotonic() + WAIT
        task = loop.create_task(_receive(
            port, {'/tf': 50, '/walker/joint_states': 3}, deadline))  # half a second
        while not task.done():
            executor.spin_once(timeout_sec=0.01)
            loop.run_until_complete(asyncio.sleep(0.01))
        decoded = task.result()
        loop.close()
        output = bridge.output
    node.destroy_node()
    assert all(decoded.values()), ({t: len(v) for t, v in decoded.items()}, output)
    joints = decoded['/walker/joint_states'][-1]
    assert list(joints.name)[0] == 'a_yaw_joint' and joints.position[2] == pytest.approx(1.5)
    moving = {t.child_frame_id: t for m in decoded['/tf'] for t in m.transforms}
    assert {'a_wrist', 'link_a_0', 'link_b_0', 'b_wrist', 'gripper_b'} <= set(moving)
    anchor = moving['gripper_a']  # gripper a screwed into n1_1 holds the tree in the truss
    assert anchor.header.frame_id == 'truss'
    seat = Truss.from_parameters(load_walker_parameters()).position('n1_1')
    t = anchor.transform.translation
    assert (t.x, t.y, t.z) == pytest.approx(tuple(seat), abs=1e-9)
    assert 'link_a_1' in moving  # a segment of the flexible link, beyond a bend


async def _refusal_of_the_old_protocol(port: int) -> str:
    """Connect offering only ``foxglove.websocket.v1``; return how the server refused."""
    import websockets

    try:
        async with websockets.connect(f'ws://127.0.0.1:{port}',
                                      subprotocols=['foxglove.websocket.v1']):
            return 'accepted'
    except (websockets.exceptions.InvalidHandshake, OSError) as error:
        return str(error)


def test_a_client_that_connects_late_gets_every_latched_topic(rclpy_context, ros_env):
    """Latched topics published long before a client connects are sent when it subscribes.

    Two clients, one after the other, each after the messages were published and passed on:
    each gets the newest message of each latched topic (of the phase's history, the newest).
    """
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from std_msgs.msg import String

    from walker_msgs.msg import StepPhase
    from walker_runtime.qos import LATCHED_QOS, latched_qos

    node = Node('latched_publisher', namespace='/walker', context=rclpy_context)
    description = node.create_publisher(String, 'robot_description', LATCHED_QOS)
    phase = node.create_publisher(StepPhase, 'phase', latched_qos(10))
    description.publish(String(data='<robot name="walker"/>'))
    for index in range(3):
        phase.publish(StepPhase(phase=StepPhase.IDLE, step_index=index))
    executor = SingleThreadedExecutor(context=rclpy_context)
    executor.add_node(node)
    bridge = NodeProcess([str(INSTALL / 'foxglove_bridge'), '--ros-args', '-r',
                          '__ns:=/walker', '-p', 'port:=0'], ros_env, 'foxglove_bridge')
    wanted = {'/walker/robot_description': 1, '/walker/phase': 1}
    received = []
    with bridge:
        assert bridge.wait_for_output('to Foxglove at ws://127.0.0.1:', WAIT), bridge.output
        port = int(bridge.output.split('to Foxglove at ws://127.0.0.1:')[1].split()[0])
        for topic in wanted:
            assert bridge.wait_for_output(f'serving {topic} ', WAIT), bridge.output
        end = time.monotonic() + 2.0  # the bridge has passed them on to nobody
        while time.monotonic() < end:
            executor.spin_once(timeout_sec=0.05)
        for _client in range(2):
            loop = asyncio.new_event_loop()
            task = loop.create_task(_receive(port, wanted, time.monotonic() + WAIT))
            while not task.done():
                executor.spin_once(timeout_sec=0.01)
                loop.run_until_complete(asyncio.sleep(0.01))
            received.append(task.result())
            loop.close()
        old_protocol = asyncio.new_event_loop()
        refusal = old_protocol.run_until_complete(_refusal_of_the_old_protocol(port))
        old_protocol.close()
        output = bridge.output
    node.destroy_node()
    assert '400' in refusal, refusal  # foxglove.sdk.v1 only, as foxglove_bridge 3.x
    for decoded in received:
        assert [m.data for m in decoded['/walker/robot_description']] == [
            '<robot name="walker"/>'], output
        assert decoded['/walker/phase'][-1].step_index == 2


@pytest.mark.parametrize('executable, arguments, words', [
    ('viz_node', ['-p', 'viz.tf_rate:=0.0'], 'viz.tf_rate'),
    ('foxglove_bridge', ['-p', 'port:=70000'], 'port'),
    ('foxglove_bridge', ['-p', "topics:=['/bad name']"], 'topics'),
])
def test_bad_parameters_are_refused_at_start_in_one_line(ros_env, executable, arguments,
                                                         words):
    """Exit code 2 and one line naming the parameter, as every walker node refuses."""
    from walker_runtime.node_main import EXIT_REFUSED

    with NodeProcess([str(INSTALL / executable), '--ros-args', '-r', '__ns:=/walker',
                      *arguments], ros_env, executable) as node:
        assert node.process.wait(timeout=WAIT) == EXIT_REFUSED, node.output
        output = node.output
    lines = [line for line in output.splitlines() if 'refusing to start' in line]
    assert len(lines) == 1 and words in lines[0], output
    assert 'Traceback' not in output
