"""The modes measured on the simulated plant are the paper's: 18 rad/s at J1, 80 at J2-J3."""

import numpy as np
import pytest

from walker_sim.core.flexibility import IDENTIFIED_JOINTS
from walker_sim.core.identification import Excitation, fit_modes, identify_modes
from walker_sim.identify_modes import format_table, main


@pytest.fixture(scope='module')
def measured(params, sim):
    return {result.joint: result for result in identify_modes(params, sim)}


@pytest.mark.parametrize('joint', IDENTIFIED_JOINTS)
def test_the_mode_seen_at_each_joint_is_within_ten_percent_of_the_paper(measured, joint):
    result = measured[joint]
    assert result.target is not None
    assert abs(result.error) <= 0.10, format_table(list(measured.values()), {})


@pytest.mark.parametrize('joint', IDENTIFIED_JOINTS)
def test_the_measurement_agrees_with_the_linearised_model(measured, tuning, joint):
    """Simulation and the eigen-analysis the springs were sized with are independent."""
    assert measured[joint].seen.frequency == pytest.approx(tuning.predicted[joint], rel=0.02)


@pytest.mark.parametrize('joint', IDENTIFIED_JOINTS)
def test_the_measured_damping_is_the_parameter_files(measured, params, joint):
    """The seen modes sit near their targets, where the damping ratio is the file's."""
    assert measured[joint].seen.damping == pytest.approx(
        params.robot.flexibility.damping_ratio, rel=0.25)


def test_joint_1_sees_the_lower_mode_than_joints_2_and_3(measured):
    yaw, pitch, vertex = (measured[j].seen.frequency for j in IDENTIFIED_JOINTS)
    assert yaw < 0.5 * min(pitch, vertex)


def test_the_fit_recovers_known_modes_from_a_synthetic_response():
    time = np.arange(1, 2001) * 0.002
    modes = [(18.0, 0.02, 0.003), (80.0, 0.05, 0.02)]
    signal = 0.01 + sum(a * np.exp(-z * w * time) * np.sin(w * np.sqrt(1 - z * z) * time + 0.3)
                        for w, z, a in modes)
    fitted = fit_modes(time, signal, Excitation())
    assert [round(m.frequency, 6) for m in fitted] == [18.0, 80.0]
    assert [round(m.damping, 6) for m in fitted] == [0.02, 0.05]
    assert [m.amplitude for m in fitted] == pytest.approx([0.003, 0.02], rel=1e-6)


def test_a_response_that_does_not_ring_is_reported():
    time = np.arange(1, 501) * 0.002
    with pytest.raises(ValueError, match='nothing rang'):
        fit_modes(time, 0.01 + 0.0 * time)


def test_the_command_line_tool_writes_json_and_passes(tmp_path, capsys):
    assert main(['--duration', '2.0', '--json', str(tmp_path / 'modes.json')]) == 0
    out = capsys.readouterr().out
    assert 'a_yaw_joint' in out and 'vertex_joint' in out
    assert (tmp_path / 'modes.json').read_text().count('seen_rad_s') == 3
