"""Message definitions and type hashes of installed interfaces, as rosbag2 stores them.

An MCAP rosbag2 bag keeps, for every message type, a *schema*: the type's ``.msg`` text
followed by the text of every type it uses, each introduced by a line of 80 ``=`` and a line
``MSG: pkg/Type`` (encoding ``ros2msg``). Readers that have never seen the type (rosbags,
Foxglove, the ``mcap`` ROS 2 decoder) decode messages from this text alone, so custom
``walker_msgs`` types need nothing installed on the reading side.

The text is built here the way rosbag2's local message definition source builds it: the
installed ``share/<pkg>/msg/<Type>.msg`` file verbatim, then its dependencies depth first, each
once, in sorted order of their names. A type with no ``.msg`` file (an interface defined in
IDL) falls back to its ``.idl`` text with ``IDL: pkg/msg/Type`` sections (encoding
``ros2idl``). Files are looked up in the install prefixes of ``AMENT_PREFIX_PATH``.

The type hash (``RIHS01_<sha256 hex>``) of an installed type is read from the
``share/<pkg>/msg/<Type>.json`` type description that rosidl generates beside the ``.msg``.
"""

from __future__ import annotations

import dataclasses
import json
import os
import re
from collections.abc import Sequence
from pathlib import Path

from walker_bag.core.errors import MessageDefinitionError

__all__ = [
    'MessageDefinition', 'SEPARATOR', 'interface_prefixes', 'split_type_name',
    'message_definition', 'type_description_hash',
]

#: The line that introduces each dependency's text in a concatenated definition.
SEPARATOR = '=' * 80 + '\n'

_NAME = r'[a-zA-Z][a-zA-Z0-9_]*'
_TYPE_NAME = re.compile(rf'^({_NAME})/(?:({_NAME})/)?({_NAME})$')
# First token of a line, with an optional array suffix: the field (or constant) type.
_MSG_FIELD_TYPE = re.compile(r'(?:^|\n)\s*([a-zA-Z0-9_/]+)(?:\[[^\]]*\])?\s+')
_IDL_INCLUDE = re.compile(r'(?:^|\n)#include\s+(?:"|<)([a-zA-Z0-9_/]+)\.idl(?:"|>)')
_PRIMITIVES = frozenset({
    'bool', 'byte', 'char', 'float32', 'float64', 'int8', 'uint8', 'int16', 'uint16',
    'int32', 'uint32', 'int64', 'uint64', 'string', 'wstring'})
# Deeper nesting than this means a cycle in the definitions.
_MAX_DEPTH = 50


@dataclasses.dataclass(frozen=True)
class MessageDefinition:
    """The schema of one message type, as stored in an MCAP rosbag2 bag.

    Attributes
    ----------
    type_name : str
        Full type name, e.g. ``'sensor_msgs/msg/JointState'``.
    encoding : str
        ``'ros2msg'`` or ``'ros2idl'``.
    text : str
        The concatenated definition.
    """

    type_name: str
    encoding: str
    text: str


def interface_prefixes(environ: dict[str, str] | None = None) -> tuple[Path, ...]:
    """Install prefixes to search for interface files: ``AMENT_PREFIX_PATH``, in order."""
    value = (os.environ if environ is None else environ).get('AMENT_PREFIX_PATH', '')
    return tuple(Path(p) for p in value.split(os.pathsep) if p)


def split_type_name(type_name: str) -> tuple[str, str, str]:
    """Split ``pkg/msg/Type`` (or ``pkg/Type``) into ``(pkg, 'msg', 'Type')``.

    Raises
    ------
    MessageDefinitionError
        If the name is not a ROS 2 interface type name.
    """
    match = _TYPE_NAME.match(type_name) if isinstance(type_name, str) else None
    if match is None:
        raise MessageDefinitionError(
            f'{type_name!r} is not a ROS 2 message type name (pkg/msg/Type)')
    package, namespace, name = match.groups()
    return package, namespace or 'msg', name


def _find(package: str, namespace: str, name: str, suffix: str,
          prefixes: Sequence[Path]) -> Path | None:
    for prefix in prefixes:
        path = prefix / 'share' / package / namespace / f'{name}{suffix}'
        if path.is_file():
            return path
    return None


def _msg_dependencies(text: str, package: str) -> list[str]:
    names = set()
    for match in _MSG_FIELD_TYPE.finditer(text):
        field_type = match.group(1)
        if field_type in _PRIMITIVES:
            continue
        names.add(field_type if '/' in field_type else f'{package}/{field_type}')
    return sorted(names)


def _idl_dependencies(text: str, package: str) -> list[str]:
    return sorted({m.group(1) for m in _IDL_INCLUDE.finditer(text)})


def _concatenate(root: str, suffix: str, label: str, prefixes: Sequence[Path]) -> str:
    """Depth-first concatenation of a definition and every definition it depends on."""
    dependencies_of = _msg_dependencies if suffix == '.msg' else _idl_dependencies
    seen: set[tuple[str, str, str]] = set()

    def text_of(type_name: str, depth: int) -> str:
        if depth > _MAX_DEPTH:
            raise MessageDefinitionError(f'definition of {root} nests deeper than {_MAX_DEPTH}')
        package, namespace, name = split_type_name(type_name)
        path = _find(package, namespace, name, suffix, prefixes)
        if path is None:
            raise MessageDefinitionError(
                f'no {suffix} file for {type_name} (needed by {root}) under share/{package}/'
                f'{namespace} in AMENT_PREFIX_PATH {[str(p) for p in prefixes]}')
        text = path.read_text()
        for dependency in dependencies_of(text, package):
            key = split_type_name(dependency)
            if key in seen:
                continue
            seen.add(key)
            text += '\n' + SEPARATOR + f'{label}: {dependency}\n' + text_of(dependency, depth + 1)
        return text

    return text_of(root, 0)


def message_definition(type_name: str,
                       prefixes: Sequence[Path] | None = None) -> MessageDefinition:
    """Return the concatenated definition of an installed message type.

    Parameters
    ----------
    type_name : str
        ``'pkg/msg/Type'`` (``'pkg/Type'`` is accepted).
    prefixes : sequence of Path, optional
        Install prefixes to search; default :func:`interface_prefixes`.

    Raises
    ------
    MessageDefinitionError
        If the type or one of its dependencies has no installed ``.msg`` (nor ``.idl``) file.
    """
    prefixes = interface_prefixes() if prefixes is None else tuple(prefixes)
    package, namespace, name = split_type_name(type_name)
    full_name = f'{package}/{namespace}/{name}'
    if _find(package, namespace, name, '.msg', prefixes) is not None:
        return MessageDefinition(full_name, 'ros2msg',
                                 _concatenate(full_name, '.msg', 'MSG', prefixes))
    if _find(package, namespace, name, '.idl', prefixes) is not None:
        text = _concatenate(full_name, '.idl', 'IDL', prefixes)
        return MessageDefinition(full_name, 'ros2idl',
                                 SEPARATOR + f'IDL: {full_name}\n' + text)
    raise MessageDefinitionError(
        f'no definition of {full_name}: share/{package}/{namespace}/{name}.msg is in none of '
        f'the install prefixes {[str(p) for p in prefixes]} (AMENT_PREFIX_PATH)')


def type_description_hash(type_name: str, prefixes: Sequence[Path] | None = None) -> str:
    """Return the ``RIHS01_...`` hash of an installed type from its rosidl type description.

    Raises
    ------
    MessageDefinitionError
        If the type has no ``.json`` type description or it lists no hash for the type.
    """
    prefixes = interface_prefixes() if prefixes is None else tuple(prefixes)
    package, namespace, name = split_type_name(type_name)
    full_name = f'{package}/{namespace}/{name}'
    path = _find(package, namespace, name, '.json', prefixes)
    if path is None:
        raise MessageDefinitionError(f'no type description share/{package}/{namespace}/'
                                     f'{name}.json for {full_name} in AMENT_PREFIX_PATH')
    try:
        hashes = json.loads(path.read_text())['type_hashes']
        return next(h['hash_string'] for h in hashes if h['type_name'] == full_name)
    except (ValueError, KeyError, TypeError, StopIteration):
        raise MessageDefinitionError(f'{path} lists no type hash for {full_name}') from None
