"""``walk_report`` on the command line: what it prints, its progress, its refusals."""

import io
import shutil

import pytest

from walker_report.progress import ProgressLine
from walker_report.walk_report import main

from synthetic_walk import STEPS

SMALL = ['--fps', '1', '--frame-size', '96x64']


def test_it_prints_the_step_table_and_the_paths_written(tmp_path, walk_bag, capsys):
    out = tmp_path / 'report'
    assert main([str(walk_bag), '--out', str(out), *SMALL]) == 0
    printed = capsys.readouterr().out
    for step in STEPS:
        assert f'{step.from_node} -> {step.to_node}' in printed
    assert f'report: {out / "report.md"}' in printed
    assert f'animation: {out / "walk.gif"}' in printed
    assert 'tip vibration near each target' in printed
    assert '[walk_report] reading the bag' in printed  # progress, since not quiet
    assert '[walk_report] rendering the animation' in printed


def test_quiet_prints_the_summary_without_progress(tmp_path, walk_bag, capsys):
    assert main([str(walk_bag), '--out', str(tmp_path / 'r'), '--quiet', '--no-animation']) == 0
    printed = capsys.readouterr().out
    assert '[walk_report]' not in printed
    assert 'n2_1 -> n1_2' in printed and 'report: ' in printed
    assert 'animation:' not in printed and not (tmp_path / 'r' / 'walk.gif').exists()


def test_a_cut_bag_is_refused_with_the_recovery_command(tmp_path, walk_bag, capsys):
    cut = tmp_path / 'cut'
    shutil.copytree(walk_bag, cut)
    mcap = cut / 'bag_0.mcap'
    mcap.write_bytes(mcap.read_bytes()[:-100])
    assert main([str(cut), '--out', str(tmp_path / 'r')]) == 2
    error = capsys.readouterr().err
    assert 'walk_report: error:' in error and f'bag_info {cut} --recover' in error
    assert not (tmp_path / 'r').exists()


@pytest.mark.parametrize(('arguments', 'message'), [
    (['--fps', '-2'], 'expected a positive number'),
    (['--fps', 'fast'], 'expected a positive number'),
    (['--max-frames', '0'], 'expected a positive number'),
    (['--frame-size', '640'], 'expected WIDTHxHEIGHT'),
    (['--frame-size', '20x20'], 'frame width must be 64 to 4096'),
    (['--fps', '200'], '0.1 to 50 frames per second'),
    (['--settle-time', '0'], 'expected a positive number'),
    (['--unknown'], 'unrecognized arguments'),
])
def test_malformed_arguments_are_refused_with_the_reason(tmp_path, walk_bag, capsys,
                                                         arguments, message):
    try:
        code = main([str(walk_bag), '--out', str(tmp_path / 'r'), *arguments])
    except SystemExit as exit_:  # argparse's own refusal
        code = exit_.code
    assert code == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / 'r').exists()


def test_a_missing_bag_is_refused(tmp_path, capsys):
    assert main([str(tmp_path / 'nothing')]) == 2
    assert 'is not a bag directory' in capsys.readouterr().err


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_progress_is_a_line_on_a_terminal_and_sparse_in_a_log():
    terminal = _Terminal()
    line = ProgressLine(stream=terminal)
    for k in range(101):
        line('rendering', k, 100)
    text = terminal.getvalue()
    assert text.count('\n') == 1 and text.endswith('rendering [########################] '
                                                   '100/100\n')
    log = io.StringIO()
    line = ProgressLine(stream=log)
    for k in range(101):
        line('rendering', k, 100)
    assert log.getvalue().splitlines() == [f'rendering: {k}/100' for k in (0, 25, 50, 75, 100)]
    quiet = io.StringIO()
    ProgressLine(quiet=True, stream=quiet)('rendering', 1, 2)
    assert quiet.getvalue() == ''
