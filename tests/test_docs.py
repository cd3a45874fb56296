"""The documentation: an entry page, links that lead somewhere, no history outside the log.

And the parameter reference: generated from the schema, current, one line per description, a
source for every value, one short comment per value in the parameter file.
"""

import importlib.util
import io
import re
import subprocess
import tokenize
from functools import cache
from pathlib import Path

import pytest
import yaml

from ros_test_support import REPO_ROOT

README = REPO_ROOT / 'README.md'
DOCS = REPO_ROOT / 'docs'
HISTORY = DOCS / 'performance_log.md'
PARAMETER_FILE = REPO_ROOT / 'ros2_ws' / 'src' / 'walker_core' / 'config' / 'walker.yaml'

#: An ISO 8601 date, and a commit hash (7 to 40 hex digits with a digit and a letter in them).
ISO_DATE = re.compile(r'\b\d{4}-\d{2}-\d{2}\b')
COMMIT_HASH = re.compile(r'(?<![\w./-])(?=[0-9a-f]*\d)(?=[0-9a-f]*[a-f])[0-9a-f]{7,40}(?![\w])')

#: Every section the README had before it became an entry page, and where it lives now: the
#: README links to each place, so that every one of them is a click away.
FORMER_README_SECTIONS = {
    'Quick start': 'README.md#quick-start',
    'Layout': 'README.md#layout',
    'Walking': 'docs/walking.md',
    'The step': 'docs/walking.md#the-step',
    'The public interface': 'README.md#the-public-interface-namespace-walker',
    'Supervisor parameters': 'docs/walking.md#the-supervisors-settings-and-what-they-trade',
    'Teleoperation': 'docs/teleoperation.md',
    'The robot model': 'docs/robot_model.md',
    'Parameter file': 'docs/robot_model.md#the-parameter-file',
    'Kinematics and dynamics': 'docs/robot_model.md#kinematics-and-dynamics',
    'Recording walks': 'docs/recording.md#recording-walks-walker_bag',
    'The walk report': 'docs/recording.md#the-walk-report-walker_report',
    'The joint controllers': 'docs/controllers.md',
    'Structure (Figure 3)': 'docs/controllers.md#structure-figure-3-and-where-each-term-sits',
    'Modes, roles and bumpless transfer': 'docs/controllers.md#modes-roles-and-bumpless-transfer',
    'The stability check': 'docs/controllers.md#the-stability-check',
    'Parameters added (control)': 'docs/controllers.md#tuning-the-shipped-values-and-why',
    'The node (joint_controller_node)': 'docs/controllers.md#the-node-joint_controller_node',
    'The five joints in one node':
        'docs/controllers.md#the-five-joints-in-one-node-joint_controllers_node',
    'Analysis (control_analysis)': 'docs/controllers.md#analysis-control_analysis',
    'Performance (of the controllers)': 'docs/controllers.md#cost',
    'URDF': 'docs/robot_model.md#urdf',
    'The plant': 'docs/plant.md',
    'What it models': 'docs/plant.md#what-it-models',
    'Node interfaces (as built)': 'docs/plant.md#node-interfaces',
    'Parameters it adds (sim)': 'docs/plant.md#its-parameters',
    'The modes, measured': 'docs/plant.md#the-modes-measured',
    'Images': 'docs/plant.md#images',
    'Benchmark (of the plant)': 'docs/plant.md#benchmark',
    'Interfaces (walker_msgs)': 'docs/architecture.md#interfaces-walker_msgs',
    'The planner': 'docs/planner.md',
    'The nine types': 'docs/planner.md#the-nine-types',
    'The bang-bang node-to-node trajectory':
        'docs/planner.md#the-bang-bang-node-to-node-trajectory-paper-section-5',
    'Figures': 'docs/planner.md#figures',
    'The planner node': 'docs/planner.md#the-planner-node',
    'Parameters added (planner)': 'docs/planner.md#its-parameters',
    'Benchmark (of the planner)': 'docs/planner.md#benchmark',
    'Performance': 'docs/performance.md',
    'The figures': 'docs/performance.md#the-benchmark-table',
    'What bounds each figure': 'docs/performance.md#what-bounds-each-figure',
    'Faults and how the walker survives them': 'docs/faults.md',
    'The fault matrix': 'docs/faults.md#the-fault-matrix-every-node-at-every-phase',
    'Injecting faults yourself': 'docs/faults.md#injecting-faults-yourself',
    'Tests': 'docs/testing.md',
    'Known limits': 'README.md#known-limits',
}


def _markdown_files() -> list[Path]:
    return [README, *sorted(DOCS.glob('*.md'))]


def _without_code(text: str) -> str:
    """Return the text without fenced code blocks and inline code (links there are examples)."""
    text = re.sub(r'^```.*?^```', '', text, flags=re.MULTILINE | re.DOTALL)
    return re.sub(r'`[^`\n]*`', '', text)


def github_anchor(heading: str) -> str:
    """Return the anchor GitHub gives a heading: lower case, no punctuation, hyphens."""
    text = re.sub(r'\[([^\]]*)\]\([^)]*\)', r'\1', heading.strip())
    text = re.sub(r'[^\w\- ]', '', text.lower().replace('`', ''))
    return text.replace(' ', '-')


@cache
def anchors(path: Path) -> frozenset[str]:
    """Every anchor of a Markdown file (a heading repeated gets -1, -2, ... as on GitHub)."""
    text = re.sub(r'^```.*?^```', '', path.read_text(), flags=re.MULTILINE | re.DOTALL)
    seen: dict[str, int] = {}
    found = set()
    for heading in re.findall(r'^#{1,6} (.+)$', text, flags=re.MULTILINE):
        anchor = github_anchor(heading)
        count = seen.get(anchor, 0)
        seen[anchor] = count + 1
        found.add(anchor if count == 0 else f'{anchor}-{count}')
    return frozenset(found)


def links(path: Path) -> list[str]:
    """Every link target of a Markdown file, outside code."""
    return re.findall(r'\]\(([^)\s]+)\)', _without_code(path.read_text()))


def _relative(target: str) -> bool:
    return not re.match(r'[a-z][a-z0-9+.-]*:', target)


def test_the_readme_is_an_entry_page():
    lines = README.read_text().splitlines()
    assert len(lines) <= 300, f'README.md has {len(lines)} lines; the reference goes to docs/'
    long = [f'{number}: {len(line)} characters' for number, line in enumerate(lines, 1)
            if len(line) > 200]
    assert not long, f'README.md lines over 200 characters: {long}'


@pytest.mark.parametrize('path', _markdown_files(), ids=lambda p: p.name)
def test_every_relative_link_resolves_and_every_anchor_exists(path):
    broken = []
    for target in links(path):
        if not _relative(target):
            continue
        file_part, _, anchor = target.partition('#')
        linked = (path.parent / file_part).resolve() if file_part else path
        if not linked.exists():
            broken.append(f'{target}: no such file')
        elif anchor and linked.suffix == '.md' and anchor not in anchors(linked):
            broken.append(f'{target}: no heading with the anchor #{anchor} in {linked.name}')
    assert not broken, f'{path.name}: ' + '; '.join(broken)


def test_the_anchor_rule_is_githubs():
    assert github_anchor('The node (`joint_controller_node`)') == 'the-node-joint_controller_node'
    assert github_anchor("The supervisor's settings, and what they trade") == \
        'the-supervisors-settings-and-what-they-trade'
    assert github_anchor('Structure (Figure 3) and where each term sits') == \
        'structure-figure-3-and-where-each-term-sits'


@pytest.mark.parametrize('section, place', sorted(FORMER_README_SECTIONS.items()))
def test_every_former_readme_section_is_one_click_from_the_readme(section, place):
    file_part, _, anchor = place.partition('#')
    target = (anchor and f'#{anchor}') if file_part == 'README.md' else place
    assert target in links(README), f'the README does not link to {place} ({section})'
    linked = REPO_ROOT / file_part
    assert linked.exists(), place
    assert not anchor or anchor in anchors(linked), place


def _comments_and_docstrings(path: Path) -> list[tuple[int, str]]:
    """Return the comments and docstrings of a Python file, with their line numbers."""
    found = []
    tokens = list(tokenize.generate_tokens(io.StringIO(path.read_text()).readline))
    previous = None
    for token in tokens:
        if token.type == tokenize.COMMENT:
            found.append((token.start[0], token.string))
        elif (token.type == tokenize.STRING and token.string.lstrip('rbuRBU')[:3] in ('"""', "'''")
              and (previous is None or previous.type in (tokenize.INDENT, tokenize.DEDENT,
                                                         tokenize.NEWLINE, tokenize.NL))):
            found.append((token.start[0], token.string))
        if token.type not in (tokenize.NL, tokenize.COMMENT):
            previous = token
    return found


def _tracked(*patterns: str) -> list[Path]:
    names = subprocess.run(['git', 'ls-files', *patterns], cwd=REPO_ROOT, check=True,
                           capture_output=True, text=True).stdout.split()
    return [REPO_ROOT / name for name in names if (REPO_ROOT / name).exists()]


def _history_in(text: str) -> list[str]:
    return ISO_DATE.findall(text) + COMMIT_HASH.findall(text)


def test_no_dates_or_commit_hashes_outside_the_performance_log():
    found = []
    for path in [p for p in _markdown_files() if p != HISTORY]:
        for number, line in enumerate(path.read_text().splitlines(), 1):
            found += [f'{path.name}:{number}: {hit}' for hit in _history_in(line)]
    for path in _tracked('*.yaml', '*.yml', '*.msg', '*.srv', '*.action', '*.toml', '*.cfg',
                         '*.txt', '*.xml', '.ci/*', 'scripts/walkerctl'):
        for number, line in enumerate(path.read_text().splitlines(), 1):
            found += [f'{path.relative_to(REPO_ROOT)}:{number}: {hit}'
                      for hit in _history_in(line)]
    for path in _tracked('*.py'):
        for number, text in _comments_and_docstrings(path):
            found += [f'{path.relative_to(REPO_ROOT)}:{number}: {hit}'
                      for hit in _history_in(text)]
    assert not found, ('dates and commit hashes belong in docs/performance_log.md and commit '
                       'messages: ' + '; '.join(found))


def test_the_history_patterns_catch_what_they_should():
    assert _history_in('measured on 2026-11-27 at commit 9c45fee') == ['2026-11-27', '9c45fee']
    assert not _history_in('0.5 mm, 1e-5, RIHS01_abc, deadbeef, walker_core, 1234567')


# The parameter reference ----------------------------------------------------------------


@cache
def _generator():
    spec = importlib.util.spec_from_file_location(
        'generate_parameter_docs', REPO_ROOT / 'scripts' / 'generate_parameter_docs.py')
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@cache
def _specs() -> dict:
    from walker_core.parameter_schema import leaf_specs

    return {spec.name: spec
            for group, prefix, section, _nodes in _generator()._load_sections()
            for spec in leaf_specs(section, prefix or f'{group}.')}


def test_the_parameter_reference_is_generated_from_the_schema_as_it_is():
    expected = _generator().render()
    current = (DOCS / 'parameters.md').read_text()
    assert current == expected, ('docs/parameters.md is out of date: run '
                                 'python3 scripts/generate_parameter_docs.py')


def test_the_reference_covers_every_value_of_the_parameter_file():
    from walker_core.parameter_schema import load_parameter_file

    in_file = set(load_parameter_file(PARAMETER_FILE))
    declared = set(_specs())
    assert in_file - declared == set(), 'values in walker.yaml that no section declares'
    assert declared - in_file == set(), 'declared parameters without a value in walker.yaml'


def test_every_parameter_has_a_one_line_description_and_a_source():
    bad = []
    for name, spec in _specs().items():
        if not spec.description or '\n' in spec.description or len(spec.description) > 100:
            bad.append(f'{name}: the description must be one line of at most 100 characters')
        if not re.match(r'(paper|chosen)\b', spec.source) or len(spec.source) > 100:
            bad.append(f'{name}: the source must say "paper ..." or "chosen ..." in at most '
                       f'100 characters, got {spec.source!r}')
    assert not bad, '; '.join(bad)


def _parameter_file_values() -> list[tuple[int, str, str]]:
    """(line number, dotted name, comment) of every value line of the parameter file."""
    values, path = [], []
    for number, line in enumerate(PARAMETER_FILE.read_text().splitlines(), 1):
        match = re.match(r'^( *)([\w/*]+):(.*)$', line)
        if not match:
            continue
        indent, key, rest = len(match.group(1)), match.group(2), match.group(3)
        path = [(i, k) for i, k in path if i < indent]
        value, _, comment = rest.partition('#')
        if value.strip():
            name = '.'.join([k for _, k in path[2:]] + [key])
            values.append((number, name, comment.strip()))
        else:
            path.append((indent, key))
    return values


def test_the_parameter_file_gives_each_value_one_short_comment_with_its_unit_and_source():
    specs = _specs()
    lines = PARAMETER_FILE.read_text().splitlines()
    values = _parameter_file_values()
    assert {name for _, name, _ in values} == set(specs)
    bad = []
    for number, name, comment in values:
        unit = specs[name].unit
        expected = f'[{unit}] ' if unit else ''
        if not comment.startswith(expected) or (not unit and comment.startswith('[')):
            bad.append(f'line {number} ({name}): the comment must start with {expected!r}')
        if not re.match(r'(paper|chosen)\b', comment[len(expected):]):
            bad.append(f'line {number} ({name}): the comment must say "paper" or "chosen"')
        if len(lines[number - 1]) > 99:
            bad.append(f'line {number} ({name}): longer than 99 characters')
    first_section = next(i for i, line in enumerate(lines) if not line.startswith('#'))
    continuations = [i + 1 for i, line in enumerate(lines[first_section:], first_section)
                     if line.lstrip().startswith('#')]
    if continuations:
        bad.append(f'comment-only lines inside the sections (lines {continuations}): one '
                   'short comment per value, the rest goes to docs/')
    assert not bad, '; '.join(bad)


def test_the_parameter_file_loads_as_it_reads():
    document = yaml.safe_load(PARAMETER_FILE.read_text())
    assert set(document) == {'/**'}
