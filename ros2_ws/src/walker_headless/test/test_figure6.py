"""``ros2 run walker_headless figure6``: the Figure 6 experiment's command (the model here)."""

from ros_test_support import write_parameter_file

from walker_core.parameter_file import default_values
from walker_headless import figure6


def test_the_figure6_command_prints_the_table_and_draws_the_figure(tmp_path, capsys):
    assert figure6.main(['--model', 'two-mass', '--out', str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert 'Figure 6 on the two-mass model of joint 1 (NOT the plant)' in out
    rows = [line for line in out.splitlines() if line.lstrip().startswith('0.')]
    assert len(rows) == 2  # Ka = 0 and the file's Ka
    assert (tmp_path / 'figure6.png').stat().st_size > 10_000


def test_the_figure6_command_refuses_a_bad_parameter_file(tmp_path, capsys):
    path = tmp_path / 'bad.yaml'
    path.write_text('/**:\n  ros__parameters:\n    robot: {}\n')
    assert figure6.main(['--model', 'two-mass', '--params-file', str(path),
                         '--out', str(tmp_path)]) == 2
    assert capsys.readouterr().out.startswith('refused:')
    assert not (tmp_path / 'figure6.png').exists()


def test_the_figure6_command_refuses_a_file_that_breaks_a_rule_between_sections(tmp_path, capsys):
    """Refused as ``run_all.py`` refuses it: the supervisor's regions against the gripper's."""
    values = dict(default_values())
    values.update({'supervisor.insertion_alignment': 0.004,
                   'supervisor.coarse_to_fine_region': 0.01, 'supervisor.descent_region': 0.005,
                   'supervisor.descent_axis_tolerance': 0.006, 'supervisor.search_radius': 0.006})
    path = write_parameter_file(tmp_path / 'walker.yaml', values)
    assert figure6.main(['--model', 'two-mass', '--params-file', str(path),
                         '--out', str(tmp_path)]) == 2
    out = capsys.readouterr().out
    assert out.startswith('refused:') and 'gripper.insertion_position_tolerance' in out
    assert not (tmp_path / 'figure6.png').exists()
