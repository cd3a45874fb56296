"""A run's two parameter sets: the model's (every node but the plant) and the truth's (the plant).

Both start from one nominal parameter file. The *model* set is that file with the run's sweep
values (what the lab tunes); the *truth* set is the model set with the run's dispersed values
(the robot as it really is). Each is checked by the walker's own schema, section by section, as
the nodes that read it would check it, so a value the walker refuses is refused here, before
anything runs, with the parameter named.
"""

from __future__ import annotations

import copy
import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from walker_core.parameter_schema import (
    ParameterError, flatten_mapping, parameter_values, read_parameter_document)

__all__ = ['load_nominal', 'check_model', 'check_truth', 'parameter_document',
           'write_parameter_file', 'WILDCARD']

#: The section of a parameter file that every node reads.
WILDCARD = '/**'


def load_nominal(path: str | Path) -> tuple[dict[str, Any], dict[str, Any]]:
    """Read a nominal parameter file: its flat values and the YAML document itself.

    Raises
    ------
    ParameterError
        The file is missing, not YAML, or not in the ``ros__parameters`` layout; or it has
        node sections besides ``/**`` (a run's files are written from ``/**`` alone).
    """
    path = Path(path)
    document = read_parameter_document(path)  # parsed once: the values and the document
    flat = parameter_values(document)
    others = sorted(str(k) for k in document if str(k) not in (WILDCARD, '**'))
    if others:
        raise ParameterError(f'parameter file {path}: a campaign takes the /** section only, '
                             f'not node sections ({", ".join(others)})')
    return flat, document


def _model(flat: Mapping[str, Any]):
    from walker_config.core.configuration import configuration_of
    from walker_core.parameter_file import ParameterFile

    return configuration_of(ParameterFile(flat, Path('model.yaml')))


def _truth(flat: Mapping[str, Any]) -> None:
    from walker_config.core.configuration import plant_sections
    from walker_core.parameter_file import ParameterFile

    plant_sections(ParameterFile(flat, Path('truth.yaml')))


#: Each checked set's configuration, or the refusal's text.
_CHECKED: dict[tuple[str, str], Any] = {}
_CACHE_SIZE = 1024


def _check_once(check, flat: Mapping[str, Any]) -> Any:
    values = json.dumps(dict(flat), sort_keys=True, default=repr)
    key = (check.__name__, values)
    if key not in _CHECKED:
        if len(_CHECKED) >= _CACHE_SIZE:
            _CHECKED.clear()
        try:
            _CHECKED[key] = check(flat)
        except ParameterError as error:
            _CHECKED[key] = ParameterError(str(error))
    if isinstance(_CHECKED[key], ParameterError):
        raise ParameterError(str(_CHECKED[key]))
    return _CHECKED[key]


def check_model(flat: Mapping[str, Any]):
    """Check the model's set as the walker's one configuration loader checks a file.

    Every section and every rule between sections
    (:func:`walker_config.core.configuration.configuration_of`), as ``run_all.py`` checks the
    file it is given; once per distinct set (the controllers' stability check designs every
    filter of every mode over the inertia range: seconds on a loaded machine).

    Returns
    -------
    WalkerConfiguration
        The set's sections, for whoever needs one of them (the truss of a route or a survey).

    Raises
    ------
    ParameterError
        Naming the parameter and the rule (the controllers' stability check included).
    """
    return _check_once(_model, flat)


def check_truth(flat: Mapping[str, Any]) -> None:
    """Check the truth's set as the plant would (robot, truss, grippers, ``sim.*``).

    Raises
    ------
    ParameterError
        Naming the parameter and the rule.
    """
    _truth(flat)


def parameter_document(document: Mapping[str, Any], values: Mapping[str, Any]
                       ) -> dict[str, Any]:
    """Return a copy of a parameter file's document with some flat values replaced.

    Parameters
    ----------
    document : mapping
        The nominal file's YAML document (``{'/**': {'ros__parameters': {...}}}``).
    values : mapping
        ``{dotted name: value}`` to put under ``/**``; each name must already be in it.

    Raises
    ------
    ParameterError
        A name that is not in the document.
    """
    result = copy.deepcopy(dict(document))
    key = WILDCARD if WILDCARD in result else '**'
    known = flatten_mapping(result[key]['ros__parameters'])
    for name, value in values.items():
        if name not in known:
            raise ParameterError(f'parameter {name!r} is not in the nominal file')
        node = result[key]['ros__parameters']
        *parents, leaf = name.split('.')
        for part in parents:
            node = node[part]
        node[leaf] = list(value) if isinstance(value, tuple) else value
    return result


def write_parameter_file(document: Mapping[str, Any], values: Mapping[str, Any],
                         path: str | Path) -> Path:
    """Write a parameter file: ``document`` with ``values`` replaced (floats written exactly).

    PyYAML writes a float as its ``repr``, which reads back as the same float: the file
    carries the drawn value bit for bit.
    """
    path = Path(path)
    path.write_text(yaml.safe_dump(parameter_document(document, values), sort_keys=False))
    return path
