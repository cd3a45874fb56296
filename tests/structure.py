"""The workspace's structure rules, checked by reading the source (no module is imported).

docs/architecture.md's rules that a reviewer would otherwise check by hand:

* a node file (a module named ``*_node.py``, or one that defines a ``Node`` subclass) is at most
  :data:`NODE_FILE_LINES` lines: a node only converts messages and calls its core;
* no import circle among the production modules (each package's modules, tests left out),
  counting every import, also one made inside a function;
* every console script a ``setup.py`` declares names a module of the workspace and a function
  defined in it;
* every workspace package a package's production modules import is declared in its
  ``package.xml`` (``depend`` or ``exec_depend``).

The modules are found by walking the ROS packages of a source tree
(:func:`ros_free.workspace_modules`), so a new package or module is checked without being
listed.
"""

from __future__ import annotations

import ast
import re
import xml.etree.ElementTree as ElementTree
from pathlib import Path

from ros_free import module_imports, workspace_modules

__all__ = ['NODE_FILE_LINES', 'long_node_files', 'import_circles', 'unresolved_console_scripts',
           'undeclared_dependencies']

#: Longest node file [lines].
NODE_FILE_LINES = 400
#: Tags of package.xml that make a package available to another's modules at run time.
_RUN_DEPENDENCY_TAGS = ('depend', 'exec_depend')


def _is_node_file(path: Path) -> bool:
    if path.name.endswith('_node.py'):
        return True
    tree = ast.parse(path.read_text(), filename=str(path))
    return any(isinstance(node, ast.ClassDef) and any(
        (base.attr if isinstance(base, ast.Attribute) else getattr(base, 'id', '')) == 'Node'
        for base in node.bases) for node in ast.walk(tree))


def long_node_files(source: Path, limit: int = NODE_FILE_LINES) -> list[str]:
    """Say which node files under ``source`` are longer than ``limit`` lines."""
    found = []
    for path in sorted(workspace_modules(source).values()):
        lines = len(path.read_text().splitlines())
        if lines > limit and _is_node_file(path):
            found.append(f'{path}: {lines} lines (a node file has at most {limit})')
    return found


def _target(imported: str, modules: dict[str, Path]) -> str | None:
    """Return the workspace module an import names (the longest prefix that is one)."""
    parts = imported.split('.')
    for end in range(len(parts), 0, -1):
        name = '.'.join(parts[:end])
        if name in modules:
            return name
    return None


def _import_graph(modules: dict[str, Path]) -> dict[str, set[str]]:
    graph: dict[str, set[str]] = {}
    for module, path in modules.items():
        edges = set()
        for imported, _line in module_imports(module, path):
            target = _target(imported, modules)
            # a package's own __init__ (a parent of the module) is not an edge: importing
            # ``a.b.c`` runs ``a`` and ``a.b`` first whatever ``c`` imports
            if target is not None and target != module \
                    and not module.startswith(target + '.'):
                edges.add(target)
        graph[module] = edges
    return graph


def import_circles(source: Path) -> list[str]:
    """Return each import circle among the production modules under ``source``, as text.

    A circle is a strongly connected set of modules (Tarjan's algorithm), shown with one
    cycle through it.
    """
    graph = _import_graph(workspace_modules(source))
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    circles: list[list[str]] = []

    def connect(start: str) -> None:  # iterative Tarjan: deep module chains, no recursion
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            module, edges = work[-1]
            advanced = False
            for target in edges:
                if target not in index:
                    index[target] = low[target] = len(index)
                    stack.append(target)
                    on_stack.add(target)
                    work.append((target, iter(sorted(graph[target]))))
                    advanced = True
                    break
                if target in on_stack:
                    low[module] = min(low[module], index[target])
            if advanced:
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[module])
            if low[module] == index[module]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == module:
                        break
                if len(component) > 1:
                    circles.append(sorted(component))

    for module in sorted(graph):
        if module not in index:
            connect(module)
    return [' -> '.join(_cycle(graph, component)) for component in sorted(circles)]


def _cycle(graph: dict[str, set[str]], component: list[str]) -> list[str]:
    """Return one cycle through the first module of a strongly connected ``component``."""
    members, start = set(component), component[0]
    paths = {start: [start]}
    queue = [start]
    while queue:
        module = queue.pop(0)
        for target in sorted(graph[module] & members):
            if target == start:
                return paths[module] + [start]
            if target not in paths:
                paths[target] = paths[module] + [target]
                queue.append(target)
    return component


_ENTRY = re.compile(r"['\"]\s*([\w.-]+)\s*=\s*([\w.]+)\s*:\s*(\w+)\s*['\"]")


def _console_scripts(setup: Path) -> list[tuple[str, str, str]]:
    """Return ``(script, module, function)`` of every console script ``setup`` declares."""
    tree = ast.parse(setup.read_text(), filename=str(setup))
    scripts = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Dict):
            for key, value in zip(node.keys, node.values, strict=True):
                if isinstance(key, ast.Constant) and key.value == 'console_scripts':
                    scripts += [m.groups() for m in _ENTRY.finditer(ast.unparse(value))]
    return scripts


def _defines(path: Path, name: str) -> bool:
    """Say whether a module defines (or imports) ``name`` at its top level."""
    tree = ast.parse(path.read_text(), filename=str(path))
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)) \
                and node.name == name:
            return True
        if isinstance(node, ast.Assign) and any(
                isinstance(t, ast.Name) and t.id == name for t in node.targets):
            return True
        if isinstance(node, (ast.Import, ast.ImportFrom)) and any(
                (alias.asname or alias.name.split('.')[0]) == name for alias in node.names):
            return True
    return False


def unresolved_console_scripts(source: Path) -> list[str]:
    """Say which console scripts under ``source`` name a module or function that is not there."""
    modules = workspace_modules(source)
    found = []
    for setup in sorted(Path(source).glob('*/setup.py')):
        for script, module, function in _console_scripts(setup):
            path = modules.get(module)
            if path is None:
                found.append(f'{setup}: {script} = {module}:{function}: no module {module}')
            elif not _defines(path, function):
                found.append(f'{setup}: {script} = {module}:{function}: {path} defines no '
                             f'{function}')
    return found


def _declared(manifest: Path) -> set[str]:
    root = ElementTree.parse(manifest).getroot()
    return {element.text.strip() for tag in _RUN_DEPENDENCY_TAGS
            for element in root.iter(tag) if element.text}


def undeclared_dependencies(source: Path) -> list[str]:
    """Say which workspace packages a package's modules import without its package.xml's leave.

    A workspace package is a directory under ``source`` with a ``package.xml``; an import of
    one by another's production module needs a ``depend`` or ``exec_depend`` on it.
    """
    source = Path(source)
    packages = {manifest.parent.name: manifest
                for manifest in sorted(source.glob('*/package.xml'))}
    found: dict[tuple[str, str], str] = {}
    for module, path in sorted(workspace_modules(source).items()):
        owner = path.relative_to(source).parts[0]
        declared = _declared(packages[owner])
        for imported, line in module_imports(module, path):
            top = imported.split('.')[0]
            if top in packages and top != owner and top not in declared:
                found.setdefault((owner, top), f'{path}:{line}: {owner} imports {top}, which '
                                 f'its package.xml does not declare')
    return list(found.values())
