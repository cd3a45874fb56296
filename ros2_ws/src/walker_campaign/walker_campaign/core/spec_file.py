"""A campaign spec file as a mapping, a spec it ``extends`` folded in.

A spec may start from another and change only what differs::

    extends: truss_as_built.yaml   # a path relative to this file, or a shipped spec's name
    name: truss_as_built_camera    # not inherited: by default, this file's name
    sweeps:
      gripper.camera.enabled: [true]
    dispersions:
      node_placement:              # replaces the base's dispersion of that name, in its place
        parameter: sim.imperfections.node_placement
        uniform: {low: 0.0, high: 0.004}

Top-level keys replace the base's; ``route``, ``dispersions`` and ``sweeps`` are merged entry
by entry (a dispersion or sweep given ``null`` is removed; new ones come after the base's, in
the file's order). The base's own relative paths (``params_file``, ``truss_survey``) stay
relative to the base's folder. A chain of ``extends`` is followed; a cycle is refused.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from walker_campaign.core.errors import SpecError

__all__ = ['read_spec_mapping', 'MERGED_KEYS', 'RELATIVE_PATH_KEYS']

#: Top-level keys whose entries a spec that extends another merges into the base's.
MERGED_KEYS = ('route', 'dispersions', 'sweeps')
#: Top-level keys holding a path relative to the spec file that names it.
RELATIVE_PATH_KEYS = ('params_file', 'truss_survey')


def read_spec_mapping(path: Path, find_base=None) -> Any:
    """Return the YAML document of a spec file with the spec it extends folded in.

    Parameters
    ----------
    path : Path
        The spec file.
    find_base : callable, optional
        ``find_base(text) -> Path`` for an ``extends`` value that is no file beside the spec
        (a shipped spec's name); default: such a value is refused.

    Raises
    ------
    SpecError
        A file cannot be read or is no valid YAML, ``extends`` is no file or forms a cycle.
    """
    return _read(Path(path), find_base, ())


def _load(path: Path) -> Any:
    try:
        return yaml.safe_load(path.read_text())
    except OSError as error:
        raise SpecError(f'cannot read campaign spec {path}: {error.strerror}') from None
    except yaml.YAMLError as error:
        raise SpecError(f'campaign spec {path} is not valid YAML: {error}') from None


def _read(path: Path, find_base, chain: tuple[Path, ...]) -> Any:
    resolved = path.resolve()
    if resolved in chain:
        names = ' -> '.join(p.name for p in chain + (resolved,))
        raise SpecError(f'extends: a cycle of campaign specs ({names})')
    mapping = _load(path)
    if not isinstance(mapping, Mapping) or 'extends' not in mapping:
        return mapping
    child = dict(mapping)
    base_text = child.pop('extends')
    if not isinstance(base_text, str) or not base_text:
        raise SpecError("extends: expected a spec file or a shipped spec's name, got "
                        f'{base_text!r}')
    base_path = resolved.parent / base_text
    if not base_path.is_file():
        if find_base is None:
            raise SpecError(f'extends: no campaign spec file {base_path}')
        base_path = find_base(base_text)
    base = _read(base_path, find_base, chain + (resolved,))
    if not isinstance(base, Mapping):
        raise SpecError(f'extends: campaign spec {base_path} is not a mapping')
    return _merge(_rooted(base, base_path.resolve().parent), child)


def _rooted(base: Mapping, folder: Path) -> dict:
    """Return the base with its relative paths made absolute (they name files beside it)."""
    rooted = {key: value for key, value in base.items() if key != 'name'}
    for key in RELATIVE_PATH_KEYS:
        if isinstance(rooted.get(key), str):
            rooted[key] = str(folder / Path(rooted[key]).expanduser())
    return rooted


def _merge(base: dict, child: Mapping) -> dict:
    merged = dict(base)
    for key, value in child.items():
        if key in MERGED_KEYS and isinstance(value, Mapping) \
                and isinstance(base.get(key), Mapping):
            entries = dict(base[key])
            for name, entry in value.items():
                if entry is None and key != 'route':
                    entries.pop(name, None)
                else:
                    entries[name] = entry
            merged[key] = entries
        else:
            merged[key] = value
    return merged
