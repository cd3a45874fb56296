"""The workspace's structure rules, checked by reading the source (no module is imported).

docs/architecture.md's rules that a reviewer would otherwise check by hand:

* a node file (a module named ``*_node.py``, or one that defines a ``Node`` subclass) is at most
  :data:`NODE_FILE_LINES` lines: a node only converts messages and calls its core;
* no import circle among the production modules (each package's modules, tests left out),
  counting every import, also one made inside a function;
* every console script a ``setup.py`` declares names a module of the workspace and a function
  defined in it;
* every workspace package a package's production modules import is declared in its
  ``package.xml`` (``depend`` or ``exec_depend``);
* no production module builds a parameter section itself (``file.section(...)``,
  ``section_from_flat``, ``Section.from_flat``, the one-section ``load_*`` helpers, the
  plant's ``plant_sections``) but the
  configuration loader and the few modules of :data:`SECTION_BUILDERS`, each with its reason:
  everyone else takes a ``WalkerConfiguration``, so a file that breaks a rule between sections
  is refused the same way everywhere; and where a node declares a section
  (:func:`section_declarations`), it is one the table of sections lists.

The modules are found by walking the ROS packages of a source tree
(:func:`ros_free.workspace_modules`), so a new package or module is checked without being
listed.
"""

from __future__ import annotations

import ast
import dataclasses
import re
import xml.etree.ElementTree as ElementTree
from pathlib import Path

from ros_free import module_imports, workspace_modules

__all__ = ['NODE_FILE_LINES', 'long_node_files', 'import_circles', 'unresolved_console_scripts',
           'undeclared_dependencies', 'SECTION_BUILDERS', 'direct_section_builds',
           'SectionDeclaration', 'section_declarations']

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


#: Calls that build a parameter section from a file's or a mapping's values: a method
#: (``file.section(...)``, ``WalkerParameters.from_flat(...)``) or a function.
_SECTION_METHODS = ('section', 'from_flat')
_SECTION_FUNCTIONS = ('section_from_flat', 'load_walker_parameters', 'load_controller_settings',
                      'load_sim_parameters', 'load_parameter_file', 'plant_sections')
_BELOW_THE_LOADER = ('a tool of a package the configuration loader depends on (walker_config '
                     'needs every section): importing the loader would make a package circle')

#: The production modules that may build a section themselves, and why. Every other module
#: takes its sections from ``walker_config.core.configuration.load_configuration``.
SECTION_BUILDERS = {
    'walker_config.core.configuration': 'the configuration loader',
    'walker_core.parameter_schema': 'the schema: builds a section from flat values',
    'walker_core.parameter_file': 'the parsed file the loader builds its sections from',
    'walker_core.robot_parameters': 'defines WalkerParameters and its one-section helper',
    'walker_control.core.config': 'defines ControllerSettings and its one-section helper',
    'walker_sim.core.config': "defines SimParameters and the plant's sections (the loader's)",
    'walker_runtime.node_parameters': 'a node declares the sections it reads as ROS '
                                      'parameters and checks its own rules with them',
    'walker_report.core.report': "reads the walk's file (which the walk's loader accepted) "
                                 'without the supervisor, planner or controllers',
    'walker_teleop.walkerctl': "the truss layout on an operator's machine, which has no "
                               'plant, controllers or planner',
    'walker_sim.core': "the plant core of a plant's own file: its sections and their rule "
                       '(as the loader reads a plant file)',
    'walker_campaign.core.parameter_sets': "a run's truth set: the plant's sections and their "
                                           'rule (as the loader reads a plant file)',
    'walker_sim.render_walker': _BELOW_THE_LOADER,
    'walker_sim.identify_modes': _BELOW_THE_LOADER,
    'walker_control.analysis.design': _BELOW_THE_LOADER,
    'walker_control.analysis.floor': _BELOW_THE_LOADER,
    'walker_planner.report': _BELOW_THE_LOADER,
    'walker_planner.figures': _BELOW_THE_LOADER,
}


def _called_name(call: ast.Call) -> tuple[str, bool]:
    """Return the name a call calls and whether it is an attribute (``x.name(...)``)."""
    if isinstance(call.func, ast.Attribute):
        return call.func.attr, True
    return getattr(call.func, 'id', ''), False


def direct_section_builds(source: Path, allowed=None) -> list[str]:
    """Say where a production module outside ``allowed`` builds a parameter section itself.

    ``allowed`` maps a module to its reason (default :data:`SECTION_BUILDERS`); a listed module
    that is not in the workspace is said too, so the list does not outlive its reasons.
    """
    allowed = SECTION_BUILDERS if allowed is None else allowed
    modules = workspace_modules(source)
    found = [f'{module}: listed as a section builder ({reason}) but not in the workspace'
             for module, reason in allowed.items() if module not in modules]
    for module, path in sorted(modules.items()):
        if module in allowed:
            continue
        tree = ast.parse(path.read_text(), filename=str(path))
        for node in ast.walk(tree):
            if not isinstance(node, ast.Call):
                continue
            name, method = _called_name(node)
            if (method and name in _SECTION_METHODS) or name in _SECTION_FUNCTIONS:
                found.append(f'{path}:{node.lineno}: {module} builds a parameter section '
                             f'itself ({ast.unparse(node.func)}(...)): take it from '
                             f'walker_config.core.configuration.load_configuration')
    return found


#: The node layer's calls that take a section type and its prefix (``node, type, prefix``).
_DECLARING_CALLS = ('declare_section', 'guard_section_updates')


@dataclasses.dataclass(frozen=True)
class SectionDeclaration:
    """Where a node declares a section, and what names its type and prefix.

    ``section`` and ``prefix`` are each ``(module, name)`` of an imported name, or ``(None,
    value)`` of a literal (a prefix left out is ``(None, '')``); an argument that is neither
    is ``(None, None)``.
    """

    where: str
    section: tuple[str | None, object]
    prefix: tuple[str | None, object]


def _imported_names(tree: ast.Module, module: str, path: Path) -> dict[str, tuple[str, str]]:
    package = module.split('.') if path.name == '__init__.py' else module.split('.')[:-1]
    names = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            base = node.module or ''
            if node.level:
                base = '.'.join(package[:len(package) - node.level + 1]
                                + ([node.module] if node.module else []))
            for alias in node.names:
                names[alias.asname or alias.name] = (base, alias.name)
    return names


def _reference(argument: ast.expr | None, names: dict[str, tuple[str, str]]):
    if argument is None:
        return None, ''
    if isinstance(argument, ast.Constant):
        return None, argument.value
    if isinstance(argument, ast.Name) and argument.id in names:
        return names[argument.id]
    return None, None


def section_declarations(source: Path) -> list[SectionDeclaration]:
    """Return every ``declare_section``/``guard_section_updates`` call of the production modules.

    The section and prefix are read from the call (positional or by keyword), each traced to
    the import that names it; no module is imported.
    """
    found = []
    for module, path in sorted(workspace_modules(source).items()):
        tree = ast.parse(path.read_text(), filename=str(path))
        names = _imported_names(tree, module, path)
        for node in ast.walk(tree):
            if not isinstance(node, ast.Call) or _called_name(node)[0] not in _DECLARING_CALLS:
                continue
            keywords = {k.arg: k.value for k in node.keywords}
            section = node.args[1] if len(node.args) > 1 else keywords.get('section_type')
            prefix = node.args[2] if len(node.args) > 2 else keywords.get('prefix')
            found.append(SectionDeclaration(f'{path}:{node.lineno}',
                                            _reference(section, names),
                                            _reference(prefix, names)))
    return found
