"""The control parameters: the file's design follows the paper, unstable sets are refused."""

import pytest

from walker_core.parameter_schema import (
    ParameterError, load_parameter_file, replace_in_section, section_to_flat)
from walker_core.robot_parameters import default_parameter_file
from walker_control.core.config import (
    ControllerSettings, UnstableControllerError, check_controller_settings,
    load_controller_settings)
from walker_control.core.modes import GAIN_MODES, Mode

DEFAULT_FLAT = load_parameter_file(default_parameter_file())
SETTINGS = load_controller_settings()


def with_overrides(**overrides):
    flat = dict(DEFAULT_FLAT)
    flat.update({name.replace('__', '.'): value for name, value in overrides.items()})
    return ControllerSettings.from_flat(flat)


def test_the_default_file_passes_the_stability_check_everywhere():
    reports = check_controller_settings(SETTINGS)
    assert set(reports) == {(role, mode) for role in range(1, 6) for mode in GAIN_MODES}
    minimum = SETTINGS.control.stability.minimum_damping
    for (role, _mode), report in reports.items():
        assert report.largest_pole_magnitude < 1.0
        assert report.smallest_damping >= minimum
        if role <= 3:  # Bessel filters: the poles judge them, eq (15) does not apply
            assert report.eq15_margin is None
            assert 'eq (15) does not apply' in report.stability_condition


def test_the_file_follows_the_paper_structure():
    control = SETTINGS.control
    assert control.coarse.acceleration_feedback[0] > 0.0
    assert all(ka == 0.0 for ka in control.coarse.acceleration_feedback[1:])
    for role in range(5):
        assert control.coarse.bandwidth[role] < control.fine.bandwidth[role]  # higher gains
        assert control.coarse.integral_time[role] == 0.0 < control.fine.integral_time[role]
        assert control.hold.integral_time[role] == 0.0
        assert control.fine.damping[role] == control.coarse.damping[role] == 1.0  # eq (16)
    # Friction compensation is the identified friction (the same parameter as the plant's).
    for role in range(1, 6):
        assert SETTINGS.friction_level(role) == pytest.approx(
            control.friction_compensation.fraction * SETTINGS.drive(role).stiction_torque)


def test_loop_design_per_role_and_mode():
    design = SETTINGS.loop_design(1, Mode.COARSE)
    assert design.acceleration_feedback == SETTINGS.control.coarse.acceleration_feedback[0]
    assert design.filter_order == SETTINGS.control.filter.order[0]
    assert SETTINGS.loop_design(1, Mode.FINE).acceleration_feedback == 0.0
    assert design.kp == pytest.approx(design.bandwidth ** 2)
    with pytest.raises(ValueError):
        SETTINGS.loop_design(6, Mode.FINE)
    with pytest.raises(ValueError):
        SETTINGS.loop_design(1, Mode.OFF)


def test_a_violation_of_eq15_is_refused_naming_role_mode_and_value():
    # eq (15) is the condition of the paper's filter: 2nd-order critically damped (J2, J3)
    fine = list(DEFAULT_FLAT['control.fine.bandwidth'])
    fine[1] = 13.0  # above wf / 2 = 12 rad/s
    refusal = r'role J2, mode fine.*eq \(15\).*0\.5 .*wc / wf = 0\.54.*control\.fine'
    with pytest.raises(UnstableControllerError, match=refusal):
        with_overrides(control__filter__kind='critical', control__fine__bandwidth=fine,
                       control__filter__corner=[8.0, 24.0, 24.0, 0.0, 0.0])


def test_too_fast_a_loop_behind_a_bessel_filter_is_refused_by_its_poles():
    with pytest.raises(UnstableControllerError,
                       match=r'role J1, mode fine.*unstable.*control\.fine'):
        with_overrides(control__fine__bandwidth=[5.0, 5.0, 5.0, 8.0, 8.0])


def test_an_unstable_sampled_loop_is_refused_where_eq15_says_nothing():
    with pytest.raises(UnstableControllerError, match=r'role J4, mode coarse.*unstable.*\|z\|'):
        with_overrides(control__coarse__acceleration_feedback=[0.5, 0.0, 0.0, 1.5, 0.0])


def test_a_poorly_damped_loop_is_refused():
    with pytest.raises(UnstableControllerError, match=r'role J1.*poorly damped'):
        with_overrides(control__stability__minimum_damping=0.4)


def test_a_refused_runtime_update_changes_nothing():
    before = section_to_flat(SETTINGS)
    with pytest.raises(UnstableControllerError):
        replace_in_section(SETTINGS, {'control.hold.bandwidth': [6.0, 5.0, 5.0, 8.0, 8.0]})
    assert section_to_flat(SETTINGS) == before
    updated = replace_in_section(SETTINGS, {'control.hold.bandwidth': [0.5, 5.0, 5.0, 8.0, 8.0]})
    assert updated.control.hold.bandwidth[0] == 0.5
    assert SETTINGS.control.hold.bandwidth[0] == 0.7


def test_a_filter_corner_above_nyquist_is_refused():
    with pytest.raises(ParameterError, match=r'role J1.*Nyquist'):
        with_overrides(timing__control_rate=10.0,
                       control__filter__corner=[40.0, 30.0, 30.0, 0.0, 0.0])


@pytest.mark.parametrize('name, value, words', [
    ('control.fine.damping', [1.0, 1.0, 1.0, 1.0], r'control\.fine.*damping needs one value'),
    ('control.filter.order', [4.0, 2.0, 2.0, 0.0, 0.0], 'expected a list of integers'),
    ('control.filter.order', [9, 2, 2, 0, 0], 'above the maximum'),
    ('control.filter.corner', [8.0, 0.0, 30.0, 0.0, 0.0], 'corner of role J2'),
    ('control.filter.kind', 'chebyshev', 'must be one of'),
    ('control.coarse.acceleration_feedback', [0.5, -1.0, 0.0, 0.0, 0.0], 'below the minimum'),
    ('control.setpoint_timeout', float('nan'), 'finite'),
    ('control.setpoint_extrapolation', -0.01, 'below the minimum'),
    ('control.setpoint_extrapolation', 0.6, r'setpoint_extrapolation \(0.6 s\) must not exceed '
                                            r'control\.setpoint_timeout'),
    ('control.sim_time_setpoint_wait', -0.1, 'below the minimum'),
    ('control.sim_time_setpoint_wait', 0.5, r'sim_time_setpoint_wait \(0.5 s\) must be below '
                                            r'control\.state_timeout'),
])
def test_malformed_values_are_refused_by_name(name, value, words):
    with pytest.raises(ParameterError, match=words):
        with_overrides(**{name.replace('.', '__'): value})
