"""The results file: streamed, resumable, exactly read back, and never mixed up."""

import json

import pytest

from campaign_samples import SMALL_SPEC, stand_in_walk
from walker_campaign.core.errors import ResultsError
from walker_campaign.core.plan import plan_run
from walker_campaign.core.results import ResultsWriter, read_results
from walker_campaign.execution import RunTask, execute_run


def rows_of(spec, index):
    return execute_run(RunTask(spec.name, plan_run(spec, index), spec.target, 60.0,
                               stand_in_walk), spec.document)


def test_runs_written_are_read_back_exactly(small_spec, tmp_path):
    path = tmp_path / 'results.jsonl'
    written = {i: rows_of(small_spec, i) for i in (0, 3, 5)}
    with ResultsWriter(path, small_spec) as writer:
        assert writer.finished == set()
        for rows in written.values():
            writer.append(rows)
    results = read_results(path)
    assert results.header['digest'] == small_spec.digest
    assert results.header['sweeps'][0]['key'] == 'control.coarse.acceleration_feedback[0]'
    assert sorted(results.runs) == [0, 3, 5]
    for index, rows in written.items():
        assert results.steps[index] + [results.runs[index]] == rows
    assert json.loads(path.read_text().splitlines()[0])['kind'] == 'campaign'


def test_a_resume_skips_finished_runs_and_cuts_a_torn_write(small_spec, tmp_path):
    path = tmp_path / 'results.jsonl'
    with ResultsWriter(path, small_spec) as writer:
        writer.append(rows_of(small_spec, 0))
    torn = json.dumps(rows_of(small_spec, 1)[0])
    with open(path, 'a') as handle:
        handle.write(json.dumps(rows_of(small_spec, 2)[0]) + '\n')  # a step row, no run row
        handle.write(torn[:40])  # the write a crash interrupted
    with ResultsWriter(path, small_spec) as writer:
        assert writer.finished == {0}
        writer.append(rows_of(small_spec, 1))
    results = read_results(path)
    assert sorted(results.runs) == [0, 1]
    assert 2 not in results.steps
    assert all(line.startswith('{') and line.endswith('}')
               for line in path.read_text().splitlines())


def test_a_results_file_of_another_campaign_is_refused(small_spec, write_spec, tmp_path):
    path = tmp_path / 'results.jsonl'
    ResultsWriter(path, small_spec).close()
    other = write_spec({'seed': 99, 'runs': 1, 'route': {'target': 'n4_3'}}, name='other')
    with pytest.raises(ResultsError, match='with other parameters'):
        ResultsWriter(path, other)


def test_more_runs_resume_the_same_file_under_a_new_header(small_spec, write_spec, tmp_path):
    path = tmp_path / 'results.jsonl'
    with ResultsWriter(path, small_spec) as writer:
        writer.append(rows_of(small_spec, 0))
    longer = write_spec({**SMALL_SPEC, 'runs': 5})
    with ResultsWriter(path, longer) as writer:
        assert writer.finished == {0}
    assert read_results(path).header['total_runs'] == 20


def test_one_writer_at_a_time(small_spec, tmp_path):
    path = tmp_path / 'results.jsonl'
    with ResultsWriter(path, small_spec), pytest.raises(ResultsError, match='being written'):
        ResultsWriter(path, small_spec)


def test_a_file_that_is_not_a_campaign_is_refused(tmp_path):
    (tmp_path / 'x.jsonl').write_text('{"kind": "step", "index": 0}\n')
    with pytest.raises(ResultsError, match='no campaign header'):
        read_results(tmp_path / 'x.jsonl')
    with pytest.raises(ResultsError, match='no results file'):
        read_results(tmp_path / 'missing.jsonl')
