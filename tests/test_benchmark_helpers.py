"""The benchmark suite's pure helpers: percentiles, loop statistics, the table, summary.json."""

import json
import math
import sys

import numpy as np
import pytest
from ros_test_support import REPO_ROOT

sys.path.insert(0, str(REPO_ROOT / 'benchmarks'))

import bench_support
import run_benchmarks


def test_percentiles_are_in_milliseconds():
    values_ns = np.arange(1, 101) * 1_000_000  # 1 ... 100 ms
    stats = bench_support.percentiles_ms(values_ns)
    assert stats['count'] == 100
    assert stats['median_ms'] == pytest.approx(50.5)
    assert stats['p99_ms'] == pytest.approx(99.01)
    assert stats['max_ms'] == pytest.approx(100.0)


def test_percentiles_of_nothing_are_only_a_count():
    assert bench_support.percentiles_ms([]) == {'count': 0}


def _events(round_trips_ns, period_ns=2_000_000, start=10_000_000_000):
    """Probe arrays of states published each period, answered by five joints in one message."""
    count = len(round_trips_ns)
    sent = start + period_ns * np.arange(count, dtype=np.int64)
    stamps = 1_000_000_000 + period_ns * np.arange(count, dtype=np.int64)
    zeros = np.zeros(count, dtype=np.int64)
    return {'tick': sent.copy(), 'publish_stamp': stamps, 'publish_time': sent,
            'plant_missed': zeros, 'overruns': zeros, 'lockstep_timeouts': zeros,
            'effort_stamp': stamps, 'effort_time': sent + np.asarray(round_trips_ns, np.int64),
            'effort_count': np.full(count, 5, dtype=np.int64)}


def test_loop_statistics_round_trip_and_missed_periods():
    period = 2_000_000
    trips = [500_000] * 9 + [3_000_000]  # the last answer comes after the next tick
    trips = trips + [500_000]             # (a state after it, so the tick exists)
    events = _events(trips, period)
    start = int(events['publish_time'][0])
    end = int(events['publish_time'][-2]) + 1  # the window holds the first ten states
    stats = bench_support.loop_statistics(events, start, end, period)
    assert stats['states_published'] == 10
    assert stats['all_five_latency']['median_ms'] == pytest.approx(0.5)
    assert stats['all_five_latency']['max_ms'] == pytest.approx(3.0)
    assert stats['missed_periods'] == 1
    assert stats['missed_fraction'] == pytest.approx(0.1)
    assert stats['sim_seconds'] == pytest.approx(9 * period / 1e9)


def test_loop_statistics_of_an_empty_window():
    events = _events([500_000] * 3)
    stats = bench_support.loop_statistics(events, 0, 1, 2_000_000)
    assert stats['states_published'] == 0
    assert 'all_five_latency' not in stats


def test_write_json_writes_nan_as_null_and_numpy_scalars_as_numbers(tmp_path):
    path = tmp_path / 'a' / 'b.json'
    bench_support.write_json(path, {'x': math.nan, 'y': np.float64(1.5), 'z': [np.int64(2)],
                                    'w': (math.inf,)})
    assert json.loads(path.read_text()) == {'x': None, 'y': 1.5, 'z': [2], 'w': [None]}


def test_table_aligns_columns_and_says_whether_a_target_is_met():
    rows = [{'figure': 'a figure', 'value': '1.00', 'target': '<= 2', 'met': True},
            {'figure': 'another', 'value': '3.00 ms', 'target': '<= 2', 'met': False},
            {'figure': 'no target', 'value': 'x', 'target': '', 'met': None}]
    lines = run_benchmarks.format_table(rows).splitlines()
    assert lines[0].split() == ['figure', 'value', 'target', 'met']
    assert set(lines[1]) == {'-', ' '}
    assert lines[2].rstrip().endswith('yes') and lines[3].rstrip().endswith('NO')
    assert lines[4].rstrip().endswith('x')
    # every column starts at the same place on every line
    start = lines[0].index('value')
    assert all(line[start - 2:start] == '  ' for line in lines[2:])


def _window(p99_ms, missed, rtf=None, cpu=0.5):
    loop = {'all_five_latency': {'median_ms': 1.0, 'p99_ms': p99_ms, 'max_ms': 9.0},
            'missed_periods': missed, 'missed_fraction': missed / 100, 'states_published': 100,
            'real_time_factor': rtf}
    return {'per_walker': [{'loop': loop, 'cpu_fraction': cpu, 'peak_rss_bytes': 2**20,
                            'cpu_seconds_per_sim_second': cpu}],
            'usage': {'cpu_fraction_total': cpu}, 'errors': []}


def test_figures_judge_the_targets():
    results = {'control_loop': {'500.0': _window(1.5, 0), '1000.0': _window(1.5, 3)},
               'scaling': {'sim_time_walking': {'1': _window(3.0, 0, 1.0, 1.0),
                                                '2': _window(3.0, 0, 0.5, 2.0)},
                           'real_time_holding': {},
                           'growth': {'1': {'real_time_factor_per_walker': 1.0,
                                            'cpu_seconds_per_sim_second_per_walker': 1.0,
                                            'relative_to_one_walker': 1.0},
                                      '2': {'real_time_factor_per_walker': 0.5,
                                            'cpu_seconds_per_sim_second_per_walker': 2.0,
                                            'relative_to_one_walker': 2.0}}}}
    rows = run_benchmarks.figures(results)
    met = {row['figure']: row['met'] for row in rows}
    assert met['control loop 500 Hz, 8 processes, real time, holding: round trip median / '
               'p99 / max'] is True
    assert met['control loop 1000 Hz, 8 processes, real time, holding: round trip median / '
               'p99 / max'] is False  # 1.5 ms > 1 ms
    assert met['control loop 1000 Hz: missed periods; CPU of the graph'] is False
    scaling = [r for r in rows if r['figure'].startswith(('1 walker', '2 walker'))]
    assert [r['met'] for r in scaling] == [True, False]


def test_scaling_rows_of_grouped_controllers_are_labelled_and_judged():
    growth = {'1': {'real_time_factor_per_walker': 1.3, 'relative_to_one_walker': 1.0,
                    'cpu_seconds_per_sim_second_per_walker': 1.0},
              '2': {'real_time_factor_per_walker': 0.6, 'relative_to_one_walker': 1.1,
                    'cpu_seconds_per_sim_second_per_walker': 1.1}}
    grouped = {'sim_time_walking': {'1': _window(2.0, 0, 1.3), '2': _window(9.0, 0, 0.6)},
               'real_time_holding': {'1': _window(1.0, 0), '2': _window(2.5, 3)},
               'growth': growth}
    results = {'scaling': {'sim_time_walking': {'1': _window(3.0, 0, 1.0, 1.0)},
                           'real_time_holding': {}, 'growth': {'1': growth['1']},
                           'grouped': grouped}}
    met = {row['figure']: row['met'] for row in run_benchmarks.figures(results)}
    sim = ('{} walker(s), controllers grouped, sim time walking: per walker real-time '
           'factor; round trip p99; CPU per simulated second (x one walker)')
    real = '{} walker(s), controllers grouped, real time 500 Hz holding: round trip p99; ' \
        'missed periods'
    assert met[sim.format(1)] is True and met[sim.format(2)] is True
    assert met[real.format(1)] is True and met[real.format(2)] is False  # 2.5 ms > 2 ms
    assert sum('walker(s)' in figure for figure in met) == 5  # one walker as processes


def test_composition_rows_cover_each_arrangement_measured():
    windows = {kind: _window(1.0, 0, 1.2) for kind in ('processes', 'grouped', 'composed')}
    results = {'composition': {'real_time_500hz': windows, 'real_time_1000hz': windows,
                               'sim_time_walking': windows}}
    figures = [row['figure'] for row in run_benchmarks.figures(results)]
    for kind in ('processes', 'grouped', 'composed'):
        assert f'{kind}: real time 1000 Hz round trip median / p99 / max; missed' in figures
        assert f'{kind}: sim time walking: real-time factor; round trip median / p99' in figures
    # results of a run before the grouped arrangement and 1 kHz: their rows, no others
    older = {'composition': {'real_time_500hz': {k: windows[k] for k in ('processes',
                                                                         'composed')},
                             'sim_time_walking': {k: windows[k] for k in ('processes',
                                                                          'composed')}}}
    figures = [row['figure'] for row in run_benchmarks.figures(older)]
    assert len(figures) == 8 and not any('grouped' in f or '1000 Hz' in f for f in figures)


def test_summary_json_schema(tmp_path):
    rows = [{'figure': 'f', 'value': 'v', 'target': 't', 'met': False}]
    machine = {'cpus': 2, 'load_average_1_5_15': [1.0, 1.0, 1.0],
               'load_average_after_1_5_15': [1.0, 1.0, 1.0]}
    summary = run_benchmarks.summary_document(machine, False, {'plant': {'ok': True}}, rows)
    assert set(summary) >= {'suite', 'machine', 'note', 'quick', 'executor', 'parts', 'figures',
                            'targets'}
    assert set(summary['targets']) == {'step_time_bound_ratio', 'tip_error_m', 'p99_round_trip',
                                       'sim_time_real_time_factor', 'per_walker_cost'}
    for row in summary['figures']:
        assert set(row) == {'figure', 'value', 'target', 'met'}
        assert row['met'] in (True, False, None)
    path = tmp_path / 'summary.json'
    bench_support.write_json(path, summary)
    assert json.loads(path.read_text()) == summary


def test_the_committed_summary_follows_the_schema():
    path = REPO_ROOT / 'benchmarks' / 'results' / 'summary.json'
    if not path.exists():
        pytest.skip('no benchmarks/results/summary.json yet')
    summary = json.loads(path.read_text())
    assert summary['figures'] and all(set(r) == {'figure', 'value', 'target', 'met'}
                                      for r in summary['figures'])
    assert summary['machine']['load_average_1_5_15']


@pytest.mark.parametrize('argv, parts', [
    ([], list(run_benchmarks.PARTS)),
    (['--only', 'walk', 'plant'], ['walk', 'plant']),
    (['--soak', '3'], ['soak']),
    (['--soak'], ['soak']),
])
def test_arguments_select_the_parts(argv, parts):
    assert run_benchmarks._arguments(argv).parts == parts


def test_a_soak_of_no_time_is_refused(capsys):
    with pytest.raises(SystemExit):
        run_benchmarks._arguments(['--soak', '0'])
    assert 'positive number of minutes' in capsys.readouterr().err


class _FakeClient:
    """Answers walk goals from a list; resume always succeeds (between steps)."""

    def __init__(self, outcomes):
        from types import SimpleNamespace

        self._outcomes = [SimpleNamespace(success=s, message=m) for s, m in outcomes]
        self._answer = SimpleNamespace(success=True, message='resumed: ready for a step')
        self.reports, self.phase, self.resumes = [], None, 0

    def walk_to(self, target, timeout, feedback, should_stop):
        return 4, self._outcomes.pop(0)

    def call_trigger(self, which, timeout=5.0):
        self.resumes += 1
        return self._answer

    def spin_for(self, seconds):
        pass


def test_a_walk_held_by_a_watchdog_is_resumed_and_the_hold_reported():
    import graph_runner

    client = _FakeClient([(False, 'fault: plant joint states: silent for 1.2 s'), (True, '')])
    result, holds = graph_runner.walk_resuming(client, 'n3_1', 10.0)
    assert result.success and client.resumes == 1
    assert holds == ['fault: plant joint states: silent for 1.2 s']


def test_a_walk_that_keeps_failing_or_fails_otherwise_is_not_resumed_forever():
    import graph_runner

    held = [(False, 'the walker is in safe hold (fault: x): call resume first')] * 5
    client = _FakeClient(held)
    result, holds = graph_runner.walk_resuming(client, 'n3_1', 10.0, resumes=2)
    assert not result.success and len(holds) == 2 and client.resumes == 2
    client = _FakeClient([(False, 'no route to n9_9')])
    result, holds = graph_runner.walk_resuming(client, 'n9_9', 10.0)
    assert not result.success and holds == [] and client.resumes == 0


def test_parts_not_run_now_come_from_the_last_run_of_the_same_kind(tmp_path):
    machine = {'date': '2026-11-21T06:00:00+00:00', 'commit': 'abc1234',
               'load_average_1_5_15': [2.0, 2.0, 2.0]}
    bench_support.write_json(tmp_path / 'plant.json', {'machine': machine, 'quick': False,
                                                       'load_average_after_part': [3.0, 2, 2],
                                                       'plant': {'x': 1}})
    bench_support.write_json(tmp_path / 'walk.json', {'machine': machine, 'quick': True,
                                                      'walk': {'x': 2}})
    (tmp_path / 'scaling.json').write_text('{not json')
    found = run_benchmarks.earlier_results(tmp_path, ['plant', 'walk', 'scaling', 'soak'],
                                           quick=False)
    assert list(found) == ['plant']
    result, status = found['plant']
    assert result == {'x': 1}
    assert status['ok'] and status['earlier_run'] == machine['date']
    assert status['load_average_after'] == [3.0, 2, 2]


def _files(*counts):
    return [{'open_files': {'/walker/recorder': n, '/walker/plant': 18}} for n in counts]


@pytest.mark.parametrize('counts, change', [
    ((19, 19, 19, 19, 19, 19, 19, 20), 0),  # open for a moment at the last sample: no leak
    ((19, 20, 19, 19, 19, 19, 19, 19), 0),  # ... or after the first leg
    ((19, 19, 19, 19, 20, 20, 21, 20), 1),  # one more file held for good: a leak
    ((19, 19, 19, 19, 19, 18, 18, 18), -1),
])
def test_the_soak_counts_only_open_files_held_for_good(counts, change):
    changes = run_benchmarks.lasting_open_files_change(_files(*counts))
    assert changes == {'/walker/recorder': change, '/walker/plant': 0}


def _soak(ratios, tips_mm, **row):
    steps = [dict({'from': 'n1_1', 'to': 'n2_2', 'success': True, 'duration_s': 2.73 * r,
                   'bound_s': 2.73, 'bound_ratio': r, 'insertion_error_m': 1e-3 * tip},
                  **row) for r, tip in zip(ratios, tips_mm, strict=True)]
    return {'soak': {'minutes_walked': 1.0, 'steps': len(steps), 'failed_steps': 0,
                     'safe_holds': 0, 'rss_growth_after_first_leg_bytes': {'/walker/plant': 0},
                     'open_files_change_after_first_leg': {'/walker/plant': 0},
                     'drift': {'duration_s': None}, 'step_rows': steps}}


def test_the_soak_reports_each_steps_ratio_to_its_own_bound_and_the_share_within_targets():
    ratios = [1.40] * 8 + [1.48, 1.52]
    tips = [0.3] * 9 + [0.6]
    rows = {r['figure']: r for r in run_benchmarks.figures(_soak(ratios, tips))}
    ratio = rows['soak: step time / time-optimal bound (median, p90, max; steps at most 1.5)']
    assert ratio['value'] == '1.40, 1.48, 1.52; 90 %' and ratio['met'] is False
    tip = rows['soak: tip error at insertion (mean, max; steps under 0.5 mm)']
    assert tip['value'] == '0.33, 0.60 mm; 90 %' and tip['met'] is False
    within = {r['figure']: r['met'] for r in run_benchmarks.figures(_soak([1.2] * 3, [0.4] * 3))}
    assert within['soak: step time / time-optimal bound (median, p90, max; steps at most 1.5)']
    assert within['soak: tip error at insertion (mean, max; steps under 0.5 mm)']


def test_a_soak_without_bounds_in_its_rows_has_no_step_time_figure():
    """Rows of a soak written before the bounds were kept, or failed steps, give no ratio."""
    old = _soak([1.4], [0.3])
    del old['soak']['step_rows'][0]['bound_ratio']
    assert not any('time-optimal bound' in r['figure'] for r in run_benchmarks.figures(old))
    failed = _soak([1.4], [0.3], success=False)
    assert not any('soak: tip error' in r['figure'] for r in run_benchmarks.figures(failed))
