"""A campaign's truss survey: read and checked once, given to every walk; a route walked twice."""

import json

import pytest
import yaml

from campaign_samples import (
    SMALL_SPEC, stand_in_walk, survey_content, surveying_stand_in_walk)
from walker_campaign.campaign import main
from walker_campaign.core.errors import SpecError
from walker_campaign.core.plan import plan_run
from walker_campaign.core.report import make_campaign_report
from walker_campaign.core.results import ResultsWriter
from walker_campaign.core.rows import combined_summary, run_rows
from walker_campaign.core.spec import load_spec, shipped_spec, with_truss_survey
from walker_campaign.execution import RunTask, execute_run

SURVEY = survey_content({'n1_2': [0.001, 0.3, -0.0005]})


@pytest.fixture
def survey_file(tmp_path):
    path = tmp_path / 'survey.yaml'
    path.write_text(yaml.safe_dump(SURVEY))
    return path


def task(spec, index, walk):
    return RunTask(spec.name, plan_run(spec, index), spec.target, spec.walk_timeout, walk,
                   None, spec.truss_survey, spec.walks)


def test_a_specs_survey_is_read_relative_to_it_and_decides_the_digest(write_spec, survey_file):
    plain = write_spec(SMALL_SPEC)
    spec = write_spec({**SMALL_SPEC, 'truss_survey': survey_file.name})
    assert spec.truss_survey == SURVEY and spec.truss_survey_file == survey_file
    assert plain.truss_survey is None
    # a results file of walks from the nominal truss is not resumed with a survey
    assert spec.digest != plain.digest


@pytest.mark.parametrize('content, fault', [
    (None, 'No such file'),
    ('- a list\n', 'not a mapping'),
    ('nodes: {}\n', 'format'),
    (yaml.safe_dump(survey_content({'n9_9': [0.0, 0.0, 0.0]})), 'n9_9'),
    (yaml.safe_dump(survey_content({'n1_2': [0.0, 0.3]})), 'position must be 3 finite'),
])
def test_a_missing_or_malformed_survey_is_refused_naming_the_field_and_the_file(
        write_spec, tmp_path, content, fault):
    path = tmp_path / 'survey.yaml'
    if content is not None:
        path.write_text(content)
    with pytest.raises(SpecError, match='truss_survey') as raised:
        write_spec({**SMALL_SPEC, 'truss_survey': str(path)})
    assert str(path) in str(raised.value) and fault in str(raised.value)


def test_the_option_takes_the_place_of_the_specs_survey(write_spec, survey_file, tmp_path):
    spec = write_spec(SMALL_SPEC)
    with pytest.raises(SpecError, match='--truss-survey'):
        with_truss_survey(spec, tmp_path / 'missing.yaml')
    assert with_truss_survey(spec, survey_file).truss_survey == SURVEY


def test_a_bad_survey_on_the_command_line_runs_nothing(write_spec, tmp_path, capsys):
    spec_path = write_spec(SMALL_SPEC, load=False)
    out = tmp_path / 'out'
    code = main([str(spec_path), '--truss-survey', str(tmp_path / 'missing.yaml'),
                 '--out', str(out), '--quiet', '--walk', 'campaign_samples:stand_in_walk'])
    assert code == 2 and 'missing.yaml' in capsys.readouterr().out
    assert not out.exists(), 'nothing is run or written'


def test_the_graph_takes_a_survey_and_a_route_walked_twice(write_spec, survey_file, tmp_path):
    spec_path = write_spec({**SMALL_SPEC, 'truss_survey': str(survey_file),
                            'route': {**SMALL_SPEC['route'], 'walks': 2}}, load=False)
    assert main([str(spec_path), '--graph', '--check', '--out', str(tmp_path / 'out'),
                 '--quiet']) == 0


def test_every_walk_of_the_campaign_starts_from_the_survey(write_spec, survey_file):
    spec = write_spec({**SMALL_SPEC, 'truss_survey': str(survey_file)})
    seen = []

    def walk(request):
        seen.append(yaml.safe_load(request.truss_survey.read_text()))
        return stand_in_walk(request)

    for index in (0, 7):
        execute_run(task(spec, index, walk), spec.document)
    assert seen == [SURVEY, SURVEY]


def test_the_second_walk_starts_from_the_survey_the_first_wrote(write_spec):
    spec = write_spec({**SMALL_SPEC, 'route': {'target': 'n1_2', 'walks': 2}})
    requests = []

    def walk(request):
        requests.append(request)
        return surveying_stand_in_walk(request)

    *steps, run = execute_run(task(spec, 3, walk), spec.document)
    first, second = requests
    assert first.truss_survey is None
    assert second.truss_survey == first.out_dir / 'truss_survey.yaml'
    assert first.out_dir != second.out_dir
    # the rows report both walks: the first searched, the second found the surveyed node
    assert {s['walk'] for s in steps} == {1, 2}
    assert run['walk1.probes'] == sum(s['probes'] for s in steps if s['walk'] == 1) > 0
    assert run['walk2.probes'] == 0
    for number in (1, 2):
        walked = [s for s in steps if s['walk'] == number]
        assert run[f'walk{number}.steps'] == len(walked)
        assert run[f'walk{number}.walk_time'] == pytest.approx(sum(s['duration']
                                                                   for s in walked))
        assert run[f'walk{number}.bound_ratio'] == pytest.approx(
            run[f'walk{number}.walk_time'] / sum(s['bound'] for s in walked))
    assert run['steps'] == len(steps)


def test_a_first_walk_without_a_survey_makes_the_run_an_error(write_spec):
    spec = write_spec({**SMALL_SPEC, 'route': {'target': 'n1_2', 'walks': 2}})
    calls = []

    def walk(request):
        calls.append(request)
        return stand_in_walk(request)  # writes no survey

    rows = execute_run(task(spec, 0, walk), spec.document)
    assert len(calls) == 1, 'the second walk is not walked from the nominal truss instead'
    assert rows[-1]['outcome'] == 'error' and 'no truss survey' in rows[-1]['message']


@pytest.mark.parametrize('walks', [0, 11, 1.5, True])
def test_a_route_walked_a_wrong_number_of_times_is_refused(write_spec, walks):
    with pytest.raises(SpecError, match='route.walks'):
        write_spec({**SMALL_SPEC, 'route': {'target': 'n1_2', 'walks': walks}})


def test_walks_reach_together_and_a_failed_walk_gives_the_message():
    ok = {'steps': [{'index': 0}], 'reached': True, 'message': 'reached'}
    held = {'steps': [{'index': 0}, {'index': 1}], 'reached': False,
            'message': 'safe hold: jammed'}
    both = combined_summary([ok, ok])
    assert both['reached'] and [s['walk'] for s in both['steps']] == [1, 2]
    second_held = combined_summary([ok, held])
    assert not second_held['reached'] and second_held['message'] == 'safe hold: jammed'
    assert [w['reached'] for w in second_held['walks']] == [True, False]
    with pytest.raises(ValueError):
        combined_summary([])


def test_one_walk_keeps_its_rows_as_they_were(small_spec):
    summary = {'steps': [{'index': 0, 'success': True, 'duration': 4.0, 'bound': 3.0}],
               'reached': True, 'message': 'reached'}
    *steps, run = run_rows('c', plan_run(small_spec, 0), summary)
    assert 'walk' not in steps[0] and not any(k.startswith('walk1.') for k in run)


def test_the_shipped_twice_campaign_walks_each_truss_twice(tmp_path):
    spec = load_spec(shipped_spec('truss_twice'))
    assert spec.walks == 2 and spec.target == 'n4_3'
    as_built = load_spec(shipped_spec('truss_as_built'))
    # the same truths as truss_as_built's: its first walk is truss_as_built's walk
    assert [d.name for d in spec.dispersions] == [d.name for d in as_built.dispersions]
    assert plan_run(spec, 5).truth_values == plan_run(as_built, 5).truth_values
    *steps, run = execute_run(task(spec, 0, surveying_stand_in_walk), spec.document)
    assert {s['walk'] for s in steps} == {1, 2}
    assert run['walk2.probes'] < run['walk1.probes']


def test_the_report_sets_the_walks_of_each_truss_side_by_side(write_spec, tmp_path):
    spec = write_spec({**SMALL_SPEC, 'route': {'target': 'n1_2', 'walks': 2}})
    path = tmp_path / 'results.jsonl'
    runs = []
    with ResultsWriter(path, spec) as writer:
        for index in range(spec.total_runs):
            rows = execute_run(task(spec, index, surveying_stand_in_walk), spec.document)
            writer.append(rows)
            runs.append(rows[-1])
    report = make_campaign_report(path, tmp_path / 'report')
    first, second = report.analysis.walks
    assert (first.walk, second.walk) == (1, 2)
    assert first.rate.trials == second.rate.trials == spec.total_runs
    assert first.rate.successes == sum(r['walk1.reached'] for r in runs)
    assert first.probes == sum(r['walk1.probes'] for r in runs) > 0 and second.probes == 0
    assert first.steps == sum(r['walk1.steps'] for r in runs)
    assert '## The same truss, walk after walk' in report.markdown.read_text()
    data = json.loads(report.json.read_text())
    assert [w['probes'] for w in data['walks']] == [first.probes, 0]
