"""A headless step end to end: reached, recorded as the graph records, the same every time.

One step (gripper b from n2_1 to n1_2 about gripper a in n1_1, the start of the parameter
file) walked twice with its bag, once without: a few seconds of CPU each.
"""

import fnmatch
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from walker_bag.core.bag_reader import BagReader
from walker_core.rotations import rotation_from_quaternion
from walker_bringup.graph import RECORDED_TOPICS
from walker_config.core.configuration import load_configuration
from walker_headless.recording import WalkRecording
from walker_headless.runner import walk
from walker_report.core.walk_data import load_walk
from walker_supervisor.core.phases import Phase
from walker_viz.core.map_markers import NOMINAL_COLOR, SURVEYED_COLOR
from walker_viz.core.robot_tree import WORLD_FRAME

TARGET = 'n1_2'
STEP_PHASES = [Phase.EXTRACTION, Phase.COARSE, Phase.FINE, Phase.INSERTION]


@pytest.fixture(scope='module')
def configuration():
    return load_configuration()


@pytest.fixture(scope='module')
def walks(configuration, tmp_path_factory):
    """Two recorded walks of the same step, and their bags."""
    results = []
    for name in ('first', 'second'):
        bag = tmp_path_factory.mktemp(name) / 'bag'
        recording = WalkRecording(bag)
        try:
            result = walk(configuration, TARGET, recording)
        finally:
            recording.close()
        results.append((result, bag))
    return results


def messages(bag):
    """Every message of a bag as stored: topic, log time, publish time, CDR bytes."""
    with open(next(Path(bag).glob('*.mcap')), 'rb') as stream:
        return [(channel.topic, message.log_time, message.publish_time, message.data)
                for _, channel, message in make_reader(stream).iter_messages()]


def test_the_step_reaches_its_node_through_the_four_phases(walks):
    result, _ = walks[0]
    assert result.reached and result.path == (TARGET,) and result.message == ''
    report = result.reports[0]
    assert report.success and report.phase_names == ['extraction', 'coarse', 'fine',
                                                     'insertion']
    assert report.time_optimal_bound > 0 and report.duration > report.time_optimal_bound
    # screwed in within the bore's clearance (1 mm, half the insertion tolerance): the descent
    # presses the gripper on the node's face, which bends the joints' estimate of it by about
    # a tenth of a millimetre against the 0.5 mm the supervisor aligns it to
    assert report.insertion_error < 1e-3 and report.insertion_attempts == 1
    in_step = [Phase(p.phase) for p in result.phases if p.step_count and p.from_node]
    assert [p for i, p in enumerate(in_step) if i == 0 or p != in_step[i - 1]] == STEP_PHASES
    assert result.phases[-1].phase == Phase.IDLE


def test_the_same_parameters_give_the_same_walk_and_bag_bit_for_bit(walks):
    (first, first_bag), (second, second_bag) = walks
    assert first.reports == second.reports and first.phases == second.phases
    assert (first.sim_time, first.periods) == (second.sim_time, second.periods)
    assert messages(first_bag) == messages(second_bag)


def test_a_walk_without_a_bag_is_the_same_walk(configuration, walks):
    assert walk(configuration, TARGET).reports == walks[0][0].reports


def test_the_bag_holds_the_graphs_topics_and_the_report_reads_it(walks):
    result, bag = walks[0]
    with BagReader(bag) as reader:
        topics = {name.removeprefix('/walker/') for name in reader.topics}
        counts = {name.removeprefix('/walker/'): n
                  for name, n in reader.message_counts.items()}
    assert all(any(fnmatch.fnmatch(topic, pattern) for pattern in RECORDED_TOPICS)
               for topic in topics)
    assert all(any(fnmatch.fnmatch(topic, pattern) for topic in topics)
               for pattern in RECORDED_TOPICS if not pattern.startswith('camera_'))
    assert not any(topic.startswith('camera_') for topic in topics), 'no camera, no topic'
    assert counts['joint_states'] == result.periods + 1  # every state, the last included
    assert counts['step_reports'] == 1
    assert counts['phase_history'] == counts['phase'] == len(result.phases)
    # the viz node's: every flexible state drawn on /tf, the fixed joints once, the markers
    assert counts['/tf'] == counts['tip_pose'] and counts['/tf_static'] == 1
    assert counts['markers'] >= 3  # the truss, the target, the planned paths
    data = load_walk(bag)
    assert not data.missing
    assert len(data.step_reports) == 1 and data.step_reports[0].message.to_node == TARGET
    assert set(data.controllers) == {'a_yaw_joint', 'a_pitch_joint', 'vertex_joint',
                                     'b_pitch_joint', 'b_yaw_joint'}
    assert abs(data.tip.position[-1][0] - data.tip.position[0][0]) > 0.1  # the tip moved


def test_the_tip_pose_is_never_the_base_gripper_not_even_idle_after_the_step(walks):
    """``tip_pose`` is the gripper that is not the supervisor's base, in every phase.

    Idle with both grippers attached after the step included.
    """
    data = load_walk(walks[0][1])
    times = np.array([event.time for event in data.phases])
    idle_after_step = 0
    for t, position in zip(data.tip.time, data.tip.position, strict=True):
        event = data.phases[int(np.searchsorted(times, t, side='right')) - 1]
        tip = 'b' if event.base_gripper == 'a' else 'a'
        poses = {g: data.gripper_poses[g] for g in 'ab'}
        at = {g: int(np.searchsorted(poses[g].time, t)) for g in 'ab'}
        assert poses[tip].time[at[tip]] == t
        np.testing.assert_array_equal(position, poses[tip].position[at[tip]])
        if event.phase == Phase.IDLE and event.step_count:
            idle_after_step += 1
    assert idle_after_step > 0  # the idle stance after the step was seen


def _matrix(transform):
    t, q = transform.translation, transform.rotation
    matrix = np.eye(4)
    matrix[:3, :3] = rotation_from_quaternion((q.x, q.y, q.z, q.w))
    matrix[:3, 3] = (t.x, t.y, t.z)
    return matrix


def test_tf_composed_from_the_bag_puts_both_grippers_where_the_plant_has_them(walks):
    """``/tf`` + ``/tf_static`` composed as tf2 does: each gripper at the plant's pose.

    ``gripper_<x>_pose`` of the same stamp, in every phase (the seat's compliance included).
    """
    frames, poses, worst, compared = {}, {'a': {}, 'b': {}}, 0.0, 0
    with BagReader(walks[0][1]) as reader:
        records = list(reader.messages([t for t in reader.topics
                                        if t in ('/tf', '/tf_static')
                                        or t.endswith(('gripper_a_pose', 'gripper_b_pose'))]))
    for record in records:
        if record.topic.endswith('_pose'):
            stamp = record.message.header.stamp
            p = record.message.pose.position
            poses[record.topic[-6]][(stamp.sec, stamp.nanosec)] = np.array([p.x, p.y, p.z])
    for record in records:
        if record.topic not in ('/tf', '/tf_static'):
            continue
        for transform in record.message.transforms:
            frames[transform.child_frame_id] = (transform.header.frame_id,
                                                _matrix(transform.transform))
        if record.topic == '/tf_static':
            continue
        stamp = record.message.transforms[0].header.stamp
        for gripper in 'ab':
            frame, pose = f'gripper_{gripper}', np.eye(4)
            while frame != WORLD_FRAME:
                parent, matrix = frames[frame]
                pose, frame = matrix @ pose, parent
            truth = poses[gripper][(stamp.sec, stamp.nanosec)]
            worst = max(worst, float(np.linalg.norm(pose[:3, 3] - truth)))
            compared += 1
    assert compared > 100
    assert worst < 1e-6, f'{worst * 1e3:.4f} mm'


def test_the_bag_carries_the_truss_map_as_the_supervisor_latches_it(walks):
    """``truss_map_markers``: all nominal at first, the step's nodes surveyed by its end."""
    result, bag = walks[0]
    with BagReader(bag) as reader:
        records = list(reader.messages([t for t in reader.topics
                                        if t.endswith('truss_map_markers')]))
    assert len(records) >= 2, 'latched at the start and again as the surveys changed the map'

    def rgb(r, g, b, *alpha):
        return tuple(round(float(v), 3) for v in (r, g, b))  # the message's are float32

    def status(record):
        return {m.text: rgb(m.color.r, m.color.g, m.color.b) for m in record.message.markers
                if m.ns == 'truss_map_status'}

    nominal, surveyed = rgb(*NOMINAL_COLOR), rgb(*SURVEYED_COLOR)
    first, last = status(records[0]), status(records[-1])
    assert set(first.values()) == {nominal} and len(first) == len(last)
    # the start's two nodes (n1_1 anchors the frame, n2_1 surveyed) and the step's target
    assert {node for node, colour in last.items() if colour == surveyed} == \
        set(result.survey['nodes'])
    assert TARGET in result.survey['nodes']
    assert all(m.header.frame_id == WORLD_FRAME for r in records for m in r.message.markers)


def test_an_unknown_target_is_refused_before_anything_moves(configuration, tmp_path):
    recording = WalkRecording(tmp_path / 'bag')
    try:
        result = walk(configuration, 'n9_9', recording)
    finally:
        recording.close()
    assert not result.reached and 'not on the truss' in result.message
    assert result.periods == 0 and result.reports == ()
    with BagReader(tmp_path / 'bag') as reader:
        rejections = [r.message for r in reader.messages(topics=['/walker/goal_rejections'])]
    assert [(r.action, r.target_node) for r in rejections] == [('walk_to', 'n9_9')]
    assert 'not on the truss' in rejections[0].reason


def test_a_walk_stopped_at_its_wall_time_limit_says_it_timed_out(configuration):
    result = walk(configuration, 'n1_2', wall_timeout=0.0)
    assert not result.reached and result.timed_out
    assert 'did not end within 0 s of wall time' in result.message
    assert 0 < result.periods < 1000  # stopped at the first check, long before the step ends


def test_whole_trajectories_held_by_the_controllers_walk_as_the_setpoint_stream(configuration,
                                                                                 walks):
    """joint_trajectory_controller's way (sent once, sampled in the loop): the same step."""
    streamed = walk(configuration, TARGET, whole_trajectories=False)
    whole = walks[0][0] if configuration.planner.send_whole_trajectories \
        else walk(configuration, TARGET, whole_trajectories=True)
    assert whole.reached and whole.path == streamed.path
    assert whole.periods == streamed.periods
    assert [p.phase for p in whole.phases] == [p.phase for p in streamed.phases]
    for mine, theirs in zip(whole.reports, streamed.reports, strict=True):
        assert mine.phase_durations == pytest.approx(theirs.phase_durations, abs=1e-9)
        assert mine.insertion_attempts == theirs.insertion_attempts
        assert mine.insertion_error == pytest.approx(theirs.insertion_error, abs=1e-5)
