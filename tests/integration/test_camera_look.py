"""A step that looks through the wrist camera, over DDS in sim time, on a truss as built.

``run_all.py --sim-time --composed-loop`` (the plant and the controllers in one process, the
planner and the supervisor in processes of their own) walks one step with the cameras on
(``gripper.camera.enabled``) over a truss whose nodes the plant places off the parameter
file's (``sim.imperfections.node_placement``, a fixed seed). In FINE above the hole the
supervisor triggers the moving gripper's camera (``camera_b/trigger``) and the plant's frame
crosses processes on ``camera_b/image_raw`` back to it: every look gets its frame (the
supervisor logs what it showed, never that none came), and the step screws in. The walk's bag
holds each frame with the plant's truth and the supervisor's measurement of the same stamp, and
its report shows the last frame before the screw-in.
"""

import json
import os
import re
import subprocess
import sys

import numpy as np
import pytest

from ros_test_support import REPO_ROOT, isolated_domain, processes_with, ros_environment

pytestmark = [pytest.mark.integration, pytest.mark.timeout(420)]

TARGET = 'n1_2'
PLACEMENT, PLACEMENT_SEED = 0.002, 0  # [m], seed: the truss as built
RUN_TIMEOUT = 360.0  # [s] wall: about 60 s on a loaded 2-core machine (not a measurement)


def _parameter_file(path):
    """Write the shipped file with the cameras on and the nodes placed off their places."""
    text = (REPO_ROOT / 'ros2_ws' / 'src' / 'walker_core' / 'config' / 'walker.yaml').read_text()
    for pattern, value in ((r'enabled: false( +# chosen: the paper)', r'enabled: true\1'),
                           (r'node_placement: 0\.0 ', f'node_placement: {PLACEMENT} '),
                           (r'(\n +seed: )0 ', rf'\g<1>{PLACEMENT_SEED} ')):
        text, count = re.subn(pattern, value, text)
        assert count == 1, f'{pattern!r} is no longer in the parameter file'
    path.write_text(text)
    return path


def test_a_step_on_a_truss_as_built_looks_through_the_camera_and_screws_in(tmp_path):
    namespace = f'/walker_camera_check_{os.getpid()}'
    out = tmp_path / 'run'
    args = [sys.executable, str(REPO_ROOT / 'scripts' / 'run_all.py'), '--sim-time',
            '--composed-loop', '--params-file', str(_parameter_file(tmp_path / 'walker.yaml')),
            '--namespace', namespace, '--out', str(out), '--target', TARGET, '--no-report',
            '--quiet']
    with isolated_domain() as domain:
        run = subprocess.run(args, env=ros_environment(domain), stdout=subprocess.PIPE,
                             stderr=subprocess.STDOUT, text=True, cwd=REPO_ROOT,
                             timeout=RUN_TIMEOUT)
    log = (out / 'logs' / 'supervisor.log').read_text() \
        if (out / 'logs' / 'supervisor.log').exists() else ''
    assert run.returncode == 0, f'{run.stdout}\n{log[-4000:]}'
    summary = json.loads((out / 'summary.json').read_text())
    assert summary['reached'] and summary['path'] == [TARGET], summary
    step, = summary['steps']
    assert step['success'], step
    seen = re.findall(rf'camera of gripper b: hole of {TARGET}\b.*', log)
    assert seen, f'the supervisor never saw a frame:\n{log[-4000:]}'
    assert 'no frame from the camera' not in log, log[-4000:]
    assert processes_with(namespace) == [], run.stdout
    _the_bag_holds_the_looks(out / 'bag', namespace, len(seen), tmp_path)


def _stamp(message):
    return message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec


def _the_bag_holds_the_looks(bag, namespace, looks, tmp_path):
    """Each look's frames, with the truth and the measurement beside each; and the report."""
    from walker_bag.core.bag_reader import BagReader
    from walker_report.core.report import ReportOptions, make_report

    camera = f'{namespace}/camera_b'
    with BagReader(bag) as reader:
        records = list(reader.messages([f'{camera}/{name}' for name in (
            'image_raw', 'camera_info', 'true_hole', 'hole')]))
    by_topic = {}
    for record in records:
        by_topic.setdefault(record.topic.rsplit('/', 1)[1], []).append(record.message)
    images = by_topic['image_raw']
    assert len(images) == 3 * looks, 'a look is three frames, and the bag holds no other'
    assert len(by_topic['camera_info']) == len(images)
    assert [_stamp(m) for m in by_topic['true_hole']] == [_stamp(m) for m in images]
    assert {_stamp(m) for m in by_topic['hole']} <= {_stamp(m) for m in images}
    assert by_topic['hole'] and all(m.header.frame_id == 'gripper_b' for m in by_topic['hole'])
    image = images[-1]
    assert image.encoding == 'rgb8' and np.asarray(image.data).size == 3 * image.width * \
        image.height
    report = make_report(bag, tmp_path / 'report', tmp_path / 'walker.yaml',
                         ReportOptions(animation=False))
    shown, = json.loads(report.json.read_text())['screw_in_frames']
    assert (shown['to_node'], shown['gripper']) == (TARGET, 'b')
    assert round(shown['stamp'] * 1e9) == _stamp(images[-1])  # the last frame before the descent
    hole = {_stamp(m): m.point for m in by_topic['hole']}[_stamp(images[-1])]
    assert shown['measured'] == pytest.approx([hole.x, hole.y, hole.z], abs=1e-12)
    assert (report.directory / shown['figure']).is_file()
