"""The recorder node in its own process, recording real publishers over Fast DDS.

Each test runs in a ROS domain of its own with discovery on loopback. The publishers are the
walk's message types on the topics of docs/architecture.md (``walk_publisher.py``). The tests
wait for conditions (a line printed, a count in the flushed ``metadata.yaml``), never for a
fixed time.
"""

import os
import signal
import struct
import sys
import time
from pathlib import Path

import pytest
from mcap.exceptions import EndOfFile
from mcap.reader import make_reader
from mcap.records import Message
from mcap.stream_reader import StreamReader
from mcap_ros2.decoder import DecoderFactory

from ros_test_support import NodeProcess, isolated_domain, ros_environment
from walker_bag.core.bag_metadata import read_metadata
from walker_bag.core.bag_reader import BagReader
from walker_bag.core.bag_recovery import recover_bag
from walker_bag.core.errors import BagPathError, MetadataError
from walker_bag.core.message_definitions import type_description_hash
from walker_bag.recorder_command import recorder_command

pytestmark = pytest.mark.integration

PUBLISHER = str(Path(__file__).resolve().parent / 'walk_publisher.py')
START_TIMEOUT = 60.0  # [s] a process starting on a loaded machine
BURST = 40
RELIABLE_TOPICS = {
    '/walker/controllers/a_yaw_joint/state': 'walker_msgs/msg/ControllerState',
    '/walker/gripper_states': 'walker_msgs/msg/GripperStates',
    '/walker/planned_trajectory': 'trajectory_msgs/msg/JointTrajectory',
}
BEST_EFFORT_TOPICS = {
    '/walker/joint_states': 'sensor_msgs/msg/JointState',
    '/walker/tip_pose': 'geometry_msgs/msg/PoseStamped',
}
LATCHED_TOPICS = {'/walker/phase', '/walker/gripper_states', '/walker/planned_trajectory'}


def publisher(env, mode, *args):
    return NodeProcess([sys.executable, PUBLISHER, mode, *map(str, args)], env, mode)


def recorder(env, bag_dir, *parameters):
    overrides = dict(p.split(':=', 1) for p in parameters)
    return NodeProcess(recorder_command(bag_dir.parent, bag_name=bag_dir.name,
                                        parameters=overrides), env, 'recorder')


def flushed_counts(bag_dir):
    """Per-topic counts of the flushed metadata.yaml ({} before it is readable)."""
    try:
        metadata = read_metadata(bag_dir)
    except MetadataError:
        return {}
    return {t.topic_metadata.name: t.message_count for t in metadata.topics_with_message_count}


def files_of(bag_dir):
    """Return the files the flushed metadata.yaml lists (() before it is readable)."""
    try:
        return read_metadata(bag_dir).relative_file_paths
    except MetadataError:
        return ()


def wait_until(condition, timeout, what):
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, f'timed out waiting for {what}'
        time.sleep(0.05)


def index_of(type_name, message):
    if type_name == 'sensor_msgs/msg/JointState':
        return int(message.position[0])
    if type_name == 'geometry_msgs/msg/PoseStamped':
        return int(message.pose.position.x)
    if type_name == 'walker_msgs/msg/ControllerState':
        return int(message.position_setpoint)
    if type_name == 'walker_msgs/msg/GripperStates':
        return int(message.grippers[1].position_error)
    return int(message.points[0].positions[0])


def dds_segments(pid):
    """Fast DDS shared-memory segments a process maps (not the per-domain port files)."""
    segments = set()
    for line in Path(f'/proc/{pid}/maps').read_text().splitlines():
        fields = line.split()
        if len(fields) >= 6 and fields[5].startswith('/dev/shm/fastrtps_') \
                and not fields[5].startswith('/dev/shm/fastrtps_port'):
            segments.add(Path(fields[5]))
    return segments


def remove_orphaned(segments):
    """Remove the segments (and lock files) of a killed process that no process maps any more."""
    mapped = set()
    for maps in Path('/proc').glob('[0-9]*/maps'):
        try:
            mapped.update(line.split()[-1] for line in maps.read_text().splitlines()
                          if '/dev/shm/fastrtps_' in line)
        except OSError:
            continue
    for segment in segments:
        if str(segment) not in mapped:
            for path in (segment, segment.with_name(segment.name + '_el')):
                path.unlink(missing_ok=True)


@pytest.fixture(scope='module')
def recorded_walk(tmp_path_factory):
    """Record a latched phase published before the recorder starts, then every type."""
    bag = tmp_path_factory.mktemp('walk') / 'walk'
    with isolated_domain() as domain:
        env = ros_environment(domain)
        with publisher(env, 'latched') as latched:
            assert latched.wait_for_output('published', START_TIMEOUT), latched.output
            with recorder(env, bag) as rec:
                assert rec.wait_for_output('recording /walker/phase', START_TIMEOUT), rec.output
                with publisher(env, 'burst', BURST) as burst:
                    assert burst.wait_for_output('done', START_TIMEOUT), burst.output
                    wait_until(lambda: all(flushed_counts(bag).get(t) == BURST
                                           for t in RELIABLE_TOPICS),
                               START_TIMEOUT, 'every reliable message in the bag')
                    published = burst.output
                rec.stop()
                assert rec.process.returncode == 0, rec.output
                log = rec.output
    return bag, published, log


def test_every_type_of_the_walk_is_recorded(recorded_walk):
    bag, _, _ = recorded_walk
    with BagReader(bag) as reader:
        assert reader.topics == {'/walker/phase': 'walker_msgs/msg/StepPhase',
                                 **RELIABLE_TOPICS, **BEST_EFFORT_TOPICS}


def test_every_reliable_message_published_is_in_the_bag_once_in_order(recorded_walk):
    bag, published, _ = recorded_walk
    with BagReader(bag) as reader:
        for topic, type_name in RELIABLE_TOPICS.items():
            assert f'published {topic} {BURST}' in published
            indices = [index_of(type_name, m.message) for m in reader.messages([topic])]
            assert indices == list(range(BURST)), topic


def test_best_effort_messages_are_recorded_without_duplicates_or_reordering(recorded_walk):
    bag, published, _ = recorded_walk
    with BagReader(bag) as reader:
        for topic, type_name in BEST_EFFORT_TOPICS.items():
            assert f'published {topic} {BURST}' in published
            indices = [index_of(type_name, m.message) for m in reader.messages([topic])]
            # Best effort may drop under load; what arrives is real, unique and in order.
            assert indices, topic
            assert indices == sorted(set(indices)), topic
            assert set(indices) <= set(range(BURST)), topic


def test_a_latched_message_published_before_the_recorder_started_is_recorded(recorded_walk):
    bag, _, _ = recorded_walk
    with BagReader(bag) as reader:
        (phase,) = list(reader.messages(['/walker/phase']))
    assert phase.message.reason == 'latched before recording'
    assert (phase.message.from_node, phase.message.to_node) == ('n0_0', 'n1_0')


def test_offered_qos_and_type_hashes_are_in_the_metadata(recorded_walk):
    bag, _, _ = recorded_walk
    metadata = read_metadata(bag)
    for info in metadata.topics_with_message_count:
        topic = info.topic_metadata
        (offer,) = topic.offered_qos_profiles
        assert offer.durability == ('transient_local' if topic.name in LATCHED_TOPICS
                                    else 'volatile'), topic.name
        assert offer.reliability == ('best_effort' if topic.name in BEST_EFFORT_TOPICS
                                     else 'reliable'), topic.name
        assert topic.type_description_hash == type_description_hash(topic.type)


def test_the_bag_closed_by_sigint_is_complete_for_the_mcap_ros2_decoder(recorded_walk):
    bag, _, log = recorded_walk
    metadata = read_metadata(bag)
    assert f'closed {bag}: {metadata.message_count} messages' in log
    with open(bag / metadata.relative_file_paths[0], 'rb') as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        assert reader.get_summary().statistics.message_count == metadata.message_count
        decoded = list(reader.iter_decoded_messages())
    assert len(decoded) == metadata.message_count
    # Log time is the receive time, publish time the publisher's: never after reception.
    assert all(m.publish_time <= m.log_time for _, _, m, _ in decoded)
    # taken in batches from every topic at once, written in log-time order all the same
    with open(bag / metadata.relative_file_paths[0], 'rb') as stream:
        in_file_order = [m.log_time for _, _, m in make_reader(stream).iter_messages(
            log_time_order=False)]
    assert in_file_order == sorted(in_file_order)
    sequences = [m.sequence for _, c, m, _ in decoded if c.topic in RELIABLE_TOPICS]
    assert sorted(sequences) == sorted(list(range(1, BURST + 1)) * len(RELIABLE_TOPICS))


@pytest.mark.parametrize('stop_signal', [signal.SIGTERM, signal.SIGINT],
                         ids=lambda s: s.name)
def test_a_stop_signal_mid_stream_leaves_a_complete_bag(ros_env, tmp_path, stop_signal):
    bag = tmp_path / 'stopped'
    with publisher(ros_env, 'stream') as stream, recorder(ros_env, bag) as rec:
        assert stream.wait_for_output('streaming', START_TIMEOUT), stream.output
        wait_until(lambda: flushed_counts(bag).get('/walker/joint_states', 0) > 0,
                   START_TIMEOUT, 'joint states in the bag')
        flushed_before = sum(flushed_counts(bag).values())
        os.kill(rec.process.pid, stop_signal)
        assert rec.process.wait(timeout=START_TIMEOUT) == 0, rec.output
    metadata = read_metadata(bag)
    assert metadata.message_count >= flushed_before
    with BagReader(bag) as reader:  # needs the summary and footer of a closed file
        assert reader.message_count == metadata.message_count
        assert reader.message_counts == {
            t.topic_metadata.name: t.message_count for t in metadata.topics_with_message_count}
        assert set(reader.topics) == {'/walker/joint_states',
                                      '/walker/controllers/a_yaw_joint/state'}


def test_a_killed_recorder_leaves_a_bag_readable_up_to_its_last_flush(ros_env, tmp_path):
    bag = tmp_path / 'killed'
    with publisher(ros_env, 'stream') as stream, recorder(ros_env, bag) as rec:
        assert stream.wait_for_output('streaming', START_TIMEOUT), stream.output
        wait_until(lambda: flushed_counts(bag).get('/walker/joint_states', 0) > 0,
                   START_TIMEOUT, 'joint states in the bag')
        segments = dds_segments(rec.process.pid)
        os.kill(rec.process.pid, signal.SIGKILL)
        assert rec.process.wait(timeout=START_TIMEOUT) == -signal.SIGKILL
    remove_orphaned(segments)
    metadata = read_metadata(bag)
    assert metadata.message_count > 0
    messages = 0
    with open(bag / metadata.relative_file_paths[0], 'rb') as file:
        try:
            for record in StreamReader(file, validate_crcs=True).records:
                messages += isinstance(record, Message)
        except (EndOfFile, struct.error):
            pass
    # metadata.yaml is replaced after each chunk is written: never more than the file holds.
    assert messages >= metadata.message_count
    with pytest.raises(BagPathError):
        BagReader(bag)
    report = recover_bag(bag)
    assert report.message_count == messages
    with BagReader(report.destination) as reader:
        assert reader.message_count == messages
    # The next recorder started in the same directory completes the cut bag in place: the
    # standard readers open it, the cut file is kept beside it.
    with recorder(ros_env, tmp_path / 'next') as rec:
        assert rec.wait_for_output(f'{bag}: left cut by a killed recorder', START_TIMEOUT), \
            rec.output
    assert (bag / 'killed_0.mcap.incomplete').exists()
    with BagReader(bag) as reader:
        assert reader.message_count == messages == read_metadata(bag).message_count
    with open(bag / 'killed_0.mcap', 'rb') as stream:
        assert sum(1 for _ in make_reader(stream).iter_messages()) == messages


def test_in_sim_time_messages_are_stamped_with_the_simulation_clock(ros_env, tmp_path):
    bag = tmp_path / 'sim'
    with publisher(ros_env, 'simclock') as sim, \
            recorder(ros_env, bag, 'use_sim_time:=true') as rec:
        assert sim.wait_for_output('streaming', START_TIMEOUT), sim.output
        wait_until(lambda: flushed_counts(bag).get('/walker/joint_states', 0) > 10,
                   START_TIMEOUT, 'joint states in the bag')
        rec.stop()
        assert rec.process.returncode == 0, rec.output
    metadata = read_metadata(bag)
    assert metadata.custom_data == {'clock': 'sim_time', 'messages_lost': '0'}
    with BagReader(bag) as reader:
        assert '/clock' in reader.topics  # the default selection records the clock too
        states = list(reader.messages(['/walker/joint_states']))
    sim_start_ns = 1000 * 10**9
    wall_clock_ns = time.time_ns()
    stamps = [m.log_time_ns for m in states]
    # The node's clock follows /clock (from 1000 s on, far from the wall clock); it reads 0
    # until the first /clock message arrives.
    assert all(s == 0 or sim_start_ns <= s < 2 * sim_start_ns for s in stamps)
    assert stamps[-1] >= sim_start_ns
    assert wall_clock_ns > 2 * sim_start_ns


def test_an_existing_bag_directory_is_refused_and_left_untouched(ros_env, tmp_path):
    bag = tmp_path / 'taken'
    bag.mkdir()
    (bag / 'notes.txt').write_text('keep')
    with recorder(ros_env, bag) as rec:
        assert rec.process.wait(timeout=START_TIMEOUT) == 2
        assert 'already exists' in rec.output and str(bag) in rec.output
    assert [p.name for p in bag.iterdir()] == ['notes.txt']


def test_an_invalid_parameter_is_refused_by_name(ros_env, tmp_path):
    with recorder(ros_env, tmp_path / 'never', 'recorder.flush_period:=0.0') as rec:
        assert rec.process.wait(timeout=START_TIMEOUT) == 2
        assert 'recorder.flush_period' in rec.output
    assert not (tmp_path / 'never').exists()


def test_the_command_line_is_that_of_ros2_run_with_the_overrides(tmp_path):
    command = recorder_command(tmp_path, bag_name='b', params_file='walker.yaml',
                               use_sim_time=True, parameters={'recorder.topics': "['x']"})
    assert Path(command[0]).is_file() and os.access(command[0], os.X_OK)
    assert command[1:] == ['--ros-args', '-r', '__ns:=/walker', '--params-file', 'walker.yaml',
                           '-p', f'recorder.directory:={tmp_path}', '-p', 'recorder.bag_name:=b',
                           '-p', 'use_sim_time:=true', '-p', "recorder.topics:=['x']"]


DIAGNOSTICS_PROBE = """
import rclpy, sys
from diagnostic_msgs.msg import DiagnosticArray
rclpy.init()
node = rclpy.create_node('diagnostics_probe')
def seen(message):
    for status in message.status:
        if status.name == '/walker/recorder: recording' and status.level == b'\\x01':
            print('WARN', status.message, flush=True)
node.create_subscription(DiagnosticArray, '/diagnostics', seen, 10)
rclpy.spin(node)
"""


def test_a_stalled_recorder_loses_no_reliable_message_held_for_it_and_reports_the_rest(
        ros_env, tmp_path):
    """SIGSTOP freezes the recorder for 3 s while its publishers go on.

    The controller states' publisher keeps every message for it (a history as deep as the
    stream): all are recorded. Joint states are best effort; gripper states reliable but
    latched with a history of one (what a late subscriber must get): those the recorder could
    not take are lost, and every loss is counted, per topic, in its log, on /diagnostics and
    in the bag's custom_data: recorded + lost = published.
    """
    bag = tmp_path / 'stalled'
    with recorder(ros_env, bag) as rec, NodeProcess.python(DIAGNOSTICS_PROBE, ros_env,
                                                           'probe') as probe:
        assert rec.wait_for_output('recording', START_TIMEOUT), rec.output
        with publisher(ros_env, 'stall', 8.0) as stall:
            assert stall.wait_for_output('streaming', START_TIMEOUT), stall.output
            time.sleep(1.0)
            os.kill(rec.process.pid, signal.SIGSTOP)
            time.sleep(3.0)  # the stall injected
            os.kill(rec.process.pid, signal.SIGCONT)
            assert stall.wait_for_output('done', START_TIMEOUT), stall.output
            published = {line.split()[1]: int(line.split()[2])
                         for line in stall.output.splitlines() if line.startswith('published')}
            wait_until(lambda: flushed_counts(bag).get('/walker/controllers/a_yaw_joint/state')
                       == published['/walker/controllers/a_yaw_joint/state'],
                       START_TIMEOUT, 'every controller state in the bag')
            assert probe.wait_for_output('WARN', START_TIMEOUT), probe.output
            rec.stop()
            assert rec.process.returncode == 0, rec.output
            log, diagnostics = rec.output, probe.output
    metadata = read_metadata(bag)
    recorded = {t.topic_metadata.name: t.message_count for t in metadata.topics_with_message_count}
    lost = {topic[len('messages_lost '):]: int(count)
            for topic, count in metadata.custom_data.items() if topic.startswith('messages_lost ')}
    assert '/walker/controllers/a_yaw_joint/state' not in lost
    with BagReader(bag) as reader:
        indices = [index_of('walker_msgs/msg/ControllerState', m.message)
                   for m in reader.messages(['/walker/controllers/a_yaw_joint/state'])]
    assert indices == list(range(published['/walker/controllers/a_yaw_joint/state']))
    for topic in ('/walker/joint_states', '/walker/gripper_states'):
        assert lost.get(topic, 0) > 0, (topic, recorded, published)
        assert recorded[topic] + lost[topic] == published[topic], topic
        assert f'{topic}: ' in log and ' lost (' in log
    assert int(metadata.custom_data['messages_lost']) == sum(lost.values())
    assert 'messages lost: /walker/gripper_states' in diagnostics


def test_the_bag_is_split_by_duration_keeps_its_newest_files_and_is_continued_on_restart(
        ros_env, tmp_path):
    bag = tmp_path / 'split'
    with publisher(ros_env, 'stream') as stream:
        assert stream.wait_for_output('streaming', START_TIMEOUT), stream.output
        with recorder(ros_env, bag, 'recorder.max_bag_duration:=0.5',
                      'recorder.max_bag_files:=2') as rec:
            wait_until(lambda: len(files_of(bag)) == 2 and files_of(bag)[0] != 'split_0.mcap',
                       START_TIMEOUT, 'the oldest file rotated away')
            rec.stop()
            assert rec.process.returncode == 0, rec.output
        first = read_metadata(bag)
        assert sorted(p.name for p in bag.glob('*.mcap')) == sorted(first.relative_file_paths)
        # a recorder started again on the same bag goes on in its next file
        with recorder(ros_env, bag, 'recorder.append:=true') as rec:
            wait_until(lambda: len(files_of(bag)) == 3 and read_metadata(bag).message_count
                       > first.message_count,
                       START_TIMEOUT, 'messages in the next file')
            rec.stop()
            assert rec.process.returncode == 0, rec.output
    metadata = read_metadata(bag)
    assert metadata.relative_file_paths[:2] == first.relative_file_paths
    for name in metadata.relative_file_paths:
        with open(bag / name, 'rb') as file:
            assert make_reader(file).get_summary().statistics.message_count > 0
    with BagReader(bag) as reader:
        assert reader.message_count == metadata.message_count


def test_a_recorder_killed_and_started_again_records_what_it_missed_in_the_bag(ros_env,
                                                                                tmp_path):
    """The span each topic was not recorded and its estimated count, in the bag itself.

    In its custom_data and as a diagnostic status written into it, the recorder started again
    as the bring-up restarts one.
    """
    bag = tmp_path / 'restarted'
    down = 1.0  # [s] at least this long with no recorder
    with publisher(ros_env, 'stream') as stream:
        assert stream.wait_for_output('streaming', START_TIMEOUT), stream.output
        with recorder(ros_env, bag) as rec:
            wait_until(lambda: flushed_counts(bag).get('/walker/joint_states', 0) > 0,
                       START_TIMEOUT, 'joint states in the bag')
            segments = dds_segments(rec.process.pid)
            os.kill(rec.process.pid, signal.SIGKILL)
            assert rec.process.wait(timeout=START_TIMEOUT) == -signal.SIGKILL
        remove_orphaned(segments)
        time.sleep(down)
        with recorder(ros_env, bag, 'recorder.append:=true') as rec:
            wait_until(lambda: 'recorder_gap /walker/joint_states'
                       in read_metadata(bag).custom_data, START_TIMEOUT, 'the gap recorded')
            rec.stop()
            assert rec.process.returncode == 0, rec.output
            output = rec.output
    gap = read_metadata(bag).custom_data['recorder_gap /walker/joint_states']
    start, end, estimated = (int(v) for v in gap.split())
    assert (end - start) * 1e-9 >= down and estimated > 0
    assert '/walker/joint_states: not recorded for' in output
    with BagReader(bag) as reader:
        statuses = [status for record in reader.messages(['/diagnostics'])
                    for status in record.message.status]
    missed = [s for s in statuses if s.message.startswith('/walker/joint_states: not recorded')]
    assert len(missed) == 1
    values = {kv.key: kv.value for kv in missed[0].values}
    assert values['topic'] == '/walker/joint_states' and int(values['estimated_count']) == \
        estimated and int(values['start_ns']) == start and int(values['end_ns']) == end
