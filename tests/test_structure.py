"""The structure rules, checked on the whole workspace, and the checker proven on small trees.

No node file over 400 lines, no import circle among production modules, every console script
resolves, every import of a workspace package declared in package.xml, no parameter section
built outside the configuration loader and its listed exceptions (:mod:`structure`).
"""

import pytest
from package_tree import write_package
import structure
from ros_test_support import REPO_ROOT

SOURCE = REPO_ROOT / 'ros2_ws' / 'src'


def test_no_node_file_is_over_400_lines():
    found = structure.long_node_files(SOURCE)
    assert not found, '\n'.join(found)


def test_no_import_circle_among_the_production_modules():
    found = structure.import_circles(SOURCE)
    assert not found, 'import circles:\n' + '\n'.join(found)


def test_every_console_script_names_a_function_that_is_there():
    found = structure.unresolved_console_scripts(SOURCE)
    assert not found, '\n'.join(found)


def test_every_workspace_package_a_package_imports_is_declared_in_its_package_xml():
    found = structure.undeclared_dependencies(SOURCE)
    assert not found, '\n'.join(found)


def test_no_production_module_builds_a_parameter_section_outside_the_loader():
    found = structure.direct_section_builds(SOURCE)
    assert not found, '\n'.join(found)


def test_every_section_a_node_declares_is_one_the_table_of_sections_lists():
    """A node that declares a section under another prefix, or one the table lacks, fails.

    A node cannot import the table (walker_config depends on every node package).
    """
    import importlib

    from walker_config.core.sections import SECTIONS

    def value(reference):
        module, name = reference
        return name if module is None else getattr(importlib.import_module(module), name)

    table = {(row.section, row.section_prefix) for row in SECTIONS}
    declarations = structure.section_declarations(SOURCE)
    declared = set()
    for declaration in declarations:
        section, prefix = value(declaration.section), value(declaration.prefix)
        assert (section, prefix) in table, \
            f'{declaration.where}: {section} under {prefix!r} is not a row of the table'
        declared.add((section, prefix))
    assert len(declarations) > 10 and declared == table, 'a section that no node declares'


def test_the_checks_see_the_workspace():
    """The rules above are not passing on an empty walk: they find the packages and scripts."""
    scripts = [s for setup in SOURCE.glob('*/setup.py')
               for s in structure._console_scripts(setup)]
    assert ('control_analysis', 'walker_control.analysis.command', 'main') in scripts
    assert len(scripts) > 10
    assert structure.long_node_files(SOURCE, limit=100)  # nodes are found, and measured
    # the listed section builders do build sections: without the list they are all found
    builders = structure.direct_section_builds(SOURCE, allowed={})
    assert {f.split(': ')[1].split()[0] for f in builders} \
        == set(structure.SECTION_BUILDERS)


@pytest.fixture
def clean_tree(tmp_path):
    write_package(tmp_path, 'walker_core', {'model.py': 'import numpy\n'})
    write_package(tmp_path, 'demo', {
        'core/__init__.py': '',
        'core/law.py': 'from walker_core import model\nfrom . import helpers\n',
        'core/helpers.py': 'import math\n',
        'demo_node.py': 'import rclpy\nfrom demo.core import law\n' + 'x = 1\n' * 300,
    }, depends=('walker_core',))
    return tmp_path


def test_a_clean_tree_passes_every_rule(clean_tree):
    assert structure.long_node_files(clean_tree) == []
    assert structure.import_circles(clean_tree) == []
    assert structure.unresolved_console_scripts(clean_tree) == []
    assert structure.undeclared_dependencies(clean_tree) == []
    assert structure.direct_section_builds(clean_tree, allowed={}) == []


def test_a_node_file_over_400_lines_fails(clean_tree):
    node = clean_tree / 'demo' / 'demo' / 'demo_node.py'
    assert len(node.read_text().splitlines()) == 302
    node.write_text(node.read_text() + 'x = 1\n' * 98)
    assert structure.long_node_files(clean_tree) == []  # 400 lines are allowed
    node.write_text(node.read_text() + 'x = 1\n')
    assert [str(node) in f and '401 lines' in f for f in structure.long_node_files(clean_tree)] \
        == [True]
    # a long module that defines a Node is a node file too, whatever its name
    shell = clean_tree / 'demo' / 'demo' / 'shell.py'
    shell.write_text('from rclpy.node import Node\nclass Shell(Node):\n    pass\n'
                     + 'x = 1\n' * 400)
    assert any(str(shell) in f for f in structure.long_node_files(clean_tree))


@pytest.mark.parametrize('relative, text, circle', [
    ('demo/demo/core/helpers.py', 'from demo.core import law\n',
     'demo.core.helpers -> demo.core.law -> demo.core.helpers'),
    ('demo/demo/core/helpers.py', 'def later():\n    from .law import x\n',
     'demo.core.helpers -> demo.core.law -> demo.core.helpers'),
    ('walker_core/walker_core/model.py', 'import demo.demo_node\n',
     'demo.core.law -> walker_core.model -> demo.demo_node -> demo.core.law'),
])
def test_an_import_circle_fails(clean_tree, relative, text, circle):
    path = clean_tree / relative
    path.write_text(path.read_text() + text)
    assert structure.import_circles(clean_tree) == [circle]


def test_a_console_script_without_its_function_or_module_fails(clean_tree):
    (clean_tree / 'demo' / 'demo' / 'tool.py').write_text('def run():\n    return 0\n')
    found = structure.unresolved_console_scripts(clean_tree)
    assert len(found) == 1 and 'demo_tool = demo.tool:main' in found[0] \
        and 'defines no main' in found[0]
    (clean_tree / 'demo' / 'demo' / 'tool.py').unlink()
    found = structure.unresolved_console_scripts(clean_tree)
    assert len(found) == 1 and 'no module demo.tool' in found[0]


def test_an_undeclared_workspace_import_fails_even_inside_a_function(clean_tree):
    write_package(clean_tree, 'other', {})
    helpers = clean_tree / 'demo' / 'demo' / 'core' / 'helpers.py'
    helpers.write_text('def later():\n    from other import tool\n')
    found = structure.undeclared_dependencies(clean_tree)
    assert len(found) == 1 and 'demo imports other' in found[0] and str(helpers) in found[0]
    manifest = clean_tree / 'demo' / 'package.xml'
    manifest.write_text(manifest.read_text().replace(
        '</package>', '<depend>other</depend></package>'))
    assert structure.undeclared_dependencies(clean_tree) == []


@pytest.mark.parametrize('text', [
    'from walker_core.parameter_file import ParameterFile\n'
    'from walker_core.robot_parameters import WalkerParameters\n'
    'def robot():\n    return ParameterFile.read().section(WalkerParameters)\n',
    'from walker_core import robot_parameters\n'
    'ROBOT = robot_parameters.load_walker_parameters()\n',
    'from walker_core.robot_parameters import WalkerParameters\n'
    'def robot(flat):\n    return WalkerParameters.from_flat(flat)\n',
])
def test_a_section_built_outside_the_loader_fails(clean_tree, text):
    helpers = clean_tree / 'demo' / 'demo' / 'core' / 'helpers.py'
    helpers.write_text(text)
    found = structure.direct_section_builds(clean_tree, allowed={})
    assert len(found) == 1 and f'{helpers}:' in found[0] \
        and 'demo.core.helpers builds a parameter section itself' in found[0]
    # the loader and the listed exceptions may; a listed module that is gone is said
    assert structure.direct_section_builds(
        clean_tree, allowed={'demo.core.helpers': 'the loader'}) == []
    assert structure.direct_section_builds(
        clean_tree, allowed={'demo.core.helpers': 'the loader', 'demo.gone': 'why'}) == [
        'demo.gone: listed as a section builder (why) but not in the workspace']


def test_a_section_declaration_is_traced_to_the_names_it_imports(clean_tree):
    node = clean_tree / 'demo' / 'demo' / 'demo_node.py'
    node.write_text('from walker_core.model import Section, PREFIX\n'
                    'from .core import law\n'
                    'declare_section(self, Section)\n'
                    'declare_section(self, Section, PREFIX)\n'
                    "guard_section_updates(self, law.Other, 'other.', None, None)\n")
    found = [(d.section, d.prefix) for d in structure.section_declarations(clean_tree)]
    assert found == [(('walker_core.model', 'Section'), (None, '')),
                     (('walker_core.model', 'Section'), ('walker_core.model', 'PREFIX')),
                     ((None, None), (None, 'other.'))]
