"""``run_all.py --headless``: the options, the summary, the bag, the table and exit codes."""

import json

import pytest
import yaml

from walker_bringup.run import main, parse_arguments


@pytest.mark.parametrize('options, named', [
    (['--composed'], '--composed'), (['--composed-loop'], '--composed-loop'),
    (['--grouped-controllers'], '--grouped-controllers'), (['--serve'], '--serve'),
    (['--no-walk'], '--no-walk'), (['--walkers', '2'], '--walkers'),
])
def test_the_graphs_own_options_are_refused_with_headless(options, named, capsys):
    with pytest.raises(SystemExit):
        parse_arguments(['--headless', *options])
    assert f'--headless runs no graph: leave {named} out' in capsys.readouterr().err


def test_a_headless_walk_writes_the_summary_and_the_bag_and_says_it_reached(tmp_path,
                                                                           capsys):
    code = main(['--headless', '--target', 'n1_2', '--out', str(tmp_path), '--no-report',
                 '--quiet'])
    printed = capsys.readouterr().out
    assert code == 0, printed
    summary = json.loads((tmp_path / 'summary.json').read_text())
    assert summary['reached'] and summary['path'] == ['n1_2'] and summary['message'] == ''
    assert summary['runner'] == 'headless' and summary['loop']['lockstep_timeouts'] == 0
    assert [s['to_node'] for s in summary['steps']] == ['n1_2']
    assert (tmp_path / 'bag' / 'metadata.yaml').exists()
    # the grip monitor counted every gripper state the bag holds, none without a grip
    metadata = yaml.safe_load((tmp_path / 'bag' / 'metadata.yaml').read_text())
    counts = {t['topic_metadata']['name']: t['message_count']
              for t in metadata['rosbag2_bagfile_information']['topics_with_message_count']}
    assert summary['grip_monitor'] == {'states': counts['/walker/gripper_states'],
                                       'no_gripper_attached': 0}
    assert counts['/walker/gripper_states'] > 0
    assert 'n2_1 -> n1_2' in printed and '[walker] reached n1_2 in 1 steps' in printed
    assert main(['--headless', '--target', 'n1_2', '--out', str(tmp_path), '--quiet']) == 2
    assert 'already exists' in capsys.readouterr().out  # a bag is never overwritten


def test_a_target_off_the_truss_ends_unreached_with_the_reason(tmp_path, capsys):
    code = main(['--headless', '--target', 'n9_9', '--out', str(tmp_path), '--no-record',
                 '--quiet'])
    printed = capsys.readouterr().out
    assert code == 1 and 'not on the truss' in printed
    summary = json.loads((tmp_path / 'summary.json').read_text())
    assert not summary['reached'] and summary['steps'] == []


def test_a_walks_truss_survey_starts_the_next_walk_and_a_bad_one_is_refused(tmp_path, capsys):
    first, second, bad = tmp_path / 'first', tmp_path / 'second', tmp_path / 'bad.yaml'
    assert main(['--headless', '--target', 'n1_2', '--out', str(first), '--no-record',
                 '--quiet']) == 0
    survey = first / 'truss_survey.yaml'
    assert survey.exists(), 'a headless walk writes the survey of the nodes it screwed into'
    assert main(['--headless', '--target', 'n1_2', '--out', str(second), '--no-record',
                 '--quiet', '--truss-survey', str(survey)]) == 0
    assert (second / 'truss_survey.yaml').exists()
    capsys.readouterr()
    bad.write_text('- not a mapping\n')
    assert main(['--headless', '--target', 'n1_2', '--out', str(tmp_path / 'third'),
                 '--no-record', '--quiet', '--truss-survey', str(bad)]) == 2
    assert str(bad) in capsys.readouterr().out
    assert not (tmp_path / 'third').exists(), 'a refused survey writes nothing'
    # the graph refuses it as well, before anything starts
    assert main(['--target', 'n1_2', '--out', str(tmp_path / 'graph'), '--no-record',
                 '--quiet', '--truss-survey', str(bad)]) == 2
    assert str(bad) in capsys.readouterr().out
    assert not (tmp_path / 'graph').exists(), 'a refused survey starts no graph'
