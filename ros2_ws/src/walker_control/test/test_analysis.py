"""The analysis tool: eq (15) over a grid, Figure 5's figures of merit, the Figure 6 harness."""

import math
import types

import numpy as np
import pytest
from numpy.polynomial import polynomial as npp
from walker_control.analysis import bode, command, figure6, routh
from walker_control.analysis.floor import sweep_floors
from walker_control.core.config import load_controller_settings
from walker_control.core.stability import eq14_transfer_function, eq15_margin

SETTINGS = load_controller_settings()


def test_eq15_routh_and_poles_agree_over_a_grid():
    result = routh.routh_grid(np.linspace(0.0, 3.0, 7), np.linspace(0.1, 2.0, 12),
                                 (0.5, 1.0, 2.0))
    assert result.points == 7 * 12 * 3
    assert 0 < result.stable < result.points - result.marginal
    assert result.eq15_disagreements == [] and result.routh_disagreements == []


def test_the_sampled_loop_departs_from_eq15_only_near_the_boundary_when_wc_t_is_small():
    # wf = 3 rad/s at T = 2 ms: wc T <= 0.012, sampling costs little phase.
    result = routh.routh_grid(np.linspace(0.0, 3.0, 7), np.linspace(0.1, 2.0, 12),
                                 (0.5, 1.0, 2.0), wf=3.0)
    assert all(abs(margin) < 0.05 for *_, margin, _wct in result.sampled_disagreements)


@pytest.mark.parametrize('feedforward', [True, False])
def test_figure5_curves_have_unit_dc_gain_and_a_consistent_bandwidth(feedforward):
    for curve in bode.figure5_curves(feedforward=feedforward):
        assert abs(curve.magnitude_db[0]) < 0.01
        index = np.searchsorted(curve.frequency, curve.bandwidth)
        assert curve.magnitude_db[index] < -3.0 <= curve.magnitude_db[index - 1]
        assert np.all(curve.magnitude_db[:index] >= -3.0)
        assert curve.peak_db == pytest.approx(max(0.0, curve.magnitude_db.max()))


def exact_minus_3db_crossing(numerator, denominator):
    """Smallest w > 0 with |N(jw)|^2 = 10^-0.3 |D(jw)|^2: polynomial roots, no grid."""
    def squared_magnitude(coefficients):  # ascending powers of w of |P(jw)|^2
        ascending = np.asarray(coefficients, dtype=complex)[::-1] * 1j ** np.arange(
            len(coefficients))
        return npp.polymul(ascending, np.conj(ascending)).real
    gap = npp.polysub(squared_magnitude(numerator),
                      10 ** -0.3 * squared_magnitude(denominator))
    roots = npp.polyroots(gap)
    return min(r.real for r in roots if abs(r.imag) < 1e-9 and r.real > 0)


def test_figure5_bandwidth_is_the_exact_minus_3db_crossing_not_a_grid_point():
    for curve in bode.figure5_curves():
        numerator, denominator = eq14_transfer_function(1.0, 1.0, bode.FIGURE5_RATIO,
                                                        curve.ka)
        assert curve.bandwidth == pytest.approx(
            exact_minus_3db_crossing(numerator, denominator), rel=1e-9)
    assert bode.figure5_curves(ka_values=(1.0,))[0].bandwidth == pytest.approx(2.6935,
                                                                                   abs=1e-4)


@pytest.mark.parametrize('ka', [0.0, 0.5, 1.0])
def test_achievable_ratio_respects_eq15_and_the_peak_limit(ka):
    ratio, bandwidth = bode.achievable_ratio(ka)
    assert ratio > 0.0 and eq15_margin(ratio, 1.0, 1.0, ka) > 0.0
    numerator, denominator = eq14_transfer_function(ratio, 1.0, 1.0, ka)
    w = np.logspace(-3, 2, 4000)
    from scipy import signal
    _, response = signal.freqs(numerator, denominator, worN=w)
    assert 20 * np.log10(np.abs(response)).max() <= bode.PEAK_LIMIT_DB + 1e-9
    assert bandwidth > 0.0


def test_figure6_harness_runs_on_any_plant_core():
    """The experiment's mechanics on the two-mass model; the claim itself needs the plant."""
    run = figure6.figure6_experiment(lambda: figure6.TwoMassJoint1Model(SETTINGS), SETTINGS,
                                      0.5, distance=0.3, move_time=2.0, settle_time=2.0)
    assert len(run.time) == len(run.joint1) == len(run.tip_deviation) == 2000
    assert run.tip_position.shape == (2000, 3)
    assert run.ka == 0.5 and math.isfinite(run.residual_amplitude)
    assert abs(run.joint1[-1] - 0.3) < 0.05 * 0.3
    # the model's joint sticks at the target and its link rings at the model's 18 rad/s
    assert run.joint1_motion == 0.0
    assert run.residual_frequency == pytest.approx(
        SETTINGS.robot.flexibility.joint1_mode, rel=0.05)


class LateArrival:
    """A plant core whose tip creeps in late: 1 mm off for 2 s of the window, then at rest."""

    rest = np.array([0.0, 0.9, 0.03])

    def reset(self):
        self.time = 0.0

    def step(self, torques, dt):
        self.time += dt

    def state(self):
        offset = 1e-3 if self.time < 3.5 else 0.0
        zeros = np.zeros(5)
        return types.SimpleNamespace(position=zeros, velocity=zeros, acceleration=zeros,
                                     tip_position=self.rest + [offset, 0.0, 0.0])


def test_figure6_residual_is_measured_from_where_the_tip_ends():
    # the window runs from 1.5 s to 4 s; a mean over it would sit 0.8 mm out, the rest is 0
    run = figure6.figure6_experiment(LateArrival, SETTINGS, 0.0, move_time=1.0,
                                      settle_time=3.0, allowance=0.5)
    assert run.residual_amplitude == pytest.approx(1e-3, rel=1e-9)
    assert run.tip_deviation[-1] == pytest.approx(0.0, abs=1e-12)


def test_dominant_frequency_finds_the_peak_of_a_moving_point():
    time = np.arange(2500) * 0.002
    direction = np.array([0.6, 0.8, 0.0])
    points = (np.outer(1e-3 * np.exp(-0.3 * time) * np.sin(17.3 * time), direction)
              + np.outer(1e-5 * np.sin(90.0 * time), [0.0, 0.0, 1.0]) + [0.2, 0.9, 0.03])
    assert figure6.dominant_frequency(time, points) == pytest.approx(17.3, rel=0.01)
    assert figure6.dominant_frequency(time, np.ones((2500, 3))) == 0.0
    with pytest.raises(ValueError, match='uniformly'):
        figure6.dominant_frequency(time[:5], points[:5])


def test_figure6_with_an_unstable_ka_is_refused():
    from walker_core.parameter_schema import ParameterError

    with pytest.raises(ParameterError, match='J1'):
        figure6.figure6_experiment(lambda: figure6.TwoMassJoint1Model(SETTINGS), SETTINGS,
                                    15.0)


def test_bode_command_writes_the_figure_and_the_table(tmp_path, capsys):
    assert command.main(['bode', '--out', str(tmp_path)]) == 0
    assert (tmp_path / 'figure5_bode.png').stat().st_size > 10_000
    out = capsys.readouterr().out
    assert '-3 dB bandwidth' in out and 'Ka' in out


def test_design_command_refuses_an_unstable_file(tmp_path, capsys):
    path = tmp_path / 'unstable.yaml'
    from walker_core.robot_parameters import default_parameter_file
    shipped = default_parameter_file().read_text()
    fine = 'bandwidth: [0.7, 5.0, 5.0, 8.0, 8.0]'  # the first is control.fine's, then hold's
    assert shipped.index('fine:') < shipped.index(fine) < shipped.index('hold:')
    path.write_text(shipped.replace(fine, 'bandwidth: [5.0, 5.0, 5.0, 8.0, 8.0]', 1))
    assert command.main(['design', '--params-file', str(path)]) == 2
    assert 'role J1, mode fine: the discrete closed loop is unstable' in capsys.readouterr().out


def test_joint_1s_sweeps_are_slower_through_its_filter_and_the_half_turn_slower_still():
    settings = load_controller_settings()
    floors = sweep_floors(settings, 0.9, 0.0005, sample_time=0.02)
    assert [floor.sweep for floor in floors] == [90.0, 180.0]
    for floor in floors:
        # the unfiltered sweep is the rate-and-torque bang-coast-bang, a little early by the
        # band it may enter before the end
        assert 0.0 < floor.unfiltered < floor.filtered
    assert floors[0].filtered < floors[1].filtered


def test_floor_command_prints_the_sweeps(capsys):
    assert command.main(['floor', '--tolerance', '0.001']) == 0
    out = capsys.readouterr().out
    assert "Joint 1's fastest sweep with the tip at 0.9 m" in out and '1 mm' in out
    assert [line.split('|')[0].strip() for line in out.splitlines()[2:]] == ['90', '180']


@pytest.mark.parametrize('option, value', [('--tolerance', '-1'), ('--tolerance', '0'),
                                           ('--radius', '-0.5'), ('--radius', 'nan')])
def test_floor_command_refuses_a_bad_radius_or_tolerance(option, value, capsys):
    with pytest.raises(SystemExit) as exit_info:
        command.main(['floor', option, value])
    assert exit_info.value.code == 2
    assert 'expected a finite number > 0' in capsys.readouterr().err


def test_floor_command_refuses_a_tip_out_of_reach(capsys):
    assert command.main(['floor', '--radius', '5']) == 2
    out = capsys.readouterr().out
    assert out.startswith('refused:') and 'out of reach' in out
