"""ParameterFile: a file read once, its sections built once, each refusal naming the parameter."""

import pytest
import yaml

from walker_core.parameter_file import ParameterFile, default_parameter_file, default_values
from walker_core.parameter_schema import ParameterError, load_parameter_file
from walker_core.robot_parameters import WalkerParameters
from walker_core.settling import SETTLING_PREFIX, SettlingWindow


def _file(tmp_path, change):
    """Write the installed file with ``change(parameters)`` applied to its nested values."""
    document = yaml.safe_load(default_parameter_file().read_text())
    change(document['/**']['ros__parameters'])
    path = tmp_path / 'walker.yaml'
    path.write_text(yaml.safe_dump(document))
    return path


def test_the_installed_file_alone_gives_the_defaults():
    file = ParameterFile.read()
    assert file.path == default_parameter_file().resolve()
    assert dict(file.values) == load_parameter_file(default_parameter_file())
    assert default_values() is default_values(), 'parsed once per process'


def test_a_file_and_overrides_apply_in_that_order(tmp_path):
    path = _file(tmp_path, lambda p: (p['truss'].update(columns=3),
                                      p['supervisor'].update(settle_time=0.5)))
    file = ParameterFile.read(path, {'truss.rows': 2})
    walker = file.section(WalkerParameters)
    assert (walker.truss.columns, walker.truss.rows) == (3, 2)
    assert walker.robot == ParameterFile.read().section(WalkerParameters).robot
    assert file.section(SettlingWindow, SETTLING_PREFIX).settle_time == 0.5
    assert file.section(WalkerParameters) is walker, 'each section is built once'
    with pytest.raises(TypeError):
        file.values['truss.rows'] = 4  # read-only: every section sees the same values


def test_an_invalid_or_missing_value_is_refused_when_its_section_is_built(tmp_path):
    path = _file(tmp_path, lambda p: p['supervisor'].update(settle_time=-1.0))
    file = ParameterFile.read(path)
    file.section(WalkerParameters)  # other sections are unaffected
    with pytest.raises(ParameterError, match="'supervisor.settle_time' = -1.0: below"):
        file.section(SettlingWindow, SETTLING_PREFIX)
    path = _file(tmp_path, lambda p: p['supervisor'].pop('settle_time'))
    with pytest.raises(ParameterError, match="'supervisor.settle_time' is missing"):
        ParameterFile.read(path).section(SettlingWindow, SETTLING_PREFIX)
    with pytest.raises(ParameterError, match='cannot read parameter file'):
        ParameterFile.read(tmp_path / 'missing.yaml')
