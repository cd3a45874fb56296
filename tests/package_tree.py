"""Small ROS package trees written by tests of the workspace's structure checkers."""

import textwrap
from pathlib import Path

__all__ = ['write_package']


def write_package(root: Path, name: str, files: dict[str, str], depends=()) -> Path:
    """Write an ament_python package ``name`` under ``root``; return its directory.

    ``files`` maps a path relative to the Python package to its source; ``depends`` are the
    package.xml's ``exec_depend`` entries. The setup.py declares one console script,
    ``<name>_tool = <name>.tool:main``, and ``tool.py`` defines that ``main``.
    """
    package = root / name
    (package / name).mkdir(parents=True)
    tags = ''.join(f'<exec_depend>{d}</exec_depend>' for d in depends)
    (package / 'package.xml').write_text(
        f'<package format="3"><name>{name}</name>{tags}</package>\n')
    (package / 'setup.py').write_text(textwrap.dedent(f"""\
        from setuptools import setup
        setup(name='{name}', entry_points={{'console_scripts': [
            '{name}_tool = {name}.tool:main',
        ]}})
        """))
    (package / name / '__init__.py').write_text('')
    (package / name / 'tool.py').write_text('def main():\n    return 0\n')
    for relative, text in files.items():
        path = package / name / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(textwrap.dedent(text))
    return package
