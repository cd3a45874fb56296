"""Typed, self-validating parameter sections loaded from a ROS 2 parameter YAML file.

A *section* is a frozen dataclass whose leaf fields are declared with :func:`parameter`, which
records the description, unit and allowed range that the ROS nodes also use to declare the
parameter, and the source of its value (the paper, or chosen and why), from which
``docs/parameters.md`` is generated (``scripts/generate_parameter_docs.py``). Sections nest;
a leaf's ROS parameter name is the dotted path of field names, e.g. ``robot.geometry.l2``.
Building a section from a flat ``{name: value}`` dictionary checks every value (type,
finiteness, range) and then the section's own cross-field rules, and raises
:class:`ParameterError` naming the offending parameter. Nothing is ever half-built.

The YAML layout is the standard ``ros__parameters`` form (``ros2 run ... --ros-args
--params-file``): sections keyed by node name, of which ``/**`` applies to every node.
"""

from __future__ import annotations

import array
import dataclasses
import math
import typing
from pathlib import Path
from typing import Any
from collections.abc import Mapping

import yaml

__all__ = [
    'ParameterError', 'ParameterSpec', 'parameter', 'leaf_specs', 'section_from_flat',
    'section_to_flat', 'flatten_mapping', 'load_parameter_file', 'read_parameter_document',
    'parameter_values', 'replace_in_section',
]


class ParameterError(ValueError):
    """A parameter value or file is invalid; the message names the parameter and the rule."""


@dataclasses.dataclass(frozen=True)
class ParameterSpec:
    """Declaration of one leaf parameter.

    Attributes
    ----------
    name : str
        Dotted ROS parameter name.
    type : type
        ``float``, ``int``, ``bool``, ``str``, ``tuple[float, ...]``, ``tuple[int, ...]`` or
        ``tuple[str, ...]``.
    description : str
        What the parameter means, in one line, for ``ros2 param describe``.
    unit : str
        SI unit (REP 103), or ``''`` when dimensionless.
    minimum, maximum : float or None
        Inclusive bounds for numbers (and for each element of a number list).
    read_only : bool
        True when the value cannot change while a node runs (geometry, masses).
    choices : tuple of str or None
        Allowed values of a string parameter.
    source : str
        Where the shipped value comes from, in one line: ``'paper ...'`` (a section or
        equation of the paper) or ``'chosen ...'`` (and why).
    """

    name: str
    type: Any
    description: str
    unit: str = ''
    minimum: float | None = None
    maximum: float | None = None
    read_only: bool = True
    choices: tuple[str, ...] | None = None
    source: str = ''

    @property
    def full_description(self) -> str:
        """Description with unit and range, as shown by ``ros2 param describe``."""
        text = self.description
        if self.unit:
            text += f' [{self.unit}]'
        if self.choices:
            text += f' (one of: {", ".join(self.choices)})'
        return text


def parameter(description: str, unit: str = '', minimum: float | None = None,
              maximum: float | None = None, *, read_only: bool = True,
              choices: tuple[str, ...] | None = None, source: str = '') -> Any:
    """Declare a leaf field of a parameter section (use as the dataclass field default)."""
    return dataclasses.field(metadata={'walker_parameter': {
        'description': description, 'unit': unit, 'minimum': minimum, 'maximum': maximum,
        'read_only': read_only, 'choices': choices, 'source': source}})


def _is_section(tp: Any) -> bool:
    return isinstance(tp, type) and dataclasses.is_dataclass(tp)


def leaf_specs(section_type: type, prefix: str = '') -> list[ParameterSpec]:
    """List every leaf parameter of a section type, depth first, with dotted names."""
    hints = typing.get_type_hints(section_type)
    specs: list[ParameterSpec] = []
    for f in dataclasses.fields(section_type):
        name = f'{prefix}{f.name}'
        tp = hints[f.name]
        if _is_section(tp):
            specs.extend(leaf_specs(tp, name + '.'))
            continue
        meta = f.metadata.get('walker_parameter')
        if meta is None:
            raise TypeError(f'{section_type.__name__}.{f.name} is not declared with parameter()')
        specs.append(ParameterSpec(name=name, type=tp, **meta))
    return specs


def _coerce(spec: ParameterSpec, value: Any) -> Any:
    """Check one value against its spec and return it in canonical form."""
    if isinstance(value, array.array):
        value = value.tolist()  # rclpy hands runtime updates of number lists over as arrays

    def fail(reason: str) -> typing.NoReturn:
        raise ParameterError(f'parameter {spec.name!r} = {value!r}: {reason}')

    def check_number(x: Any) -> float:
        if isinstance(x, bool) or not isinstance(x, (int, float)):
            fail('expected a number')
        x = float(x)
        if not math.isfinite(x):
            fail('must be finite (NaN and infinity are refused)')
        if spec.minimum is not None and x < spec.minimum:
            fail(f'below the minimum {spec.minimum:g}{" " + spec.unit if spec.unit else ""}')
        if spec.maximum is not None and x > spec.maximum:
            fail(f'above the maximum {spec.maximum:g}{" " + spec.unit if spec.unit else ""}')
        return x

    if spec.type is float:
        return check_number(value)
    if spec.type is int:
        if isinstance(value, bool) or not isinstance(value, int):
            fail('expected an integer')
        return int(check_number(value))
    if spec.type is bool:
        if not isinstance(value, bool):
            fail('expected true or false')
        return value
    if spec.type is str:
        if not isinstance(value, str):
            fail('expected a string')
        if spec.choices is not None and value not in spec.choices:
            fail(f'must be one of {", ".join(spec.choices)}')
        return value
    if spec.type == tuple[float, ...]:
        if isinstance(value, (str, bytes)) or not isinstance(value, (list, tuple)):
            fail('expected a list of numbers')
        return tuple(check_number(x) for x in value)
    if spec.type == tuple[int, ...]:
        if isinstance(value, (str, bytes)) or not isinstance(value, (list, tuple)):
            fail('expected a list of integers')
        if any(isinstance(x, bool) or not isinstance(x, int) for x in value):
            fail('expected a list of integers')
        return tuple(int(check_number(x)) for x in value)
    if spec.type == tuple[str, ...]:
        if not isinstance(value, (list, tuple)) or not all(isinstance(x, str) for x in value):
            fail('expected a list of strings')
        return tuple(value)
    raise TypeError(f'unsupported parameter type {spec.type!r} for {spec.name}')


def section_from_flat(section_type: type, flat: Mapping[str, Any], prefix: str = '') -> Any:
    """Build a section from a flat ``{dotted name: value}`` mapping.

    Every leaf must be present; unknown names under the prefix are ignored (other sections of
    the shared file). Raises :class:`ParameterError` naming the first invalid parameter.
    """
    hints = typing.get_type_hints(section_type)
    values = {}
    for f in dataclasses.fields(section_type):
        name = f'{prefix}{f.name}'
        tp = hints[f.name]
        if _is_section(tp):
            values[f.name] = section_from_flat(tp, flat, name + '.')
            continue
        if name not in flat:
            raise ParameterError(f'parameter {name!r} is missing')
        spec = ParameterSpec(name=name, type=tp, **f.metadata['walker_parameter'])
        values[f.name] = _coerce(spec, flat[name])
    try:
        return section_type(**values)
    except ParameterError:
        raise
    except (ValueError, TypeError) as error:
        raise ParameterError(f'{prefix.rstrip(".") or section_type.__name__}: {error}') from None


def section_to_flat(section: Any, prefix: str = '') -> dict[str, Any]:
    """Inverse of :func:`section_from_flat`: the flat ``{dotted name: value}`` mapping."""
    flat: dict[str, Any] = {}
    for f in dataclasses.fields(section):
        value = getattr(section, f.name)
        name = f'{prefix}{f.name}'
        if dataclasses.is_dataclass(value):
            flat.update(section_to_flat(value, name + '.'))
        else:
            flat[name] = list(value) if isinstance(value, tuple) else value
    return flat


def replace_in_section(section: Any, updates: Mapping[str, Any], prefix: str = '') -> Any:
    """Return a new section with some flat values replaced, validated as a whole.

    Raises :class:`ParameterError` (and leaves ``section`` untouched, being frozen) when the
    result is invalid or an update names an unknown parameter.
    """
    flat = section_to_flat(section, prefix)
    unknown = sorted(set(updates) - set(flat))
    if unknown:
        raise ParameterError(f'unknown parameter(s): {", ".join(unknown)}')
    flat.update(updates)
    return section_from_flat(type(section), flat, prefix)


def flatten_mapping(mapping: Mapping[str, Any], prefix: str = '') -> dict[str, Any]:
    """Flatten nested YAML mappings into dotted names, as ROS 2 does for parameter files."""
    flat: dict[str, Any] = {}
    for key, value in mapping.items():
        if not isinstance(key, str):
            raise ParameterError(f'parameter name {key!r} under {prefix!r} is not a string')
        name = f'{prefix}{key}'
        if isinstance(value, Mapping):
            flat.update(flatten_mapping(value, name + '.'))
        else:
            flat[name] = value
    return flat


def _node_key_matches(key: str, node_name: str | None) -> bool:
    if node_name is None:
        return False
    key = key.rstrip('/')
    return key == node_name or key.split('/')[-1] == node_name.split('/')[-1]


def load_parameter_file(path: str | Path, node_name: str | None = None) -> dict[str, Any]:
    """Read a ROS 2 parameter YAML file into a flat ``{dotted name: value}`` mapping.

    Parameters
    ----------
    path : str or Path
        The ``ros__parameters`` YAML file.
    node_name : str, optional
        Merge the section of this node (by full name or base name) over the ``/**`` section.

    Raises
    ------
    ParameterError
        If the file is missing, is not YAML, or does not have the ``ros__parameters`` layout.
    """
    path = Path(path)
    return parameter_values(read_parameter_document(path), node_name)


def read_parameter_document(path: str | Path) -> Mapping[str, Any]:
    """Parse a ROS 2 parameter YAML file once; return the document, its layout checked.

    Raises
    ------
    ParameterError
        If the file is missing, is not YAML, or does not have the ``ros__parameters`` layout.
    """
    path = Path(path)
    try:
        document = yaml.safe_load(path.read_text())
    except OSError as error:
        raise ParameterError(f'cannot read parameter file {path}: {error.strerror}') from None
    except yaml.YAMLError as error:
        raise ParameterError(f'parameter file {path} is not valid YAML: {error}') from None
    if not isinstance(document, Mapping) or not document:
        raise ParameterError(f'parameter file {path} must map node names to sections')
    for key, section in document.items():
        if not isinstance(section, Mapping) or 'ros__parameters' not in section:
            raise ParameterError(
                f'parameter file {path}: section {key!r} has no "ros__parameters" mapping')
        if not isinstance(section['ros__parameters'], Mapping):
            raise ParameterError(
                f'parameter file {path}: {key}.ros__parameters must be a mapping')
    return document


def parameter_values(document: Mapping[str, Any],
                     node_name: str | None = None) -> dict[str, Any]:
    """Return a parsed parameter file's flat ``{dotted name: value}`` mapping.

    ``document`` is :func:`read_parameter_document`'s; ``node_name``'s section (by full name
    or base name) is merged over the ``/**`` section.
    """
    wildcard: dict[str, Any] = {}
    specific: dict[str, Any] = {}
    for key, section in document.items():
        if str(key) in ('/**', '**'):
            wildcard.update(flatten_mapping(section['ros__parameters']))
        elif _node_key_matches(str(key), node_name):
            specific.update(flatten_mapping(section['ros__parameters']))
    return {**wildcard, **specific}
