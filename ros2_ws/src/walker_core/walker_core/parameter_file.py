"""The parameter file read once, and the typed sections built from its values.

A file is parsed once per :meth:`ParameterFile.read`, and every section is built from those
values (:meth:`ParameterFile.section`); the installed ``config/walker.yaml``, which every node
declares its parameters with as defaults, is parsed once per process (:func:`default_values`).
The sections come from the packages that own them; the whole set, with the rules between
sections, is ``walker_config.core.configuration.load_configuration`` (docs/architecture.md,
Configuration).
"""

from __future__ import annotations

import functools
import os
import types
from pathlib import Path
from collections.abc import Mapping
from typing import Any, TypeVar

from walker_core.parameter_schema import load_parameter_file, section_from_flat

__all__ = ['ParameterFile', 'default_parameter_file', 'default_values']

_SectionT = TypeVar('_SectionT')


def default_parameter_file() -> Path:
    """Path of the installed ``walker.yaml``, or of the source one next to this package.

    The ament index is asked first; without it (no ``AMENT_PREFIX_PATH``, or the package not
    in it) the file beside the package's source (a source checkout or a symlink install) is
    used.

    Raises
    ------
    FileNotFoundError
        When neither exists, saying how to point at the file.
    """
    try:
        from ament_index_python.packages import get_package_share_directory
        candidate = Path(get_package_share_directory('walker_core')) / 'config' / 'walker.yaml'
        if candidate.exists():
            return candidate
    except (ImportError, LookupError, ValueError, OSError):  # OSError: no AMENT_PREFIX_PATH
        pass
    source = _source_parameter_file()
    if source.exists():
        return source
    raise FileNotFoundError(
        f'walker_core/config/walker.yaml was found neither through the ament index '
        f'(AMENT_PREFIX_PATH={os.environ.get("AMENT_PREFIX_PATH", "")!r}) nor beside the '
        f'package source ({source}): source the workspace install/setup.bash, or pass '
        f'the parameter file explicitly')


def _source_parameter_file() -> Path:
    return Path(__file__).resolve().parents[1] / 'config' / 'walker.yaml'


@functools.cache
def default_values() -> Mapping[str, Any]:
    """Return the installed ``walker.yaml``'s flat values, parsed once per process (read-only).

    Raises
    ------
    ParameterError
        If the installed file cannot be read or has not the ``ros__parameters`` layout.
    """
    return types.MappingProxyType(load_parameter_file(default_parameter_file()))


class ParameterFile:
    """A parameter file's values and the sections built from them.

    Parameters
    ----------
    values : mapping
        Flat ``{dotted name: value}`` values.
    path : Path
        The file they were read from.

    Notes
    -----
    A file names every parameter of the sections asked of it (a missing one is refused,
    named), as ``walker.yaml`` does: a node started with a file that leaves some out takes the
    installed values for them, and a tool would then judge other values than the graph runs.
    Only the ``/**`` section of a file is read: a section keyed by one node's name applies to
    that node alone, as ``--params-file`` does.
    """

    def __init__(self, values: Mapping[str, Any], path: Path) -> None:
        self.values = types.MappingProxyType(dict(values))
        self.path = path
        self._sections: dict[tuple[type, str], Any] = {}

    @classmethod
    def read(cls, path: str | Path | None = None,
             overrides: Mapping[str, Any] | None = None) -> 'ParameterFile':
        """Read ``path`` once (default: the installed ``walker.yaml``, parsed once per process).

        Parameters
        ----------
        path : str or Path, optional
            The ``ros__parameters`` file.
        overrides : mapping, optional
            Flat values over the file's (as ``-p name:=value`` over ``--params-file``).

        Raises
        ------
        ParameterError
            If a file is missing, is not YAML, or has not the ``ros__parameters`` layout (the
            values themselves are checked by :meth:`section`).
        """
        resolved = Path(path or default_parameter_file()).resolve()
        values = dict(default_values()) if resolved == default_parameter_file().resolve() \
            else load_parameter_file(resolved)
        values.update(overrides or {})
        return cls(values, resolved)

    def section(self, section_type: type[_SectionT], prefix: str = '') -> _SectionT:
        """Build (once) and return the section ``section_type`` found under ``prefix``.

        Raises
        ------
        ParameterError
            Naming the missing or invalid parameter, or the rule of the section it breaks.
        """
        key = (section_type, prefix)
        if key not in self._sections:
            self._sections[key] = section_from_flat(section_type, self.values, prefix)
        return self._sections[key]
