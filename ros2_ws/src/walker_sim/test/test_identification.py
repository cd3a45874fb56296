"""The modes measured on the simulated plant are the paper's: 18 rad/s at J1, 80 at J2-J3.

Measured as a lab would: strike the joint, hold all five, read the torque at its brake.
"""

import json

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
    assert abs(result.error) <= 0.10, format_table(list(measured.values()))


@pytest.mark.parametrize('joint', IDENTIFIED_JOINTS)
def test_the_measurement_agrees_with_the_linearised_model(measured, tuning, joint):
    """Simulation and the eigen-analysis the springs were sized with are independent."""
    assert measured[joint].seen.frequency == pytest.approx(tuning.predicted[joint], rel=0.02)


@pytest.mark.parametrize('joint', IDENTIFIED_JOINTS)
def test_the_measured_free_joint_resonance_agrees_with_the_model(measured, tuning, joint):
    free = measured[joint].free_joint
    assert free is not None
    assert free.frequency == pytest.approx(tuning.free_joint[joint], rel=0.02)
    assert free.frequency > measured[joint].seen.frequency


@pytest.mark.parametrize('joint', IDENTIFIED_JOINTS)
def test_the_measured_damping_is_the_parameter_files(measured, params, joint):
    """The seen modes sit at their targets, where the damping ratio is the file's."""
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
    assert [m.weight for m in fitted] == pytest.approx(
        [a / Excitation().spectrum(w) for w, _, a in modes], rel=1e-6)


def test_the_fit_leaves_out_transients_and_what_sampling_cannot_resolve():
    """A pole damped near 1 (the brakes catching) or near Nyquist is not a mode."""
    time = np.arange(1, 2001) * 0.002
    nyquist = np.pi / 0.002
    parts = [(18.0, 0.02, 0.3), (200.0, 0.9, 2.0), (0.97 * nyquist, 0.01, 0.05)]
    signal = sum(a * np.exp(-z * w * time) * np.cos(w * np.sqrt(1 - z * z) * time)
                 for w, z, a in parts)
    fitted = fit_modes(time[:1400], signal[:1400], rank_tolerance=1e-6)
    assert [round(m.frequency, 3) for m in fitted] == [18.0]
    assert fitted[0].weight == fitted[0].amplitude  # no excitation: the amplitude decides


def test_a_response_that_does_not_ring_is_reported():
    time = np.arange(1, 501) * 0.002
    with pytest.raises(ValueError, match='nothing rang'):
        fit_modes(time, 0.01 + 0.0 * time)


@pytest.mark.parametrize('time, signal, message', [
    (np.arange(5) * 0.002, np.zeros(5), 'at least 10'),
    (np.arange(20) * 0.002, np.zeros(19), 'at least 10'),
    (np.arange(20) * 0.002, np.r_[np.zeros(19), np.nan], 'non-finite'),
    (np.r_[np.arange(19) * 0.002, 1.0], np.zeros(20), 'uniformly'),
])
def test_a_malformed_record_is_refused(time, signal, message):
    with pytest.raises(ValueError, match=message):
        fit_modes(time, signal)


def test_unknown_joints_and_bad_excitations_are_refused(params, sim):
    with pytest.raises(ValueError, match='unknown joints'):
        identify_modes(params, sim, joints=('elbow_joint',))
    with pytest.raises(ValueError, match='duration'):
        Excitation(duration=-1.0)


def test_the_command_line_tool_writes_json_and_passes(tmp_path, capsys):
    path = tmp_path / 'modes.json'
    assert main(['--duration', '2.0', '--no-free-joint', '--json', str(path)]) == 0
    out = capsys.readouterr().out
    assert 'a_yaw_joint' in out and 'vertex_joint' in out
    document = json.loads(path.read_text())
    assert [j['joint'] for j in document['joints']] == list(IDENTIFIED_JOINTS)
    assert all(abs(j['error']) <= 0.10 for j in document['joints'])


def test_the_command_line_tool_refuses_a_bad_duration(capsys):
    assert main(['--duration', '0']) == 2
    assert 'duration' in capsys.readouterr().err
