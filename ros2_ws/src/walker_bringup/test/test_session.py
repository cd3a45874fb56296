"""The walk session: the one way to run a walk, here with its headless backend.

The graph backend is what ``run_all.py`` runs (its tests and the integration tests start
graphs); these show the API a script uses, and that the example in docs/architecture.md runs
as printed.
"""

import json
import re
from pathlib import Path

import pytest

from walker_bringup.session import (
    Arrangement, SessionError, SessionOptions, WalkSession, WalkSummary)
from walker_config.core.configuration import load_configuration

ARCHITECTURE = Path(__file__).resolve().parents[4] / 'docs' / 'architecture.md'


def test_a_headless_session_walks_and_returns_what_summary_json_holds(tmp_path, capsys):
    options = SessionOptions(arrangement=Arrangement.HEADLESS, out=tmp_path, record=False,
                             quiet=True)
    with WalkSession(load_configuration(), options) as session:
        summary = session.walk('n1_2')
    assert isinstance(summary, WalkSummary) and summary.code == 0
    assert summary.reached and summary.path == ('n1_2',) and summary.runner == 'headless'
    written = json.loads((tmp_path / 'summary.json').read_text())
    assert written['reached'] is summary.reached and written['path'] == list(summary.path)
    assert [s['to_node'] for s in written['steps']] == [row.to_node for row in summary.rows]
    assert '[walker] reached n1_2 in 1 steps' in capsys.readouterr().out


def test_a_step_is_one_step_to_a_neighbouring_node(tmp_path):
    options = SessionOptions(arrangement=Arrangement.HEADLESS, out=tmp_path, record=False,
                             quiet=True)
    with WalkSession(load_configuration(), options) as session:
        summary = session.step('n1_2')
    assert summary.reached and summary.steps_taken == 1


@pytest.mark.parametrize('changes, named', [
    ({'walkers': 2}, 'walkers'), ({'foxglove_port': 8765}, 'foxglove_port'),
    ({'realtime': 50}, 'realtime')])
def test_the_graphs_own_options_are_refused_for_the_headless_runner(changes, named):
    with pytest.raises(SessionError, match=f'runs no graph: leave {named} out') as error:
        SessionOptions(arrangement=Arrangement.HEADLESS, **changes)
    assert error.value.code == 2


def test_the_headless_runner_has_no_walker_to_hold_between_walks(tmp_path):
    session = WalkSession(load_configuration(),
                          SessionOptions(arrangement='headless', out=tmp_path, quiet=True))
    with pytest.raises(SessionError, match='hold: a headless walk runs to its end'):
        session.hold()
    with pytest.raises(SessionError, match='no graph to serve'):
        session.serve()


def test_the_graph_arrangements_group_the_controllers_as_run_all_does():
    assert not SessionOptions().grouped_controllers
    assert SessionOptions(arrangement=Arrangement.GROUPED).grouped_controllers
    assert SessionOptions(arrangement=Arrangement.COMPOSED_LOOP).grouped_controllers
    assert not SessionOptions(arrangement=Arrangement.COMPOSED).grouped_controllers
    assert SessionOptions(arrangement=Arrangement.COMPOSED, sim_time=True).grouped_controllers


def test_the_example_of_the_architecture_page_runs_as_printed(tmp_path, monkeypatch, capsys):
    text = ARCHITECTURE.read_text()
    section = text[text.index('## Running a walk'):text.index('## The headless runner')]
    example = re.search(r'```python\n(.*?)```', section, re.S).group(1)
    assert len(example.strip().splitlines()) <= 10
    monkeypatch.chdir(tmp_path)
    example = example.replace("'n4_3'", "'n1_2'")  # one step, and no bag nor report to make
    example = example.replace("out='runs/notebook'", "out='runs/notebook', record=False")
    assert 'record=False' in example
    exec(compile(example, 'architecture.md', 'exec'), {})
    printed = capsys.readouterr().out
    assert 'True 1 ' in printed and 'n2_1 -> n1_2' in printed
    assert (tmp_path / 'runs' / 'notebook' / 'summary.json').is_file()


class _Group:
    """Records what a launch starts, and with which command."""

    def __init__(self):
        self.started = []

    def start(self, spec, command=None):
        self.started.append((spec.name, command))


@pytest.mark.parametrize('arrangement, wrapped', [
    (Arrangement.PROCESSES, 'plant'), (Arrangement.COMPOSED_LOOP, 'loop'),
    (Arrangement.COMPOSED, 'graph')])
def test_a_wrapper_replaces_the_command_of_the_processes_it_names(tmp_path, arrangement,
                                                                   wrapped):
    from walker_bringup.graph_walkers import describe_walkers, launch

    configuration = load_configuration()
    options = SessionOptions(arrangement=arrangement, sim_time=True, out=tmp_path,
                             overrides=(('timing.control_rate', '250.0'),))
    walker = describe_walkers(options, configuration, tmp_path,
                              {'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST'})[0]
    walker.group = _Group()
    launch(walker, options, configuration.path,
           lambda spec, command: ['probe', spec.name] if spec.name == wrapped else command)
    assert (wrapped, ['probe', wrapped]) in walker.group.started
    assert all(command is None or command == ['probe', wrapped] or name == 'loop'
               for name, command in walker.group.started if name != wrapped)
    # the overrides reach every node, after run_all.py's own
    plant = next(n for n in walker.nodes if n.executable == 'plant_node')
    assert ('timing.control_rate', '250.0') in plant.parameters
