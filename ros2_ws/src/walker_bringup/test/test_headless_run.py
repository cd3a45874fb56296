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


def test_a_parameter_given_on_the_command_line_reaches_every_node_and_the_headless_walk(
        tmp_path, capsys):
    from walker_bringup.run import session_options

    args = parse_arguments(['-p', 'gripper.camera.enabled:=true',
                            '--param', 'sim.imperfections.node_placement:=0.001'])
    assert session_options(args).overrides == (('gripper.camera.enabled', 'true'),
                                               ('sim.imperfections.node_placement', '0.001'))
    code = main(['--headless', '--target', 'n1_2', '--out', str(tmp_path), '--no-record',
                 '--quiet', '-p', 'gripper.camera.enabled:=true'])
    assert code == 0, capsys.readouterr().out
    summary = json.loads((tmp_path / 'summary.json').read_text())
    assert summary['looks'] and all(look['node'] == 'n1_2' for look in summary['looks'])


@pytest.mark.parametrize('given, words', [
    ('gripper.camera.enabled=true', 'expected NAME:=VALUE'),
    ('gripper.camera.enabled:=[1,', 'is not YAML'),
])
def test_a_malformed_parameter_is_refused_by_the_command_line(given, words, capsys):
    with pytest.raises(SystemExit):
        parse_arguments(['-p', given])
    assert words in capsys.readouterr().err


@pytest.mark.parametrize('given, words', [
    ('gripper.camera.enable:=true', 'gripper.camera.enable'),
    ('gripper.camera.width:=-4', 'gripper.camera.width'),
])
def test_a_parameter_the_files_rules_refuse_starts_nothing(given, words, tmp_path, capsys):
    code = main(['--headless', '--out', str(tmp_path / 'run'), '--quiet', '-p', given])
    assert code == 2 and words in capsys.readouterr().out
    assert not (tmp_path / 'run').exists()
