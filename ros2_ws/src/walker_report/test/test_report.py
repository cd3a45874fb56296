"""The report of a known walk: its steps, its figures, its numbers, its animation."""

import json
import math
import re

import numpy as np
import pytest
from PIL import Image

from walker_report.core import figures
from walker_report.core.errors import ReportError
from walker_report.core.report import (
    ReportOptions, default_output_dir, make_report, prepare_output)

from conftest import SMALL_ANIMATION
from synthetic_walk import (
    CLAMPED, END, PEAK_FRACTION, STEPS, TOPICS, URDF_LIMITS, build_walk_bag, walker_truss)

#: Every figure of the synthetic walk's report and its size in inches (times figures.DPI).
FIGURES = {'timeline': None, 'tip_path': (13.0, 6.0), 'joints': (13.0, 11.0),
           'vibration': None, 'steps': None, 'step_01': (13.0, 4.2), 'step_02': (13.0, 4.2)}


def test_the_report_lists_exactly_the_steps_written(report):
    text = report.markdown.read_text()
    headings = re.findall(r'^### (.*)$', text, flags=re.MULTILINE)
    assert headings == [f'step {s.index + 1}: {s.from_node} -> {s.to_node}' for s in STEPS]
    table = [line for line in text.splitlines() if re.match(r'\| [0-9]+ \| [ab] \|', line)]
    assert len(table) == len(STEPS)
    for line, step in zip(table, STEPS, strict=True):
        cells = [c.strip() for c in line.strip('|').split('|')]
        assert cells[:3] == [str(step.index + 1), step.moving,
                             f'{step.from_node} -> {step.to_node}']
        durations = [float(c) for c in cells[4:8]]
        assert durations == pytest.approx([b - a for a, b in step.phases.values()], abs=0.01)
        assert float(cells[11]) == pytest.approx(step.insertion_error * 1e3, abs=0.01)
    numbers = json.loads(report.json.read_text())
    assert [(s['from_node'], s['to_node']) for s in numbers['steps']] == [
        (s.from_node, s.to_node) for s in STEPS]
    assert [s['to_node'] for s in numbers['step_spans']] == [s.to_node for s in STEPS]
    assert all(s['has_report'] for s in numbers['step_spans'])
    assert 'note' not in report.summary  # nothing is missing


@pytest.mark.parametrize('name', sorted(FIGURES))
def test_every_figure_is_a_png_of_the_expected_size_with_something_drawn(report, name):
    path = report.figures[name]
    assert path.parent == report.directory and path.name == f'{name}.png'
    with Image.open(path) as image:
        assert image.format == 'PNG'
        if FIGURES[name] is not None:
            assert image.size == tuple(round(v * figures.DPI) for v in FIGURES[name])
        assert image.width >= 600 and image.height >= 150
        colors = image.convert('RGB').getcolors(maxcolors=2**20)
    assert len(colors) > 20  # not a blank canvas


def test_the_markdown_embeds_every_figure_and_the_animation_and_they_exist(report):
    text = report.markdown.read_text()
    linked = re.findall(r'!\[[^\]]*\]\(([^)]+)\)', text)
    assert set(linked) == {f'{n}.png' for n in FIGURES} | {'walk.gif', 'walk_final.png'}
    for name in linked:
        assert (report.directory / name).stat().st_size > 1000


def test_the_markdown_lists_the_bag_metadata(report, walk_bag):
    text = report.markdown.read_text()
    assert str(walk_bag) in text
    assert f'duration: {END:.2f} s' in text
    for topic, (kind, count) in report.content.walk.bag.topics.items():
        assert f'| {topic} | {kind} | {count} |' in text


def test_the_vibration_near_each_target_is_the_sine_written(report):
    truss = walker_truss()
    for step in STEPS:
        vibration = report.content.vibrations[step.index + 1]
        assert vibration.insertion_start == pytest.approx(step.insertion_start)
        assert vibration.window == pytest.approx((step.insertion_start - 1.0,
                                                  step.insertion_start))
        assert vibration.window_samples == 101  # 100 Hz over 1 s, both ends
        # the sine's largest sampled value is within 0.5 % of its amplitude at 100 Hz
        assert vibration.amplitude == pytest.approx(step.vibration, rel=5e-3)
        assert vibration.hole_offset == pytest.approx(math.hypot(*step.offset), abs=1e-6)
        assert vibration.height == pytest.approx(0.03, abs=1e-6)
        hole = truss.position(step.to_node)
        assert vibration.mean_position[:2] == pytest.approx(hole[:2] + step.offset, abs=1e-6)
        # the deviation shown is along the vibrating axis only
        other = 1 - step.axis
        assert np.max(np.abs(vibration.deviation[vibration.time >= -1.0, other])) < 1e-6
    numbers = json.loads(report.json.read_text())['vibration']
    assert [v['amplitude'] for v in numbers] == pytest.approx([s.vibration for s in STEPS],
                                                              rel=5e-3)


def test_the_joints_are_judged_against_the_recorded_limits(report):
    content = report.content
    assert content.limits.source == 'the recorded robot_description'
    assert content.limits.torque == URDF_LIMITS
    by_joint = {j.joint: j for j in content.joints}
    for joint, limit in URDF_LIMITS.items():
        stats = by_joint[joint]
        assert stats.torque_limit == limit
        assert stats.peak_fraction == pytest.approx(PEAK_FRACTION, rel=1e-9)
        assert stats.saturated == (CLAMPED if joint == 'a_pitch_joint' else 0)
    assert by_joint['a_yaw_joint'].max_error['coarse'] == pytest.approx(0.2)
    assert by_joint['a_yaw_joint'].max_error['fine'] == pytest.approx(1e-4)


def test_the_animation_has_one_frame_per_half_second_of_the_walk(report):
    animation = report.animation
    expected = math.floor(END * SMALL_ANIMATION.fps) + 1  # joint states from 0 to END
    assert animation.frames == expected
    with Image.open(animation.path) as gif:
        assert gif.format == 'GIF'
        assert gif.n_frames == expected
        assert gif.size == (SMALL_ANIMATION.width, SMALL_ANIMATION.height)
        assert gif.info['duration'] == 500  # real time: half a second per frame
        assert gif.info['loop'] == 0
    with Image.open(animation.still) as still:
        assert still.size == (2 * SMALL_ANIMATION.width, 2 * SMALL_ANIMATION.height)


def test_a_bag_without_reports_or_controllers_gives_what_it_can_and_says_what_is_missing(
        tmp_path):
    bag = build_walk_bag(tmp_path / 'bag', reports=False, controllers=False,
                         description=False, safe_hold=True)
    result = make_report(bag, tmp_path / 'out', options=ReportOptions(animation=False))
    assert result.content.rows == []
    notes = '\n'.join(result.content.notes)
    assert '/walker/step_reports: no per-step table' in notes
    assert '/walker/controllers/*/state: no joint errors and torques' in notes
    assert 'torque limits from the parameter file' in notes
    assert 'ended in SAFE_HOLD at 10.00 s: fine overran its planned time' in notes
    assert 'step 2: n1_1 -> n2_2 never began insertion' in notes
    assert result.content.limits.source == 'the parameter file'
    assert set(result.figures) == {'timeline', 'tip_path', 'joints', 'vibration', 'steps',
                                   'step_01', 'step_02'}
    assert list(result.content.vibrations) == [1]
    text = result.markdown.read_text()
    assert 'SAFE_HOLD at 10.00 s' in text and 'No step report in the bag' in text
    assert result.animation is None and not (tmp_path / 'out' / 'walk.gif').exists()


def test_a_bag_without_poses_states_or_phases_still_gives_a_report(tmp_path):
    left_out = ('tip_pose', 'joint_states', 'phase', 'gripper_states', 'control_mode')
    bag = build_walk_bag(tmp_path / 'bag', leave_out=left_out)
    result = make_report(bag, tmp_path / 'out',
                         options=ReportOptions(animation_options=SMALL_ANIMATION))
    notes = '\n'.join(result.content.notes)
    for topic in left_out:
        assert f'the bag has no /walker/{topic}: ' in notes
    assert 'no animation: the bag has no joint_states' in notes
    assert result.animation is None and result.content.spans == []
    assert len(result.content.rows) == len(STEPS)  # the step reports are still there
    assert set(result.figures) == {'timeline', 'tip_path', 'joints', 'vibration', 'steps'}


def test_what_cannot_be_measured_is_null_in_the_json_not_nan(tmp_path):
    bag = build_walk_bag(tmp_path / 'bag', leave_out=('tip_pose',))
    result = make_report(bag, tmp_path / 'out',  # the synthetic walk's 1 s settling window
                         options=ReportOptions(animation=False, settle_time=1.0))
    assert all(math.isnan(v.amplitude) for v in result.content.vibrations.values())

    def refuse(constant):
        raise AssertionError(f'report.json holds {constant}, which is not JSON')

    numbers = json.loads(result.json.read_text(), parse_constant=refuse)
    assert [v['amplitude'] for v in numbers['vibration']] == [None, None]
    assert '| 1 | n1_2 | 4.00 - 5.00 | 0 | - | - | - |' in result.markdown.read_text()


def test_a_bag_without_messages_is_refused(tmp_path):
    bag = build_walk_bag(tmp_path / 'bag', leave_out=tuple(TOPICS))
    with pytest.raises(ReportError, match='holds no message'):
        make_report(bag, tmp_path / 'out')
    assert not (tmp_path / 'out').exists()


def test_a_report_replaces_the_files_of_a_former_one(tmp_path):
    out = tmp_path / 'out'
    out.mkdir()
    for name in ('step_07.png', 'walk.gif', 'walk_final.png', 'notes.txt'):
        (out / name).write_bytes(b'old')
    assert prepare_output(out) == out
    assert sorted(p.name for p in out.iterdir()) == ['notes.txt']  # not the report's: kept


def test_the_default_output_is_beside_the_bag(walk_bag):
    assert default_output_dir(walk_bag) == walk_bag.parent / 'bag_report'
    assert default_output_dir(walk_bag / 'bag_0.mcap') == walk_bag.parent / 'bag_report'


@pytest.mark.parametrize(('change', 'message'), [
    ({'bag': 'missing'}, 'is not a bag directory'),
    ({'params_file': 'bad.yaml'}, 'the parameter file .*bad.yaml'),
    ({'out': 'file'}, 'exists and is not a directory'),
])
def test_bad_input_is_refused_before_anything_is_written(tmp_path, walk_bag, change, message):
    (tmp_path / 'file').write_text('x')
    (tmp_path / 'bad.yaml').write_text('/**:\n  ros__parameters:\n    truss: {spacing: -1}\n')
    arguments = {'bag': walk_bag, 'out': tmp_path / 'out', 'params_file': None}
    arguments.update({k: tmp_path / v for k, v in change.items()})
    with pytest.raises(ReportError, match=message):
        make_report(arguments['bag'], arguments['out'], arguments['params_file'])
    assert not (tmp_path / 'out').exists()


def test_invalid_options_are_refused():
    with pytest.raises(ReportError, match='settling window'):
        ReportOptions(settle_time=-1.0)
    with pytest.raises(ReportError, match='settling window'):
        ReportOptions(settle_time=math.nan)


def test_the_settling_window_is_the_parameter_files(tmp_path, walk_bag):
    """Without an option the window is the file's ``supervisor.settle_time``."""
    import yaml

    from walker_core.parameter_file import default_parameter_file

    document = yaml.safe_load(default_parameter_file().read_text())
    document['/**']['ros__parameters']['supervisor']['settle_time'] = 1.0
    params_file = tmp_path / 'walker.yaml'
    params_file.write_text(yaml.safe_dump(document))
    result = make_report(walk_bag, tmp_path / 'out', params_file,
                         options=ReportOptions(animation=False))
    assert result.content.settle_time == 1.0


def test_the_report_says_what_the_bag_lacks_losses_and_a_recorders_downtime(tmp_path):
    """A frozen recorder's losses and a killed one's gap, from the bag's own record."""
    bag = build_walk_bag(tmp_path / 'bag', custom_data={
        'messages_lost': '477', 'messages_lost /walker/joint_states': '405',
        'messages_lost /clock': '72',
        'recorder_gap /walker/joint_states': '2000000000 3670000000 834'})
    report = make_report(bag, tmp_path / 'report',
                         options=ReportOptions(animation=False, settle_time=1.0))
    assert report.content.walk.bag.losses['messages_lost'] == 477
    text = report.markdown.read_text()
    assert '**What the bag lacks**' in text
    assert '477 messages lost on the way to the recorder: /clock 72, /walker/joint_states 405' \
        in text
    assert 'about 834 messages not recorded while the recorder was down (up to 1.67 s)' in text


def test_a_bag_that_lacks_nothing_says_nothing_of_it(report):
    assert 'What the bag lacks' not in report.markdown.read_text()


def test_a_walk_without_camera_frames_says_nothing_of_cameras(report):
    assert 'camera' not in report.markdown.read_text().lower()
    assert 'camera' not in report.summary.lower()
    assert 'screw_in_frames' not in json.loads(report.json.read_text())
    assert report.content.screw_ins == ()
