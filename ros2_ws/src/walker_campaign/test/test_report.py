"""The campaign report from a results file: numbers, figures, Markdown."""

import json

import pytest

from campaign_samples import stand_in_walk
from walker_campaign.core.analysis import analyse
from walker_campaign.core.plan import plan_run
from walker_campaign.core.report import make_campaign_report
from walker_campaign.core.results import ResultsWriter, read_results
from walker_campaign.execution import RunTask, execute_run


@pytest.fixture
def results_path(small_spec, tmp_path):
    """Every run of the small spec, walked by the stand-in (offsets make some jam)."""
    path = tmp_path / 'results.jsonl'
    with ResultsWriter(path, small_spec) as writer:
        for index in range(small_spec.total_runs):
            writer.append(execute_run(RunTask(small_spec.name, plan_run(small_spec, index),
                                              small_spec.target, 60.0, stand_in_walk),
                                      small_spec.document))
    return path


def test_the_analysis_counts_what_the_rows_say(results_path):
    results = read_results(results_path)
    analysis = analyse(results)
    runs = results.run_rows
    reached = sum(r['reached'] for r in runs)
    assert analysis.rate.successes == reached and analysis.rate.trials == len(runs) == 12
    assert analysis.rate.low <= reached / 12 <= analysis.rate.high
    assert len(analysis.points) == 4
    assert sum(p.rate.trials for p in analysis.points) == 12
    assert len(analysis.step_ratios) == len(results.step_rows)
    failed = [r for r in runs if r['outcome'] == 'failed']
    assert sum(c.count for c in analysis.safe_holds) == len(failed)
    assert analysis.jams['jammed screw-ins'] == sum(r['jams'] for r in runs)
    assert any(p.pareto for p in analysis.points)
    parameters = {s.parameter for s in analysis.sensitivities}
    assert 'friction' in parameters
    assert analysis.walks == []  # one walk per run: nothing to set side by side


def test_the_report_counts_the_grip_losses_of_the_runs_that_monitored_them(results_path,
                                                                           tmp_path):
    """Runs whose rows carry the grip monitor are summed in the jams table.

    Older rows without it (``grip_losses`` None) leave the table as it was.
    """
    rows = [json.loads(line) for line in results_path.read_text().splitlines()]
    runs = [r for r in rows if r.get('kind') == 'run']
    assert 'runs with the grip monitor' not in analyse(read_results(results_path)).jams
    runs[0]['grip_losses'], runs[0]['grip_states'] = 3, 100
    runs[1]['grip_losses'], runs[1]['grip_states'] = 0, 90
    path = tmp_path / 'results.jsonl'
    path.write_text(''.join(json.dumps(r) + '\n' for r in rows))
    jams = analyse(read_results(path)).jams
    assert jams['grip losses (gripper states with no gripper attached)'] == 3
    assert jams['runs with a grip loss'] == 1 and jams['runs with the grip monitor'] == 2
    text = make_campaign_report(path, tmp_path / 'report', tolerance=0.002).markdown.read_text()
    assert '| runs with a grip loss | 1 |' in text


def test_the_stand_in_figures_follow_their_parameters(results_path):
    """The stand-in's coarse phase grows with friction: the sensitivity must say so."""
    analysis = analyse(read_results(results_path))
    rho = {(s.parameter, s.figure): s.rho for s in analysis.sensitivities}
    assert rho[('friction', 'bound_ratio')] > 0.9


def test_the_report_is_written(results_path, tmp_path):
    report = make_campaign_report(results_path, tmp_path / 'report', tolerance=0.002)
    for name in ('outcomes', 'distributions', 'sensitivity', 'grid', 'pareto'):
        assert report.figures[name].is_file() and report.figures[name].stat().st_size > 5000
    text = report.markdown.read_text()
    rate = report.analysis.rate
    assert f'({rate.successes} of {rate.trials})' in text
    assert '95 % Wilson interval' in text
    for name in ('outcomes.png', 'distributions.png', 'sensitivity.png', 'grid.png',
                 'pareto.png'):
        assert f']({name})' in text
    data = json.loads(report.json.read_text())
    assert data['success']['walks'] == 12
    assert data['success']['wilson_low'] == pytest.approx(rate.low)
    assert len(data['points']) == 4


def test_a_campaign_without_sweeps_or_results_still_reports(write_spec, tmp_path):
    spec = write_spec({'seed': 1, 'runs': 2, 'route': {'target': 'n4_3'}})
    path = tmp_path / 'results.jsonl'
    ResultsWriter(path, spec).close()
    report = make_campaign_report(path, tmp_path / 'report')
    assert set(report.figures) == {'outcomes', 'distributions'}
    assert '0 of 0' in report.markdown.read_text()


def test_the_report_shows_the_vision_error_of_the_runs_that_looked(results_path, tmp_path):
    rows = [json.loads(line) for line in results_path.read_text().splitlines()]
    runs = [r for r in rows if r.get('kind') == 'run']
    assert 'vision_error' not in analyse(read_results(results_path)).step_quantiles
    runs[0].update(looks=5, looks_unseen=1, vision_errors=[1e-4, 3e-4])
    runs[1].update(looks=2, looks_unseen=0, vision_errors=[2e-4])
    path = tmp_path / 'results.jsonl'
    path.write_text(''.join(json.dumps(r) + '\n' for r in rows))
    analysis = analyse(read_results(path))
    assert analysis.step_quantiles['vision_error'][0.5] == pytest.approx(2e-4)
    assert analysis.jams['looks through the wrist camera'] == 7
    assert analysis.jams['looks that did not see the hole'] == 1
    text = make_campaign_report(path, tmp_path / 'report', tolerance=0.002).markdown.read_text()
    assert '| vision error [mm] | 0.2 |' in text.replace('0.20', '0.2')
