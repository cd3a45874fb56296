"""Reading a walk from its bag and what is computed from it: phases, steps, joints, frames."""

import math
import shutil

import numpy as np
import pytest

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_core.robot_parameters import load_walker_parameters
from walker_report.core.analysis import (
    EXTRACTION, FINE, IDLE, INSERTION, SAFE_HOLD, joint_limits, phase_intervals, step_spans,
    target_vibration)
from walker_report.core.animation import AnimationOptions, plan_frames, sample_states
from walker_report.core.errors import BagCutShortError, ReportError
from walker_report.core.walk_data import PhaseEvent, PoseSeries, load_walk

from synthetic_walk import (
    END, PHASE_CODES, SAFE_HOLD_REASON, STEPS, build_walk_bag, joint_positions, phase_events,
    tip_position)


@pytest.fixture(scope='module')
def walk(walk_bag):
    return load_walk(walk_bag)


def test_the_timeline_intervals_are_the_phases_written(walk):
    intervals = phase_intervals(walk.phases, walk.end_time)
    events = phase_events()
    assert [(i.phase, i.step_index, i.from_node, i.to_node) for i in intervals] == [
        (PHASE_CODES[name], index, source, target)
        for _, name, index, _, source, target, _ in events]
    starts = [e[0] for e in events]
    assert [i.start for i in intervals] == pytest.approx(starts, abs=1e-9)
    assert [i.end for i in intervals] == pytest.approx(starts[1:] + [END], abs=1e-9)


def test_the_steps_are_the_steps_written_with_their_reports(walk):
    spans = step_spans(phase_intervals(walk.phases, walk.end_time), walk.step_reports)
    assert [(s.number, s.step_index, s.from_node, s.to_node) for s in spans] == [
        (s.index + 1, s.index, s.from_node, s.to_node) for s in STEPS]
    for span, step in zip(spans, STEPS, strict=True):
        assert (span.start, span.end) == pytest.approx((step.start, step.end))
        assert span.insertion_start == pytest.approx(step.insertion_start)
        assert [i.name for i in span.intervals] == list(step.phases)
        assert span.report.message.to_node == step.to_node and span.safe_hold is None


def _event(time, phase, index=0, source='n0_0', target='n1_0', reason=''):
    return PhaseEvent(time, phase, 'a', index, 2, source, target, reason)


def test_repeated_phase_messages_merge_and_a_safe_hold_ends_its_step():
    events = [_event(0.0, IDLE, source='', target=''), _event(1.0, EXTRACTION),
              _event(1.5, EXTRACTION), _event(2.0, FINE), _event(3.0, SAFE_HOLD, reason='jam'),
              _event(3.5, SAFE_HOLD, index=1, source='', target='', reason='jam'),
              _event(4.0, IDLE, source='', target=''), _event(4.5, IDLE, index=1),
              _event(5.0, EXTRACTION), _event(6.0, INSERTION)]
    intervals = phase_intervals(events, 7.0)
    assert [(i.phase, i.start, i.end) for i in intervals] == [
        (IDLE, 0.0, 1.0), (EXTRACTION, 1.0, 2.0), (FINE, 2.0, 3.0), (SAFE_HOLD, 3.0, 4.0),
        (IDLE, 4.0, 5.0), (EXTRACTION, 5.0, 6.0), (INSERTION, 6.0, 7.0)]
    first, again = step_spans(intervals)
    assert first.safe_hold.reason == 'jam' and first.insertion_start is None
    assert (first.number, again.number) == (1, 2)  # the same step tried again is a new row
    assert again.insertion_start == 6.0 and again.report is None


def test_a_safe_hold_outside_any_step_belongs_to_no_step():
    intervals = phase_intervals([_event(0.0, IDLE), _event(1.0, SAFE_HOLD, reason='hold')], 2.0)
    assert step_spans(intervals) == []


def test_a_new_fault_while_holding_is_a_new_interval():
    intervals = phase_intervals([_event(1.0, SAFE_HOLD, reason='jam'),
                                 _event(2.0, SAFE_HOLD, reason='base gripper free')], 3.0)
    assert [(i.start, i.reason) for i in intervals] == [(1.0, 'jam'),
                                                         (2.0, 'base gripper free')]


def test_joint_states_are_reordered_to_the_physical_joints(walk):
    assert walk.joints.position.shape == (int(END * 50) + 1, 5)
    for k in (0, 100, 400):
        assert walk.joints.position[k] == pytest.approx(joint_positions(walk.joints.time[k]))


def test_the_tip_and_the_grippers_are_read_with_their_stamps(walk):
    assert walk.tip.time == pytest.approx(np.arange(int(END * 100) + 1) / 100)
    for k in (0, 420, 1100):
        assert walk.tip.position[k] == pytest.approx(tip_position(walk.tip.time[k]), abs=1e-12)
    assert walk.namespace == '/walker' and walk.missing == ()
    assert walk.bag.clock == 'sim_time'


def test_the_vibration_window_needs_a_positive_time(walk):
    spans = step_spans(phase_intervals(walk.phases, walk.end_time))
    with pytest.raises(ValueError, match='positive time'):
        target_vibration(spans[0], walk.tip, 0.0)
    empty = target_vibration(spans[0], PoseSeries.empty(), 1.0)
    assert math.isnan(empty.amplitude) and empty.window_samples == 0


def test_torque_limits_come_from_the_urdf_else_the_parameter_file():
    params = load_walker_parameters()
    from_file = joint_limits('', params)
    assert from_file.source == 'the parameter file'
    assert from_file.torque == {'a_yaw_joint': 10.0, 'a_pitch_joint': 12.0,
                                'vertex_joint': 10.0, 'b_pitch_joint': 12.0,
                                'b_yaw_joint': 10.0}
    assert joint_limits('<robot', params).source.startswith('the parameter file (the recorded')
    partial = ('<robot name="w"><joint name="vertex_joint" type="revolute">'
               '<limit effort="7.5" lower="-1" upper="1" velocity="1"/></joint></robot>')
    limits = joint_limits(partial, params)
    assert limits.torque['vertex_joint'] == 7.5 and limits.torque['a_yaw_joint'] == 10.0
    assert limits.source == 'the recorded robot_description and the parameter file'


def test_a_bag_cut_short_is_refused_with_the_way_to_recover_it(tmp_path, walk_bag):
    cut = tmp_path / 'cut'
    shutil.copytree(walk_bag, cut)
    mcap = cut / 'bag_0.mcap'
    mcap.write_bytes(mcap.read_bytes()[:mcap.stat().st_size // 2])
    with pytest.raises(BagCutShortError, match=r'cut short.*bag_info .*cut --recover'):
        load_walk(cut)


def test_a_directory_that_is_not_a_bag_is_refused(tmp_path):
    with pytest.raises(ReportError, match='not a bag directory'):
        load_walk(tmp_path / 'nothing')
    (tmp_path / 'empty').mkdir()
    with pytest.raises(ReportError, match='cannot read the bag'):
        load_walk(tmp_path / 'empty')


def test_frames_are_taken_every_period_of_the_walk_up_to_the_limit():
    plan = plan_frames(0.0, 12.5, 10.0, 600)
    assert len(plan.times) == 126 and plan.times[-1] == pytest.approx(12.5)
    assert plan.interval == pytest.approx(0.1) and plan.delay == 0.1 and plan.speedup == 1.0
    long = plan_frames(0.0, 300.0, 10.0, 600)
    assert len(long.times) == 600 and long.times[-1] == pytest.approx(300.0)
    assert long.speedup == pytest.approx(300.0 / 599 / 0.1)
    assert len(plan_frames(5.0, 5.0, 10.0, 600).times) == 1
    with pytest.raises(ValueError, match='finite time span'):
        plan_frames(1.0, 0.0, 10.0, 600)


@pytest.mark.parametrize(('option', 'value'), [
    ('fps', 0.0), ('fps', math.inf), ('fps', 100.0), ('max_frames', 1), ('width', 8),
    ('height', 10_000), ('max_frames', 2.5)])
def test_invalid_animation_options_are_refused(option, value):
    with pytest.raises(ValueError, match=option.replace('_', '.?') if option != 'fps'
                       else 'frames per second'):
        AnimationOptions(**{option: value})


def test_each_frame_takes_the_latest_state_at_or_before_it(walk):
    joints, position, _ = sample_states(walk, np.array([0.0, 1.015, 12.5]))
    assert joints[1] == pytest.approx(joint_positions(1.0))  # 50 Hz states: the one at 1.00 s
    assert position[2] == pytest.approx(walk.gripper_poses['a'].position[-1])
    assert joints.shape == (3, len(PHYSICAL_JOINT_NAMES))


def test_a_walk_without_joint_states_cannot_be_animated(tmp_path):
    bag = build_walk_bag(tmp_path / 'bag', controllers=False)
    walk = load_walk(bag)
    bare = walk.__class__(**{**walk.__dict__, 'joints': walk.joints.empty()})
    with pytest.raises(ValueError, match='no joint_states'):
        sample_states(bare, np.zeros(1))


def test_the_safe_hold_variant_has_its_reason(tmp_path):
    walk = load_walk(build_walk_bag(tmp_path / 'bag', safe_hold=True, reports=False))
    spans = step_spans(phase_intervals(walk.phases, walk.end_time), walk.step_reports)
    assert spans[1].safe_hold.reason == SAFE_HOLD_REASON
    assert spans[1].safe_hold.end == pytest.approx(END)
