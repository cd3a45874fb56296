"""Samples for the campaign tests: a small spec, and a fast stand-in for a walk.

The stand-in reads what a walk would read (the model's and the truth's files) and makes up a
summary from them, so the campaign machinery (files, seeds, rows, resume) is tested in
milliseconds. Its figures mean nothing about the walker.
"""

import math
import time

from walker_core.parameter_schema import load_parameter_file

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
