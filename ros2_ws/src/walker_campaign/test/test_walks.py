"""The walk functions: run_all.py given the model's file, the plant the truth's; a summary back.

``run_all.py`` itself is replaced by a stand-in process that checks its command line with
``run_all.py``'s own parser and writes a summary naming the files it was given, so the walk
functions' contract with it is tested in a second.
"""

import json
from pathlib import Path

import pytest

from walker_campaign import walks
from walker_campaign.walks import WalkError, WalkRequest, walk_function

#: run_all.py's stand-in: parse as run_all.py does, write summary.json, or fail as told
_STAND_IN = """
import json, sys
from pathlib import Path
from walker_bringup.run import parse_arguments
args = parse_arguments(sys.argv[1:])
if args.target == 'nowhere':
    print('the walk refused its target'); sys.exit(2)
out = Path(args.out); out.mkdir(parents=True)
(out / 'summary.json').write_text(json.dumps({
    'steps': [], 'reached': True, 'message': '', 'headless': args.headless,
    'sim_time': args.sim_time, 'model': args.params_file, 'truth': args.plant_params_file,
    'record': args.record}))
"""


@pytest.fixture
def stand_in(monkeypatch):
    monkeypatch.setattr(walks, '_RUN_ALL', _STAND_IN)


def request(tmp_path: Path, target: str = 'n1_2', record: bool = False) -> WalkRequest:
    return WalkRequest(tmp_path / 'model.yaml', tmp_path / 'truth.yaml', target,
                       tmp_path / 'run', 60.0, record)


def test_the_default_walk_is_the_headless_runner():
    from walker_campaign.campaign import DEFAULT_WALK

    assert walk_function(DEFAULT_WALK) is walks.headless_walk
    assert walk_function('graph') is walks.graph_walk


@pytest.mark.parametrize('name', ['headless', 'graph'])
def test_the_plant_gets_the_truth_and_the_rest_the_model(stand_in, tmp_path, name):
    summary = walk_function(name)(request(tmp_path))
    assert summary['reached'] and summary['timed_out'] is False
    assert summary['model'] == str(tmp_path / 'model.yaml')
    assert summary['truth'] == str(tmp_path / 'truth.yaml')
    assert summary['headless'] == (name == 'headless')
    assert summary['sim_time'] == (name == 'graph')
    assert summary['record'] is False


def test_a_recorded_walk_keeps_its_bag(stand_in, tmp_path):
    assert walks.headless_walk(request(tmp_path, record=True))['record'] is True


def test_a_walk_without_a_summary_is_an_error_with_its_output(stand_in, tmp_path):
    with pytest.raises(WalkError, match='refused its target') as error:
        walks.headless_walk(request(tmp_path, target='nowhere'))
    assert 'exit code 2' in str(error.value)


def test_an_unknown_walk_function_is_refused_by_name():
    with pytest.raises(ValueError, match='no walk function'):
        walk_function('teleport')
    assert walk_function('json:dumps') is json.dumps
