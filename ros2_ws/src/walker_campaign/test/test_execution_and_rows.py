"""One run carried out where it is scheduled: its files, its walk, its rows."""

import pytest

from campaign_samples import stand_in_walk
from walker_campaign.core.parameter_sets import load_nominal
from walker_campaign.core.plan import plan_run
from walker_campaign.core.rows import (
    cause_of, combined_summary, deterministic_part, error_rows, run_rows)
from walker_campaign.execution import RunTask, execute_run
from walker_campaign.walks import WalkError
from walker_core.parameter_schema import load_parameter_file


def task(spec, index, walk=stand_in_walk, record_dir=None):
    return RunTask(spec.name, plan_run(spec, index), spec.target, spec.walk_timeout, walk,
                   record_dir)


def test_the_walk_gets_the_model_and_the_truth_bit_for_bit(small_spec, tmp_path):
    seen = {}

    def walk(request):
        seen['model'] = load_parameter_file(request.model_file)
        seen['truth'] = load_parameter_file(request.truth_file)
        return {'steps': [], 'reached': False, 'message': 'no step'}

    plan = plan_run(small_spec, 5)
    execute_run(task(small_spec, 5, walk), small_spec.document)
    for name, value in plan.truth_values.items():
        assert seen['truth'][name] == value  # floats exactly, through the YAML file
    for name in ('robot.drive.yaw.friction_torque', 'sim.imperfections.joint_offset'):
        assert seen['model'][name] == small_spec.nominal[name]  # the model is nominal
    for name, value in plan.model_values.items():
        assert seen['model'][name] == value
    assert seen['truth']['sim.imperfections.seed'] == plan.imperfection_seed


def test_a_run_gives_its_step_rows_then_its_run_row(small_spec):
    rows = execute_run(task(small_spec, 2), small_spec.document)
    *steps, run = rows
    assert [r['kind'] for r in rows] == ['step'] * len(steps) + ['run']
    plan = plan_run(small_spec, 2)
    for row in rows:
        assert row['index'] == 2 and row['point'] == plan.point
        assert row['sweep.control.coarse.acceleration_feedback[0]'] == plan.sweep[
            'control.coarse.acceleration_feedback[0]']
        assert row['draw.friction'] == plan.draws['friction']
    assert run['outcome'] == 'reached' and run['steps'] == 2 and run['jams'] == 0
    assert run['walk_time'] == pytest.approx(sum(s['duration'] for s in steps))
    assert steps[0]['bound_ratio'] == pytest.approx(steps[0]['duration'] / steps[0]['bound'])
    assert steps[0]['phase.coarse'] > 0
    assert run['exec.walk'] == 'stand_in_walk' and run['exec.wall_time'] >= 0


def test_a_run_repeated_gives_the_same_rows_but_for_how_it_ran(small_spec):
    first = execute_run(task(small_spec, 7), small_spec.document)
    again = execute_run(task(small_spec, 7), small_spec.document)
    assert [deterministic_part(r) for r in first] == [deterministic_part(r) for r in again]
    assert not any(k.startswith('exec.') for k in deterministic_part(first[-1]))


def test_a_failed_walk_counts_its_jams_and_names_its_cause(small_spec):
    plan = plan_run(small_spec, 0)
    summary = {'steps': [
        {'index': 0, 'success': True, 'attempts': 2, 'duration': 5.0, 'bound': 2.5,
         'insertion_error': 0.0004, 'message': ''},
        {'index': 1, 'success': False, 'attempts': 3, 'duration': 9.0, 'bound': 2.5,
         'insertion_error': 0.0031, 'message': 'insertion jammed 3 times: 3.10 mm off'}],
        'reached': False, 'message': 'the walk stopped at step 2'}
    *steps, run = run_rows('c', plan, summary)
    assert [s['jams'] for s in steps] == [1, 3]
    assert run['outcome'] == 'failed' and run['jams'] == 4 and run['steps_ok'] == 1
    assert run['cause'] == 'insertion jammed # times'
    assert run['tip_error_max'] == 0.0031 and run['step_ratio_max'] == 9.0 / 2.5


@pytest.mark.parametrize('message, cause', [
    ('insertion jammed 3 times: tip 2.31 mm off', 'insertion jammed # times'),
    ('coarse overran its planned time by 20.0 s', 'coarse overran its planned time by # s'),
    ('the base gripper a reports free (it was attached)', 'the base gripper a reports free'),
    ('', 'unknown')])
def test_causes_group_messages_that_differ_in_numbers(message, cause):
    assert cause_of(message) == cause


def test_a_walk_that_cannot_run_becomes_an_error_row(small_spec):
    def refused(request):
        raise WalkError('the plant refused its parameters')

    def crashed(request):
        raise ZeroDivisionError('boom')

    rows = execute_run(task(small_spec, 1, refused), small_spec.document)
    assert len(rows) == 1 and rows[0]['outcome'] == 'error'
    assert rows[0]['message'] == 'the plant refused its parameters'
    rows = execute_run(task(small_spec, 1, crashed), small_spec.document)
    assert rows[0]['outcome'] == 'error' and rows[0]['message'].startswith(
        'ZeroDivisionError: boom (test_execution_and_rows.py:')
    rows = execute_run(task(small_spec, 1, 'teleport'), small_spec.document)
    assert rows[0]['message'].startswith("no walk function 'teleport'")
    assert error_rows('c', plan_run(small_spec, 1), 'x')[0]['steps'] == 0


def test_a_recorded_run_keeps_its_files(small_spec, tmp_path):
    execute_run(task(small_spec, 3, record_dir=str(tmp_path / 'run3')), small_spec.document)
    flat = load_parameter_file(tmp_path / 'run3' / 'truth.yaml')
    assert flat['sim.imperfections.seed'] == plan_run(small_spec, 3).imperfection_seed
    assert load_nominal(tmp_path / 'run3' / 'model.yaml')[0]['robot.mass.link'] == \
        small_spec.nominal['robot.mass.link']


def test_a_search_on_a_jam_shows_its_probes_and_where_the_hole_was_found(small_spec):
    plan = plan_run(small_spec, 0)
    summary = {'steps': [
        {'index': 0, 'success': True, 'attempts': 4, 'duration': 12.0, 'bound': 2.5,
         'insertion_error': 0.0004, 'message': '', 'search_probes': 3,
         'hole_offset': 0.0026},
        {'index': 1, 'success': True, 'attempts': 1, 'duration': 4.0, 'bound': 2.5,
         'insertion_error': 0.0003, 'message': '', 'search_probes': 0, 'hole_offset': 0.0}],
        'reached': True, 'message': ''}
    *steps, run = run_rows('c', plan, summary)
    assert [s['probes'] for s in steps] == [3, 0]
    assert [s['hole_offset'] for s in steps] == [0.0026, 0.0]
    assert run['probes'] == 3 and run['jams'] == 3 and run['outcome'] == 'reached'


def test_the_run_row_carries_the_grip_monitor_and_an_old_summary_reads_without_it(small_spec):
    """The summary's ``grip_monitor`` becomes the run row's grip counts.

    ``grip_states`` and ``grip_losses``; a summary without one (the graph's, an older file)
    gives None, not 0.
    """
    plan = plan_run(small_spec, 0)
    step = {'index': 0, 'success': False, 'attempts': 3, 'duration': 9.0, 'bound': 2.5,
            'message': 'insertion jammed 3 times'}
    summary = {'steps': [step], 'reached': False, 'message': 'insertion jammed 3 times',
               'grip_monitor': {'states': 412, 'no_gripper_attached': 2}}
    run = run_rows('c', plan, summary)[-1]
    assert (run['grip_states'], run['grip_losses']) == (412, 2)
    old = run_rows('c', plan, {k: v for k, v in summary.items() if k != 'grip_monitor'})[-1]
    assert old['grip_states'] is None and old['grip_losses'] is None


def test_walks_on_one_truss_sum_their_grip_monitors():
    first = {'steps': [], 'reached': True, 'grip_monitor': {'states': 10,
                                                            'no_gripper_attached': 0}}
    second = {'steps': [], 'reached': True, 'grip_monitor': {'states': 12,
                                                             'no_gripper_attached': 1}}
    assert combined_summary([first, second])['grip_monitor'] == {
        'states': 22, 'no_gripper_attached': 1}
    assert 'grip_monitor' not in combined_summary([first, {'steps': [], 'reached': True}])


def test_the_run_row_carries_the_looks_and_each_approachs_last_vision_error(small_spec):
    plan = plan_run(small_spec, 0)
    looks = [{'seen': True, 'error': 0.002, 'final': False},
             {'seen': True, 'error': 0.00008, 'final': True},
             {'seen': False, 'error': None, 'final': True},
             {'seen': True, 'error': 0.00012, 'final': True}]
    summary = {'steps': [], 'reached': True, 'message': '', 'looks': looks}
    run = run_rows('c', plan, summary)[-1]
    assert (run['looks'], run['looks_unseen']) == (4, 1)
    assert run['vision_errors'] == [0.00008, 0.00012]
    blind = run_rows('c', plan, {'steps': [], 'reached': True, 'message': ''})[-1]
    assert blind['looks'] is None and blind['vision_errors'] is None
    both = combined_summary([summary, {'steps': [], 'reached': True, 'looks': looks[:1]}])
    assert both['looks'] == looks + looks[:1]
