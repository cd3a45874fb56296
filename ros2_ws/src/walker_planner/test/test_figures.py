"""The figures command writes Figures 8 and 9 (and the duration curve); the report prints."""

from ros_test_support import REPO_ROOT
from walker_planner.figures import FIGURE9_CASES, main

PNG_SIGNATURE = b'\x89PNG\r\n\x1a\n'


def test_one_command_writes_the_figures(tmp_path, capsys):
    assert main(['--out', str(tmp_path / 'figures')]) == 0
    written = sorted((tmp_path / 'figures').glob('*.png'))
    assert [p.name for p in written] == ['duration_vs_midpoint.png',
                                         'figure8_torques_and_trajectory.png',
                                         'figure9_family_180deg.png']
    printed = capsys.readouterr().out.split()
    for path in written:
        assert path.read_bytes()[:8] == PNG_SIGNATURE
        assert path.stat().st_size > 20_000  # drawn, not blank
        assert str(path) in printed


def test_figure9_shows_several_parameter_sets():
    assert len(FIGURE9_CASES) >= 6
    assert len({start for start, _ in FIGURE9_CASES}) >= 2
    assert any(start == mid for start, mid in FIGURE9_CASES)  # the circular trajectory too


def test_the_console_script_is_installed():
    script = REPO_ROOT / 'ros2_ws' / 'install' / 'walker_planner' / 'lib' / 'walker_planner'
    assert (script / 'planner_figures').exists() and (script / 'planner_node').exists()


def test_the_report_prints_the_solutions_and_the_simplification_errors(capsys):
    from walker_planner.report import main as report

    assert report([]) == 0
    out = capsys.readouterr().out
    for step in ('90 deg nominal', '90 deg family minimum', '180 deg nominal',
                 '180 deg family minimum'):
        assert f'| {step} | simplified |' in out and f'| {step} | full |' in out
        assert f'| {step} | lumped |' in out
