"""A recorded walk seen as a ROS user sees it: the node list, TF and markers from the bag.

One sim-time graph (every node a process, the recorder on) walks one step; the bag is then
read with the ``mcap`` reader and its ROS 2 decoder, as Foxglove reads it, with no walker
code: the TF tree of ``/tf_static`` and ``/tf`` (looked up as tf2 does, each edge
interpolated between its samples) must put each gripper within 0.02 mm of where the plant had it
(``gripper_a_pose``, ``gripper_b_pose``) at every pose sample, through the extraction, the
swing, the insertion and the hand-over of the base.
"""

from __future__ import annotations

import bisect
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from ros_test_support import running_graph, ros_environment

WALK_TIMEOUT = 600.0  # [s] of wall time for a step on a loaded 2-core machine
TOLERANCE = 0.00002  # [m] the plant's gripper pose against TF's
pytestmark = [pytest.mark.integration, pytest.mark.timeout(WALK_TIMEOUT + 300.0)]


class Graph:
    """The recording graph and its client; what the client saw of the node list."""

    def __init__(self, tmp: Path, domain: int) -> None:
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from walker_msgs.msg import GripperStates

        from walker_bringup.graph import walker_graph
        from walker_bringup.graph_client import GraphClient, init_context
        from walker_bringup.processes import ProcessGroup
        from walker_core.robot_parameters import default_parameter_file

        self.bag = tmp / 'bag'
        self.nodes = walker_graph(default_parameter_file(), sim_time=True, record=True,
                                  bag_path=self.bag)
        self.group = ProcessGroup(tmp / 'logs', ros_environment(domain))
        for spec in self.nodes:
            self.group.start(spec)
        self.context = init_context(domain)
        self.client = GraphClient('/walker', self.context)
        self.gripper_states = []
        self.client.node.create_subscription(
            GripperStates, 'gripper_states', self.gripper_states.append,
            QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.TRANSIENT_LOCAL))
        self.closed = None
        try:
            self.client.wait_until_ready([n.full_name for n in self.nodes], 120.0,
                                         should_stop=lambda: bool(self.group.poll_deaths()))
        except BaseException:
            self.close()
            raise

    def node_list(self) -> tuple[list[str], dict[str, list]]:
        """Return what ``ros2 node list`` shows in /walker, and every hidden node's services."""
        self.client.spin_for(2.0)  # every helper node discovered
        node = self.client.node
        shown, hidden = [], {}
        for name, namespace in node.get_node_names_and_namespaces():
            if namespace != '/walker':
                continue
            if name.startswith('_'):  # ros2cli's rule: hidden unless --all
                hidden[name] = node.get_service_names_and_types_by_node(name, namespace)
            else:
                shown.append(f'{namespace}/{name}')
        return sorted(shown), hidden

    def close(self) -> dict:
        if self.closed is None:
            self.client.close()
            self.context.try_shutdown()
            self.closed = self.group.stop_all()
        return self.closed


@pytest.fixture(scope='module')
def walked(tmp_path_factory):
    """Run the graph, walk; the node list seen, the walk's outcome, the closed bag."""
    with running_graph(Graph, tmp_path_factory.mktemp('visualisation')) as graph:
        node_list = graph.node_list()
        _, result = graph.client.walk_to('n1_2', WALK_TIMEOUT)
        graph.client.spin_for(1.0)
        graph.close()  # the recorder closes the bag
        yield node_list, result, graph.bag, [n.full_name for n in graph.nodes]


def test_ros2_node_list_shows_the_documented_nodes_only(walked):
    (shown, hidden), _, _, expected = walked
    assert shown == sorted(expected), 'helper nodes must be hidden (a leading underscore)'
    assert len(shown) == 10  # plant, five controllers, planner, supervisor, recorder, viz
    assert {'_recorder_reader', '_supervisor_sampler', '_planner_stream',
            '_walker_graph_client'} <= set(hidden), hidden
    assert all(services == [] for services in hidden.values()), hidden


def _read(bag: Path) -> dict[str, list]:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    wanted = {'/tf', '/tf_static', '/walker/gripper_a_pose', '/walker/gripper_b_pose',
              '/walker/markers'}
    messages: dict[str, list] = {topic: [] for topic in wanted}
    for path in sorted(bag.glob('*.mcap')):
        with path.open('rb') as stream:
            reader = make_reader(stream, decoder_factories=[DecoderFactory()])
            for _, channel, _, message in reader.iter_decoded_messages(topics=list(wanted)):
                messages[channel.topic].append(message)
    return messages


def _ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def _matrix(transform) -> np.ndarray:
    t, r = transform.translation, transform.rotation
    pose = np.eye(4)
    pose[:3, :3] = Rotation.from_quat([r.x, r.y, r.z, r.w]).as_matrix()
    pose[:3, 3] = [t.x, t.y, t.z]
    return pose


class TfBuffer:
    """tf2's lookup, small: static edges for all time, dynamic ones interpolated."""

    def __init__(self, static, dynamic) -> None:
        self.static = {}
        for message in static:  # the newest static message holds them all
            self.static = {t.child_frame_id: (t.header.frame_id, _matrix(t.transform))
                           for t in message.transforms}
        self.dynamic: dict[str, list] = {}
        for message in dynamic:
            for t in message.transforms:
                self.dynamic.setdefault(t.child_frame_id, []).append(
                    (_ns(t.header.stamp), t.header.frame_id, t.transform))
        for samples in self.dynamic.values():
            samples.sort(key=lambda s: s[0])

    def _edge(self, child: str, stamp: int):
        if child in self.static:
            return self.static[child]
        samples = self.dynamic[child]
        times = [s[0] for s in samples]
        i = bisect.bisect_right(times, stamp) - 1
        if i < 0 or i + 1 >= len(samples) and times[i] != stamp:
            return None  # no sample on each side: tf2 would refuse to extrapolate
        if times[i] == stamp or samples[i][1] != samples[i + 1][1]:
            return samples[i][1], _matrix(samples[i][2])
        (t0, parent, a), (t1, _, b) = samples[i], samples[i + 1]
        share = (stamp - t0) / (t1 - t0)
        rotations = Rotation.from_quat([[q.x, q.y, q.z, q.w] for q in
                                        (a.rotation, b.rotation)])
        pose = np.eye(4)
        pose[:3, :3] = Slerp([0.0, 1.0], rotations)([share]).as_matrix()[0]
        ta, tb = (np.array([v.translation.x, v.translation.y, v.translation.z]) for v in (a, b))
        pose[:3, 3] = ta + share * (tb - ta)
        return parent, pose

    def lookup(self, frame: str, stamp: int, fixed: str = 'truss') -> np.ndarray | None:
        """Pose of ``frame`` in ``fixed`` at ``stamp``, or None outside the samples."""
        pose = np.eye(4)
        while frame != fixed:
            edge = self._edge(frame, stamp)
            if edge is None:
                return None
            frame, transform = edge
            pose = transform @ pose
        return pose


def test_tf_from_the_bag_puts_each_gripper_where_the_plant_has_it(walked):
    _, result, bag, _ = walked
    assert result.success, result.message
    assert result.steps_taken == 1 and list(result.path) == ['n1_2'], result
    messages = _read(bag)
    assert messages['/tf_static'] and messages['/tf'], 'TF is recorded'
    tf = TfBuffer(messages['/tf_static'], messages['/tf'])
    assert {'gripper_a', 'a_wrist', 'link_a_0', 'link_b_0', 'b_wrist', 'gripper_b'} <= \
        set(tf.dynamic), 'the five joints and the root in the truss'
    worst, checked, samples = 0.0, 0, 0
    for gripper in ('a', 'b'):
        for pose in messages[f'/walker/gripper_{gripper}_pose']:
            samples += 1
            stamp = _ns(pose.header.stamp)
            found = tf.lookup(f'gripper_{gripper}', stamp)
            if found is None:
                continue
            p = pose.pose.position
            error = float(np.linalg.norm(found[:3, 3] - [p.x, p.y, p.z]))
            assert error < TOLERANCE, (f'gripper {gripper} at t={stamp * 1e-9:.3f} s is '
                                       f'{error * 1e3:.2f} mm from where TF puts it')
            worst, checked = max(worst, error), checked + 1
    # every sample once the first transform is out, to the walk's end (a few at either end
    # fall outside TF's samples, as they would for tf2)
    assert checked >= 0.95 * samples, (checked, samples)
    print(f'{checked} gripper poses checked against TF: worst {worst * 1e3:.5f} mm')


def test_the_truss_markers_are_in_the_bag(walked):
    from walker_core.robot_parameters import load_walker_parameters
    from walker_core.truss import Truss

    _, _, bag, _ = walked
    markers = _read(bag)['/walker/markers']
    assert markers, 'the markers are recorded'
    first = {m.ns: m for m in markers[0].markers}
    truss = Truss.from_parameters(load_walker_parameters())
    assert {'truss_members', 'truss_nodes'} <= set(first)
    assert len(first['truss_nodes'].points) == len(truss.node_names)
    assert all(m.header.frame_id == 'truss' for m in markers[0].markers)
    drawn = [m for message in markers for m in message.markers
             if m.ns == 'planned_tip_path' and m.action == 0]
    assert drawn and len(drawn[-1].points) > 10, 'a planned tip path was drawn'
    targets = [m.text for message in markers for m in message.markers
               if m.ns == 'target' and m.action == 0]
    assert 'n1_2' in targets

