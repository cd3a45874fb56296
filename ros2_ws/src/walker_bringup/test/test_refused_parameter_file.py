"""run_all.py refuses a bad parameter file before it starts or writes anything, graph or not."""

import pytest
from ros_test_support import write_parameter_file

from walker_bringup.run import main as run_all
from walker_core.parameter_file import default_values


@pytest.mark.parametrize('runner', [['--sim-time'], ['--headless']])
def test_run_all_refuses_a_bad_file_before_it_starts_or_writes_anything(tmp_path, capsys,
                                                                        runner):
    flat = dict(default_values())
    flat['sim.start.other_node'] = 'n9_9'
    path = write_parameter_file(tmp_path / 'walker.yaml', flat)
    out = tmp_path / 'run'
    assert run_all(['--params-file', str(path), '--out', str(out), *runner]) == 2
    said = capsys.readouterr()
    assert 'sim.start.other_node' in said.err + said.out
    if runner == ['--sim-time']:
        assert str(path) in said.err + said.out
    assert not out.exists()
