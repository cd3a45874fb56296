"""Find the ROS imports of the ROS-free layers, by reading the source (no module is imported).

The rule (docs/architecture.md): every module of a ``core`` package or directory, and every
module of ``walker_core``, is plain Python: it imports neither rclpy nor an interface package
(``*_msgs``, ``*_srvs``, ``*_interfaces``, the rcl and rosidl libraries), not even lazily inside a
function, and not through a module of the workspace that does. The modules are found by walking
the ROS packages of a source tree, so a new package or module is checked without being listed.
"""

from __future__ import annotations

import ast
import dataclasses
from collections.abc import Iterator
from pathlib import Path

__all__ = ['RosImport', 'ros_free_violations', 'is_ros_module', 'workspace_modules',
           'module_imports']

#: ROS packages whose every module must be ROS-free (besides every ``core`` of every package).
ROS_FREE_PACKAGES = ('walker_core',)
_ROS_PREFIXES = ('rclpy', 'rcl_', 'rcutils', 'rmw', 'rosidl', 'rosbag2_py')
_INTERFACE_SUFFIXES = ('_msgs', '_srvs', '_interfaces')


@dataclasses.dataclass(frozen=True)
class RosImport:
    """A ROS import reached from a module that must be ROS-free.

    Attributes
    ----------
    module : str
        The ROS-free module (dotted name).
    imported : str
        The ROS module imported.
    chain : tuple of str
        The modules from ``module`` to the one that imports ``imported`` (itself when direct).
    path : Path
        The file of the module that imports it, and ``line`` its line.
    """

    module: str
    imported: str
    chain: tuple[str, ...]
    path: Path
    line: int

    def __str__(self) -> str:
        via = f' (through {" -> ".join(self.chain[1:])})' if len(self.chain) > 1 else ''
        return f'{self.module} imports {self.imported}{via}: {self.path}:{self.line}'


def is_ros_module(name: str) -> bool:
    """Say whether a dotted module name belongs to rclpy, the rcl libraries or an interface."""
    top = name.split('.')[0]
    return top.startswith(_ROS_PREFIXES) or top.endswith(_INTERFACE_SUFFIXES)


def workspace_modules(source: Path) -> dict[str, Path]:
    """Map every Python module of the ROS packages under ``source`` to its file.

    A ROS package is a directory with a ``package.xml``; its Python packages are the
    directories beside it that hold an ``__init__.py`` (tests and build files are left out).
    """
    modules: dict[str, Path] = {}
    for manifest in sorted(Path(source).glob('*/package.xml')):
        package_dir = manifest.parent
        for init in sorted(package_dir.glob('*/__init__.py')):
            python_package = init.parent
            if python_package.name in ('test', 'tests'):
                continue
            for path in sorted(python_package.rglob('*.py')):
                parts = path.relative_to(package_dir).with_suffix('').parts
                if parts[-1] == '__init__':
                    parts = parts[:-1]
                modules['.'.join(parts)] = path
    return modules


def _must_be_ros_free(module: str) -> bool:
    parts = module.split('.')
    return parts[0] in ROS_FREE_PACKAGES or 'core' in parts[1:]


def module_imports(module: str, path: Path) -> Iterator[tuple[str, int]]:
    """Yield every module ``module`` imports, anywhere in its file, with the line."""
    tree = ast.parse(path.read_text(), filename=str(path))
    package = module.split('.') if path.name == '__init__.py' else module.split('.')[:-1]
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, node.lineno
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[:len(package) - node.level + 1]
                prefix = '.'.join(base + ([node.module] if node.module else []))
            else:
                prefix = node.module or ''
            yield prefix, node.lineno
            for alias in node.names:  # ``from pkg import module`` imports a module too
                yield f'{prefix}.{alias.name}', node.lineno
        elif isinstance(node, ast.Call) and node.args \
                and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str):
            function = node.func
            name = function.attr if isinstance(function, ast.Attribute) else \
                function.id if isinstance(function, ast.Name) else ''
            if name in ('import_module', '__import__'):
                yield node.args[0].value, node.lineno


def _loaded_with(name: str, modules: dict[str, Path]) -> list[str]:
    """List the workspace modules importing ``name`` runs: its parent packages, then itself."""
    parts = name.split('.')
    return [m for m in ('.'.join(parts[:i]) for i in range(1, len(parts) + 1)) if m in modules]


def ros_free_violations(source: Path) -> list[RosImport]:
    """Return every ROS import reached from a module that must be ROS-free, under ``source``.

    Each ROS-free module is followed through the workspace modules it imports (and their
    parent packages), so a core that imports a node module is caught as well.
    """
    modules = workspace_modules(source)
    direct: dict[str, list[tuple[str, int]]] = {m: list(module_imports(m, p)) for m, p in
                                                modules.items()}
    found: dict[tuple[str, str, int], RosImport] = {}
    for start in sorted(m for m in modules if _must_be_ros_free(m)):
        seen = {start}
        queue: list[tuple[str, tuple[str, ...]]] = [(start, (start,))]
        while queue:
            module, chain = queue.pop(0)
            for imported, line in direct[module]:
                if is_ros_module(imported):  # ``from rclpy.node import Node``: once, not twice
                    found.setdefault((start, module, line),
                                     RosImport(start, imported, chain, modules[module], line))
                    continue
                for reached in _loaded_with(imported, modules):
                    if reached not in seen:
                        seen.add(reached)
                        queue.append((reached, (*chain, reached)))
    return list(found.values())
