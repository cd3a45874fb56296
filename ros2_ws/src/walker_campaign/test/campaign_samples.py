"""Samples for the campaign tests: a small spec, and a fast stand-in for a walk.

The stand-in reads what a walk would read (the model's and the truth's files) and makes up a
summary from them, so the campaign machinery (files, seeds, rows, resume) is tested in
milliseconds. Its figures mean nothing about the walker.
"""

import math
import time
from pathlib import Path

import yaml

from walker_core.parameter_schema import load_parameter_file
from walker_supervisor.core.truss_map import SURVEY_FORMAT

#: Two dispersions (one drawn per joint), a 2 x 2 sweep, 3 runs per point: 12 runs.
SMALL_SPEC = {
    'seed': 11, 'runs': 3, 'route': {'target': 'n1_2'},
    'dispersions': {
        'friction': {'parameters': ['robot.drive.*.friction_torque',
                                    'robot.drive.*.stiction_torque'],
                     'apply': 'scale', 'uniform': {'low': 0.9, 'high': 1.2}},
        'offset': {'parameter': 'sim.imperfections.joint_offset', 'per_parameter': True,
                   'normal': {'mean': 0.0, 'std': 0.0002}}},
    'sweeps': {'control.coarse.acceleration_feedback[0]': [0.0, 0.25],
               'planner.bang_bang.torque_fraction': [0.7, 0.8]}}


def stand_in_walk(request, seconds: float = 0.0):
    """Make up a summary of two steps whose figures follow the truth's friction and offset."""
    truth = load_parameter_file(request.truth_file)
    model = load_parameter_file(request.model_file)
    friction = truth['robot.drive.yaw.friction_torque'] / model['robot.drive.yaw.friction_torque']
    offset = sum(abs(v) for v in truth['sim.imperfections.joint_offset'])
    if seconds:
        time.sleep(seconds)
    steps = []
    for index in range(2):
        error = 0.0003 + offset * 0.9 + 0.0001 * index
        success = error < truth['gripper.insertion_position_tolerance']
        steps.append({
            'index': index, 'gripper': 'ab'[index % 2], 'from_node': 'n2_1', 'to_node': 'n1_2',
            'sweep': math.pi / 2, 'success': success,
            'phase_durations': {'extraction': 0.8, 'coarse': 2.0 * friction, 'fine': 0.3,
                                'insertion': 1.0},
            'duration': 4.1 + 2.0 * (friction - 1.0), 'bound': 2.73,
            'insertion_error': error, 'insertion_error_estimated': error * 0.8,
            'residual_vibration': 0.0002, 'attempts': 1 if success else 3,
            'message': '' if success else f'insertion jammed 3 times: {error * 1e3:.2f} mm off'})
        if not success:
            break
    reached = all(s['success'] for s in steps)
    return {'steps': steps, 'reached': reached, 'target': request.target,
            'message': 'reached' if reached else 'step aborted: insertion jammed'}


def slow_stand_in_walk(request):
    """Walk the stand-in for a few seconds, as a short walk takes (for the Ray test)."""
    return stand_in_walk(request, seconds=4.0)


def survey_content(nodes: dict[str, list[float]], anchor: str = 'n2_1') -> dict:
    """Return a survey file's content: ``nodes`` at the positions [m] given, 1 mm std."""
    entries = {node: {'position': position,
                      'covariance': [[1e-6 if i == j else 0.0 for j in range(3)]
                                     for i in range(3)]}
               for node, position in nodes.items()}
    entries.setdefault(anchor, {'position': [0.0, 0.0, 0.0],
                                'covariance': [[0.0] * 3 for _ in range(3)]})
    return {'format': SURVEY_FORMAT, 'frame': 'truss', 'anchor': anchor, 'nodes': entries}


def surveying_stand_in_walk(request):
    """Walk the stand-in, surveying: probe for a hole unless the survey has the target.

    It writes a survey of the target into its output directory and names it in its summary,
    as a headless walk does; the survey it started from is named in the summary too.
    """
    summary = stand_in_walk(request)
    known = {}
    if request.truss_survey is not None:
        known = yaml.safe_load(Path(request.truss_survey).read_text())['nodes']
    for step in summary['steps']:
        step['search_probes'] = 0 if request.target in known else 4
    out = Path(request.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    survey = out / 'truss_survey.yaml'
    survey.write_text(yaml.safe_dump(survey_content({request.target: [0.0, 0.3, 0.0]})))
    summary['truss_survey_file'] = str(survey)
    summary['started_from'] = str(request.truss_survey) if request.truss_survey else None
    return summary
