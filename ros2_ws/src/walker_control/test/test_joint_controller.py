"""The composed joint controller: terms, modes, bumpless transfer, role swap, refusals.

The closed-loop checks run the controller against a rigid single joint (the joint's own
diagonal inertia, the other joints still): the model the controller is designed on. The same
checks on the flexible pybullet plant belong with the plant.
"""

import math

import numpy as np
import pytest

from walker_core.dynamics import RigidModel, diagonal_inertia
from walker_core.joint_roles import PHYSICAL_JOINT_NAMES, physical_to_roles
from walker_control.core.config import load_controller_settings
from walker_core.parameter_schema import ParameterError, replace_in_section
from walker_control.core.inputs import Setpoint
from walker_control.core.joint_controller import (
    JointController, Measurement, MeasurementError, RoleChangeError)
from walker_control.core.modes import Mode

#: The terms of Figure 3 alone (no reference shaping, no setpoint filter, no friction
#: feed-forward), so each term can be checked against the design; the additions are checked on
#: their own below.
SETTINGS = replace_in_section(load_controller_settings(),
                              {'control.filter.reference': False,
                               'control.filter.setpoint_order': [0, 0, 0, 0, 0],
                               'control.friction_compensation.feedforward_speed': 0.0})
#: With reference shaping and friction feed-forward on, J1-J3's compensator deadband and ramp
#: 0.2 and 0.3 mrad, J4's 0.5 and 1 mrad: the controller as shipped.
SHAPED = replace_in_section(SETTINGS, {
    'control.filter.reference': True, 'control.friction_compensation.feedforward_speed': 0.02,
    'control.friction_compensation.deadband': [0.0002, 0.0002, 0.0002, 0.0005, 0.005],
    'control.friction_compensation.ramp': [0.0003, 0.0003, 0.0003, 0.001, 0.005]})
#: As shipped, with J4's setpoints through J2 and J3's command filter (off by default).
WRIST_IN_STEP = replace_in_section(SHAPED, {'control.filter.setpoint_order': [0, 0, 0, 2, 0],
                                            'control.filter.setpoint_corner': [0, 0, 0, 24.0, 0]})
T = SETTINGS.sample_time
STANCE = np.array([0.0, 0.85, 1.45, 0.85, 0.0])  # physical joint angles [rad]


def inertia_of(joint, base, q=STANCE):
    role_q = physical_to_roles(q, base)
    role = (PHYSICAL_JOINT_NAMES.index(joint) + 1 if base == 'a'
            else 5 - PHYSICAL_JOINT_NAMES.index(joint))
    return diagonal_inertia(role_q, RigidModel.from_parameters(SETTINGS))[role - 1]


class RigidJoint:
    """One joint of the rigid model, the others still, with Coulomb friction and stiction.

    Exact zero-order-hold integration; a joint whose velocity would change sign within a
    period stops (sticks) instead. The friction is the drive's, as the controller knows it.
    """

    def __init__(self, joint, base='a', position=None, disturbance=0.0, friction=True):
        self.index = PHYSICAL_JOINT_NAMES.index(joint)
        self.q = STANCE.copy()
        if position is not None:
            self.q[self.index] = position
        self.velocity = 0.0
        self.acceleration = 0.0
        self.inertia = inertia_of(joint, base, self.q)
        self.disturbance = disturbance
        drive = SETTINGS.robot.drive.for_role(1 if self.index in (0, 4) else
                                              3 if self.index == 2 else 2)
        self.coulomb = drive.friction_torque if friction else 0.0
        self.stiction = drive.stiction_torque if friction else 0.0

    @property
    def position(self):
        return self.q[self.index]

    def measurement(self):
        return Measurement(self.position, self.velocity, self.acceleration, tuple(self.q))

    def step(self, torque):
        applied = torque + self.disturbance
        v = self.velocity
        if v == 0.0 and abs(applied) <= self.stiction:
            self.acceleration = 0.0
            return
        direction = math.copysign(1.0, v if v != 0.0 else applied)
        a = (applied - direction * self.coulomb) / self.inertia
        if v != 0.0 and (v + a * T) * v < 0.0:  # friction stops the joint within the period
            stop = -v / a
            self.q[self.index] += v * stop + 0.5 * a * stop ** 2
            self.velocity = 0.0
            self.acceleration = -v / T
            return
        self.q[self.index] += v * T + 0.5 * a * T ** 2
        self.velocity = v + a * T
        self.acceleration = a


def run(controller, plant, samples, setpoint=None):
    """Run closed loop; ``setpoint`` is a Setpoint, a function of the sample index, or None."""
    efforts, outputs = [], []
    for k in range(samples):
        sp = setpoint(k) if callable(setpoint) else setpoint
        out = controller.update(plant.measurement(), sp, T)
        plant.step(out.effort)
        efforts.append(out.effort)
        outputs.append(out)
    return np.array(efforts), outputs


def ramp(start, rate, start_index=0):
    def setpoint(k):
        t = max(0, k - start_index) * T
        return Setpoint(position=start + rate * t, velocity=rate if k >= start_index else 0.0)
    return setpoint


# ------------------------------------------------------------------------------------ basics
def test_starts_in_hold_at_the_measured_position_from_zero_torque():
    controller = JointController(SETTINGS, 'vertex_joint')
    plant = RigidJoint('vertex_joint', position=0.3)
    efforts, outputs = run(controller, plant, 200)
    assert controller.mode == Mode.HOLD
    assert efforts[0] == 0.0
    assert all(out.reference.position == 0.3 for out in outputs)
    assert np.max(np.abs(efforts)) < 1e-9


def test_terms_follow_the_rigid_model_design():
    controller = JointController(SETTINGS, 'b_pitch_joint', 'a')  # role J4, unfiltered
    controller.command(Mode.FINE)
    q = STANCE.copy()
    measured = Measurement(q[3], 0.05, 0.0, tuple(q))
    setpoint = Setpoint(position=q[3] + 0.02, velocity=0.15, acceleration=0.5, effort=0.1)
    out = controller.update(measured, setpoint, T)
    inertia = inertia_of('b_pitch_joint', 'a')
    fine = SETTINGS.control.fine
    wc, zc, ti = fine.bandwidth[3], fine.damping[3], fine.integral_time[3]
    assert out.role == 4 and out.mode == Mode.FINE
    assert out.inertia == pytest.approx(inertia)
    assert out.feedforward == pytest.approx(inertia * 0.5 + 0.1)
    assert out.proportional == pytest.approx(inertia * wc ** 2 * 0.02)
    assert out.derivative == pytest.approx(inertia * 2 * zc * wc * 0.1)
    assert out.integral == pytest.approx(inertia * wc ** 2 / ti * 0.02 * T)
    assert out.acceleration_feedback == 0.0


def test_acceleration_feedback_only_on_joint_1_in_coarse():
    q = STANCE.copy()
    inertia = inertia_of('a_yaw_joint', 'a')
    controller = JointController(SETTINGS, 'a_yaw_joint', 'a')
    controller.command(Mode.COARSE)
    out = controller.update(Measurement(q[0], 0.0, 2.0, tuple(q)), None, T)
    ka = SETTINGS.control.coarse.acceleration_feedback[0]
    assert out.acceleration_feedback == pytest.approx(-ka * inertia * 2.0)
    controller.command(Mode.FINE)
    assert controller.update(Measurement(q[0], 0.0, 2.0, tuple(q)), None,
                             T).acceleration_feedback == 0.0
    other = JointController(SETTINGS, 'vertex_joint', 'a')
    other.command(Mode.COARSE)
    assert other.update(Measurement(q[2], 0.0, 2.0, tuple(q)), None,
                        T).acceleration_feedback == 0.0


def test_a_missing_acceleration_is_refused_only_when_it_is_fed_back():
    q = STANCE.copy()
    controller = JointController(SETTINGS, 'a_yaw_joint', 'a')
    controller.update(Measurement(q[0], 0.0, None, tuple(q)), None, T)  # HOLD: not needed
    controller.command(Mode.COARSE)
    with pytest.raises(MeasurementError, match='acceleration'):
        controller.update(Measurement(q[0], 0.0, None, tuple(q)), None, T)


# ----------------------------------------------------------------------- closed loop, rigid
@pytest.mark.parametrize('joint', PHYSICAL_JOINT_NAMES)
@pytest.mark.parametrize('base', ['a', 'b'])
def test_fine_mode_reaches_a_step_within_its_tolerance_on_the_rigid_model(joint, base):
    controller = JointController(SETTINGS, joint, base)
    role = controller.role
    plant = RigidJoint(joint, base)
    controller.command(Mode.FINE, base)
    target = plant.position + 0.02
    # Settling time of the slowest fine loop (J1, wc = 0.7 rad/s) is several seconds.
    seconds = 12.0 / SETTINGS.control.fine.bandwidth[role - 1] + 2.0
    run(controller, plant, int(seconds / T), Setpoint(position=target))
    assert abs(plant.position - target) < SETTINGS.control.in_position_tolerance[role - 1]
    assert abs(plant.velocity) < 1e-3


def test_feedforward_tracks_a_trajectory_on_the_rigid_model():
    """With the exact rigid inertia, the feed-forward does the work: the error stays tiny."""
    controller = JointController(SETTINGS, 'b_pitch_joint', 'a')  # unfiltered role J4
    plant = RigidJoint('b_pitch_joint', 'a', friction=False)
    controller.command(Mode.COARSE)
    start = plant.position
    w, amplitude = 2.0, 0.3
    settle = int(3.0 / T)  # let the transfer offset of the mode change decay first

    def setpoint(k):
        if k < settle:
            return Setpoint(position=start)
        t = (k - settle) * T
        return Setpoint(position=start + amplitude * (1 - math.cos(w * t)),
                        velocity=amplitude * w * math.sin(w * t),
                        acceleration=amplitude * w * w * math.cos(w * t))
    _, outputs = run(controller, plant, settle + int(4.0 / T), setpoint)
    errors = np.array([out.position_error for out in outputs[settle:]])
    assert np.max(np.abs(errors)) < 0.01 * amplitude


def test_effort_is_clamped_and_the_integral_does_not_wind_up():
    controller = JointController(SETTINGS, 'b_pitch_joint', 'a')
    limit = SETTINGS.drive(4).torque_limit
    plant = RigidJoint('b_pitch_joint', 'a', disturbance=-3.0 * limit)  # a joint it cannot move
    controller.command(Mode.FINE)
    efforts, outputs = run(controller, plant, int(2.0 / T),
                           Setpoint(position=plant.position + 0.5))
    assert np.max(np.abs(efforts)) <= limit
    assert efforts[-1] == limit and all(out.saturated for out in outputs[int(1.0 / T):])
    # Saturated for the last second with a large error: the integral has not moved (without
    # anti-windup it would have grown by Ki * 0.5 rad * 1 s, far beyond the limit).
    integrals = [out.integral for out in outputs[int(1.0 / T):]]
    assert max(integrals) == min(integrals)
    assert abs(integrals[-1]) < 0.05 * limit
    ki = outputs[-1].inertia * SETTINGS.control.fine.bandwidth[3] ** 2 \
        / SETTINGS.control.fine.integral_time[3]
    assert ki * 0.5 * 1.0 > limit


def test_friction_compensation_signed_by_the_error_and_off_in_the_deadband():
    controller = JointController(SETTINGS, 'vertex_joint', 'a')
    q = STANCE.copy()
    controller.update(Measurement(q[2], 0.0, 0.0, tuple(q)), None, T)
    controller.command(Mode.FINE)
    level = SETTINGS.friction_level(3)
    for _ in range(int(12 * SETTINGS.control.bumpless_time_constant / T)):
        out = controller.update(Measurement(q[2], 0.0, 0.0, tuple(q)),
                                Setpoint(position=q[2] - 0.1), T)
    assert out.friction_compensation == pytest.approx(-level, rel=1e-3)
    out = controller.update(Measurement(q[2], 0.0, 0.0, tuple(q)),
                            Setpoint(position=q[2] + 0.0001), T)
    assert abs(out.friction_compensation) < 0.01 * level  # in the deadband: only the decay


def test_off_gives_zero_torque_and_a_latched_hold_does_not_override_it():
    controller = JointController(SETTINGS, 'vertex_joint')
    plant = RigidJoint('vertex_joint')
    controller.command(Mode.OFF)
    controller.hold('stale state')
    efforts, _ = run(controller, plant, 10, Setpoint(position=plant.position + 0.3))
    assert controller.mode == Mode.OFF and np.all(efforts == 0.0)


# ------------------------------------------------------------------------- bumpless transfer
def _switch(joint, base, first, second, setpoint):
    """Run in ``first`` along a ramp, switch to ``second``; return efforts and the switch k.

    From OFF the joint coasts (no friction) so that the new mode has motion to take over.
    """
    controller = JointController(SETTINGS, joint, base)
    plant = RigidJoint(joint, base, friction=first != Mode.OFF)
    if first == Mode.OFF:
        plant.velocity = 0.05
    controller.command(first)
    start = plant.position
    sp = setpoint(start)
    switch_at = int(3.0 / T)
    efforts, outputs = run(controller, plant, switch_at, sp)
    controller.command(second)
    after, after_outputs = run(controller, plant, int(1.0 / T),
                               lambda k: sp(k + switch_at))
    return np.concatenate([efforts, after]), outputs + after_outputs, switch_at


SWITCHES = [(Mode.COARSE, Mode.FINE), (Mode.FINE, Mode.HOLD), (Mode.HOLD, Mode.COARSE),
            (Mode.COARSE, Mode.HOLD), (Mode.OFF, Mode.HOLD)]


@pytest.mark.parametrize('first, second', SWITCHES)
@pytest.mark.parametrize('joint', ['a_yaw_joint', 'vertex_joint', 'b_yaw_joint'])
def test_mode_switch_is_bumpless(joint, first, second):
    def setpoint(start):
        return ramp(start, 0.05)
    efforts, outputs, k = _switch(joint, 'a', first, second, setpoint)
    limit = SETTINGS.drive(outputs[-1].role).torque_limit
    jump = abs(efforts[k] - efforts[k - 1])
    if first != Mode.OFF:
        normal = np.max(np.abs(np.diff(efforts[k - 200:k])))  # ordinary change per sample
        assert jump <= 2.0 * normal + 1e-4 * limit
    else:
        assert efforts[k - 1] == 0.0
        assert jump <= 1e-3 * limit
    # The scenario has a bump to remove: the new mode's command differs from the old one.
    bump = abs(outputs[k].transfer) + abs(outputs[k].friction_compensation
                                          - outputs[k - 1].friction_compensation)
    assert bump > 10.0 * jump


# [rad/s^2] measured in the last coarse sample; 30 drives the command past the torque limit
@pytest.mark.parametrize('spike', [0.0, 12.0, 30.0])
def test_the_acceleration_feedback_is_not_carried_into_fine_as_an_offset(spike):
    """Joint 1 ends a coarse motion ringing: its last acceleration feedback is one sample's.

    Carried over as a decaying offset, one 12 rad/s^2 sample (the flexible link ringing after
    a real-time stall) held about 8 N*m for the bumpless time constant and drove the joint
    tens of milliradians off in FINE. The offset at the switch is the same with and without
    the spike, and the joint stays where it was; also when the spike's feedback clamped the
    filter's input at the torque limit (the feedback is taken out before the clamp, not from
    the clamped input).
    """
    joint = 'a_yaw_joint'
    controller = JointController(SETTINGS, joint, 'a')
    plant = RigidJoint(joint, 'a')
    controller.command(Mode.COARSE)
    hold = Setpoint(position=plant.position)
    run(controller, plant, int(1.0 / T), hold)
    ringing = Measurement(plant.position, plant.velocity, spike, tuple(plant.q))
    before = controller.update(ringing, hold, T)
    assert abs(before.acceleration_feedback) > 5.0 or spike == 0.0  # Ka on in coarse, joint 1
    plant.step(before.effort)
    controller.command(Mode.FINE)
    after, outputs = run(controller, plant, int(1.0 / T), hold)
    assert abs(outputs[0].transfer) < 0.05  # no offset to carry: holding still
    assert abs(plant.position - hold.position) < 1e-3  # [rad]


def test_role_swap_while_holding_is_bumpless_and_changes_the_filter():
    joint = 'a_yaw_joint'
    settings = replace_in_section(SETTINGS, {'control.relaxation.duration': 0.0})
    controller = JointController(settings, joint, 'a')
    plant = RigidJoint(joint, 'a', disturbance=0.5, friction=False)  # against a steady torque
    efforts, _ = run(controller, plant, int(15.0 / T))
    assert controller.role == 1 and abs(efforts[-1]) > 0.3
    controller.command(Mode.HOLD, 'b')
    assert controller.role == 5
    plant.inertia = inertia_of(joint, 'b', plant.q)
    after, outputs = run(controller, plant, int(2.0 / T))
    assert abs(after[0] - efforts[-1]) < 1e-3
    assert outputs[-1].role == 5
    assert SETTINGS.control.filter.order[0] != SETTINGS.control.filter.order[4]


@pytest.mark.parametrize('first, second', [(Mode.COARSE, Mode.COARSE),
                                           (Mode.COARSE, Mode.FINE), (Mode.FINE, Mode.FINE)])
def test_role_swap_refused_while_moving_and_nothing_changes(first, second):
    controller = JointController(SETTINGS, 'a_yaw_joint', 'a')
    controller.command(first, 'a')
    with pytest.raises(RoleChangeError, match='only while holding'):
        controller.command(second, 'b')
    assert controller.role == 1 and controller.base_gripper == 'a'
    assert controller.mode == first


@pytest.mark.parametrize('first, second', [(Mode.COARSE, Mode.HOLD), (Mode.HOLD, Mode.FINE),
                                           (Mode.OFF, Mode.COARSE), (Mode.FINE, Mode.OFF)])
def test_role_swap_accepted_into_or_out_of_hold_and_off(first, second):
    controller = JointController(SETTINGS, 'a_yaw_joint', 'a')
    controller.command(first, 'a')
    controller.command(second, 'b')
    assert controller.role == 5 and controller.mode == second


def test_unknown_gripper_is_refused():
    controller = JointController(SETTINGS, 'a_yaw_joint', 'a')
    with pytest.raises(ValueError, match='gripper'):
        controller.command(Mode.HOLD, 'c')


# ---------------------------------------------------------------------------- latched hold
def test_a_latched_hold_holds_where_the_joint_was_until_the_next_command():
    controller = JointController(SETTINGS, 'vertex_joint')
    plant = RigidJoint('vertex_joint')
    controller.command(Mode.FINE)
    sp = ramp(plant.position, 0.1)
    run(controller, plant, int(2.0 / T), sp)
    controller.hold('setpoint stream stale')
    held_at = plant.position
    _, outputs = run(controller, plant, int(4.0 / T), lambda k: sp(k + int(2.0 / T)))
    assert controller.mode == Mode.HOLD and controller.hold_reason == 'setpoint stream stale'
    assert outputs[0].reference.position == held_at
    assert abs(plant.position - held_at) < 0.01
    controller.command(Mode.FINE)
    assert controller.mode == Mode.FINE and controller.hold_reason == ''


def test_tracking_mode_without_setpoint_holds_where_it_entered():
    controller = JointController(SETTINGS, 'vertex_joint')
    plant = RigidJoint('vertex_joint', position=0.2)
    controller.command(Mode.COARSE)
    _, outputs = run(controller, plant, 50)
    assert all(out.reference.position == 0.2 for out in outputs)


# ------------------------------------------------------------------------------- refusals
@pytest.mark.parametrize('measurement', [
    Measurement(math.nan, 0.0, 0.0, tuple(STANCE)),
    Measurement(0.1, math.inf, 0.0, tuple(STANCE)),
    Measurement(0.1, 0.0, math.nan, tuple(STANCE)),
    Measurement(0.1, 0.0, 0.0, (0.0, math.nan, 0.0, 0.0, 0.0)),
    Measurement(0.1, 0.0, 0.0, (0.0, 0.0, 0.0)),
])
def test_bad_measurements_are_refused_and_change_nothing(measurement):
    reference, probe = (JointController(SETTINGS, 'vertex_joint') for _ in range(2))
    good = Measurement(STANCE[2], 0.01, 0.0, tuple(STANCE))
    for controller in (reference, probe):
        controller.command(Mode.FINE)
        controller.update(good, Setpoint(position=STANCE[2] + 0.05), T)
    with pytest.raises(MeasurementError):
        probe.update(measurement, Setpoint(position=STANCE[2] + 0.05), T)
    assert probe.update(good, Setpoint(position=STANCE[2] + 0.05), T) == \
        reference.update(good, Setpoint(position=STANCE[2] + 0.05), T)


@pytest.mark.parametrize('dt', [0.0, -T, math.nan, math.inf])
def test_bad_sample_times_are_refused(dt):
    controller = JointController(SETTINGS, 'vertex_joint')
    with pytest.raises(ValueError, match='dt'):
        controller.update(Measurement(0.0, 0.0, 0.0, tuple(STANCE)), None, dt)


def test_unknown_joint_is_refused():
    with pytest.raises(ValueError, match='unknown joint'):
        JointController(SETTINGS, 'elbow_joint')


# --------------------------------------------- reference shaping and friction feed-forward
def sweep(start, distance, duration):
    """Return a minimum-jerk move of ``distance`` rad in ``duration`` s, then at rest."""
    def setpoint(k):
        tau = min(1.0, k * T / duration)
        shape = 10 * tau**3 - 15 * tau**4 + 6 * tau**5
        rate = (30 * tau**2 - 60 * tau**3 + 30 * tau**4) / duration
        accel = (60 * tau - 180 * tau**2 + 120 * tau**3) / duration**2
        return Setpoint(position=start + distance * shape,
                        velocity=distance * rate if tau < 1.0 else 0.0,
                        acceleration=distance * accel if tau < 1.0 else 0.0)
    return setpoint


def test_shaping_and_friction_feedforward_are_on_as_shipped():
    shipped = load_controller_settings()
    assert shipped.control.filter.reference
    assert shipped.control.friction_compensation.feedforward_speed > 0.0
    assert SHAPED == shipped  # the tests below check the shipped controller


def test_shaped_reference_makes_joint1_follow_a_fast_sweep_without_fighting_its_filter():
    """Joint 1 follows a fast sweep on the rigid model within 3 mrad of its shaped reference.

    Behind its 8 rad/s fourth-order filter, a 1.2 rad sweep in 2 s: with the shipped controller
    the joint stays within 3 mrad of the shaped reference (breaking away from stiction costs
    most of it) and ends on the target; the paper's controller alone lags by more than a
    hundred times that.
    """
    results = {}
    for name, settings in (('shipped', SHAPED), ('figure 3', SETTINGS)):
        controller = JointController(settings, 'a_yaw_joint', 'a')
        plant = RigidJoint('a_yaw_joint', position=0.0)
        controller.command(Mode.COARSE)
        _, outputs = run(controller, plant, int(5.0 / T), sweep(0.0, 1.2, 2.0))
        errors = np.array([out.position_error for out in outputs])
        trace = np.array([out.reference.position for out in outputs])
        results[name] = (np.abs(errors).max(), plant.position, trace)
    shipped_error, shipped_end, _ = results['shipped']
    paper_error, _, _ = results['figure 3']
    assert shipped_error < 3e-3
    assert paper_error > 100 * shipped_error
    assert abs(shipped_end - 1.2) < SHAPED.control.in_position_tolerance[0]


def test_shaped_reference_is_reported_beside_the_commanded_setpoint():
    controller = JointController(SHAPED, 'a_yaw_joint', 'a')
    plant = RigidJoint('a_yaw_joint', position=0.0)
    controller.command(Mode.COARSE)
    _, outputs = run(controller, plant, 200, sweep(0.0, 0.5, 1.0))
    out = outputs[-1]
    assert out.reference == sweep(0.0, 0.5, 1.0)(199)
    assert out.shaped_reference.position < out.reference.position  # behind, by the filter
    measurement = plant.measurement()
    out = controller.update(measurement, sweep(0.0, 0.5, 1.0)(200), T)
    assert out.position_error == pytest.approx(
        out.shaped_reference.position - measurement.position, abs=1e-15)


def test_shaping_starts_at_the_measured_joint_and_passes_a_hold_unchanged():
    controller = JointController(SHAPED, 'a_yaw_joint', 'a')
    plant = RigidJoint('a_yaw_joint', position=0.4)
    _, outputs = run(controller, plant, 500)
    shaped = np.array([out.shaped_reference.position for out in outputs])
    assert np.abs(shaped - 0.4).max() < 1e-12
    assert np.abs(plant.position - 0.4) < 1e-9


def test_shaping_runs_on_through_coarse_to_fine_and_restarts_after_a_hold():
    """The shaped reference runs on through COARSE to FINE and restarts after a hold.

    The sequencer switches to FINE while a move is still streaming: the shaped reference goes
    on moving smoothly; after HOLD it starts again from where the joint is.
    """
    controller = JointController(SHAPED, 'a_yaw_joint', 'a')
    plant = RigidJoint('a_yaw_joint', position=0.0)
    controller.command(Mode.COARSE)
    move = sweep(0.0, 0.8, 2.0)
    _, before = run(controller, plant, 500, move)
    controller.command(Mode.FINE)
    _, after = run(controller, plant, 500, lambda k: move(k + 500))
    shaped = np.array([out.shaped_reference.position for out in before + after])
    steps = np.abs(np.diff(shaped))
    assert steps[499] < 2.0 * steps[495:499].max()  # no jump at the switch
    controller.hold('test')
    run(controller, plant, 10)
    controller.command(Mode.FINE)
    out = controller.update(plant.measurement(), move(1500), T)
    assert abs(out.shaped_reference.position - plant.position) < 2e-3


def _follow_on_rigid_joints(settings, joints, move, samples):
    """Each of ``joints`` (base a) follows ``move`` alone on the frictionless rigid model."""
    traces = []
    for joint in joints:
        controller = JointController(settings, joint, 'a')
        plant = RigidJoint(joint, position=0.85, friction=False)
        controller.command(Mode.FINE)
        _, outputs = run(controller, plant, samples, move)
        traces.append((np.array([out.shaped_reference.position for out in outputs]),
                       np.array([out.reference.position for out in outputs]), plant))
    return traces


def test_the_wrist_keeps_step_with_joint_2_through_its_setpoint_filter():
    """J4 (no command filter) follows a descent-like move as J2 does behind its filter.

    A 34 mrad minimum-jerk move in 0.3 s (J2 and J4 in a descent): on the rigid model each
    joint follows its shaped reference, J2 through its command filter and J4 through its
    setpoint filter (the same design), so the two move together within a microradian. Without
    the setpoint filter (as shipped) J4 leads J2 by its filter's delay, several milliradians
    in mid-move.
    """
    move = sweep(0.85, 0.034, 0.3)
    samples = int(0.6 / T)
    gaps = {}
    for name, settings in (('in step', WRIST_IN_STEP), ('shipped', SHAPED)):
        (shaped2, _, joint2), (shaped4, received4, joint4) = _follow_on_rigid_joints(
            settings, ('a_pitch_joint', 'b_pitch_joint'), move, samples)
        gaps[name] = np.abs(shaped4 - shaped2).max()
        assert received4[-1] == pytest.approx(0.85 + 0.034)  # the setpoint, as received
        for joint in (joint2, joint4):  # both arrive
            assert joint.position == pytest.approx(
                0.85 + 0.034, abs=SHAPED.control.in_position_tolerance[1])
    assert gaps['in step'] < 1e-6
    assert gaps['shipped'] > 5e-3


def test_the_setpoint_filter_starts_at_the_measured_joint_and_restarts_after_a_hold():
    controller = JointController(WRIST_IN_STEP, 'b_pitch_joint', 'a')  # role J4
    plant = RigidJoint('b_pitch_joint', position=0.85)
    controller.command(Mode.FINE)
    out = controller.update(plant.measurement(), Setpoint(0.9), T)
    assert out.reference.position == 0.9
    assert out.shaped_reference.position == pytest.approx(0.85, abs=1e-4)  # no jump
    run(controller, plant, 1000, Setpoint(0.9))
    assert plant.position == pytest.approx(0.9,
                                           abs=SHAPED.control.in_position_tolerance[3])
    controller.hold('test')
    run(controller, plant, 10)
    controller.command(Mode.FINE)
    out = controller.update(plant.measurement(), Setpoint(0.95), T)
    assert out.shaped_reference.position == pytest.approx(plant.position, abs=1e-4)


@pytest.mark.parametrize('changes, words', [
    ({'control.filter.setpoint_corner': [0.0, 0.0, 0.0, 0.0, 0.0]},
     'setpoint_corner of role J4 must be > 0 rad/s when its setpoint_order is 2'),
    ({'control.filter.setpoint_order': [0, 0, 0, 2]}, 'setpoint_order needs one value per'),
    ({'control.filter.setpoint_order': [0, 0, 0, 9, 0]}, 'setpoint_order'),
    # above the 785 rad/s Nyquist frequency of a 250 Hz loop: refused, not built mid-walk
    ({'timing.control_rate': 250.0, 'control.filter.setpoint_corner': [0, 0, 0, 900.0, 0]},
     'setpoint_corner of role J4: filter corner 900.0 rad/s must be positive and below'),
])
def test_bad_setpoint_filters_are_refused(changes, words):
    with pytest.raises(ParameterError, match=words):
        replace_in_section(WRIST_IN_STEP, changes)


def test_friction_feedforward_follows_the_setpoint_velocity():
    from walker_control.core.friction_compensation import friction_feedforward

    assert friction_feedforward(1.5, 0.0, 0.02) == 0.0
    assert friction_feedforward(1.5, 0.02, 0.02) == pytest.approx(1.5 * math.tanh(1.0))
    assert friction_feedforward(1.5, -1.0, 0.02) == pytest.approx(-1.5)
    assert friction_feedforward(1.5, 1.0, 0.0) == 0.0  # off
    controller = JointController(SHAPED, 'vertex_joint', 'a')
    plant = RigidJoint('vertex_joint', position=1.45)
    controller.command(Mode.FINE)
    out = controller.update(plant.measurement(), Setpoint(1.45, velocity=0.5), T)
    coulomb = SHAPED.drive(3).friction_torque
    assert out.feedforward == pytest.approx(coulomb * math.tanh(0.5 / 0.02))


def test_shaping_keeps_time_when_samples_are_missed():
    """A controller that sees every fifth state shapes its reference on the time that passed.

    A starved process in real time misses states; its reference must not lag on that account.
    """
    every, skipping = (JointController(SHAPED, 'a_yaw_joint', 'a') for _ in range(2))
    for controller in (every, skipping):
        controller.command(Mode.COARSE)
    plant = RigidJoint('a_yaw_joint', position=0.0)
    measurement = plant.measurement()
    step = Setpoint(position=0.1)
    for k in range(500):
        out_every = every.update(measurement, step, T)
        if k % 5 == 4:
            out_skipping = skipping.update(measurement, step, 5 * T)
    assert out_skipping.shaped_reference.position == pytest.approx(
        out_every.shaped_reference.position, abs=1e-12)


def test_lowpass_filter_advances_over_missed_samples_as_over_held_ones():
    from walker_control.core.lowpass import LowPassFilter

    once, held = (LowPassFilter(4, 8.0, T) for _ in range(2))
    for value in (1.0, -0.5, 2.0):
        for _ in range(7):
            expected = held.update(value)
        assert once.update(value, 7) == expected
    assert np.array_equal(once.state, held.state)


@pytest.mark.parametrize('settings', [SETTINGS, SHAPED], ids=['figure 3', 'shaped'])
def test_a_controller_that_misses_every_other_state_still_tracks_joint1_sweep(settings):
    """A controller that misses every other state keeps the loop it was designed for.

    The plant holds the last effort over the missed states; the controller's filter keeps time,
    so joint 1 ends the sweep as close to the target as with every state, overshooting no more.

    Run once per sample instead, joint 1's filter would double its delay, and the joint would
    overshoot the target by tenths of a radian (seen on the walker in real time).
    """
    overshoot, end = {}, {}
    for every in (1, 2):
        controller = JointController(settings, 'a_yaw_joint', 'a')
        plant = RigidJoint('a_yaw_joint', position=0.0)
        controller.command(Mode.COARSE)
        move = sweep(0.0, 1.2, 2.0)
        positions = []
        for k in range(int(5.0 / T)):
            if k % every == 0:
                effort = controller.update(plant.measurement(), move(k), every * T).effort
            plant.step(effort)
            positions.append(plant.position)
        overshoot[every] = max(positions) - 1.2
        end[every] = plant.position
    assert overshoot[2] < max(2.0 * overshoot[1], 5e-3), overshoot
    assert abs(end[2] - 1.2) < max(2.0 * abs(end[1] - 1.2), 5e-3), end


def test_a_hold_that_changes_the_base_runs_the_relaxation_dither_then_holds_where_it_ends():
    """The step's end: the dither alone for control.relaxation.duration, then HOLD afresh."""
    joint = 'a_yaw_joint'
    controller = JointController(SETTINGS, joint, 'a')
    plant = RigidJoint(joint, 'a')
    run(controller, plant, int(1.0 / T))  # holding under base a: no relaxation
    assert not controller.relaxing
    controller.command(Mode.HOLD, 'b')
    assert controller.relaxing
    dither = SETTINGS.relaxation(controller.role)
    samples = round(SETTINGS.control.relaxation.duration / T)
    efforts, outputs = run(controller, plant, samples)
    expected = [dither.torque(k * T) for k in range(samples)]
    assert efforts == pytest.approx(expected, abs=1e-9)
    assert max(abs(e) for e in efforts) > SETTINGS.drive(controller.role).stiction_torque
    assert all(o.mode == Mode.HOLD for o in outputs)
    after, outputs = run(controller, plant, int(0.5 / T))
    assert not controller.relaxing
    assert outputs[0].reference.position == pytest.approx(plant.q[0])  # where it came to rest
    assert abs(after[0]) < 1e-6  # HOLD starts from zero torque, bumpless


def test_each_role_dithers_at_its_own_frequency_within_its_torque_limit():
    frequencies = [SETTINGS.relaxation(role).frequency for role in range(1, 6)]
    assert len(set(frequencies)) == 5
    for role in range(1, 6):
        assert SETTINGS.relaxation(role).amplitude <= SETTINGS.drive(role).torque_limit


@pytest.mark.parametrize('case', ['same_base', 'latched_hold', 'tracking', 'off_by_parameter'])
def test_no_relaxation_without_a_base_change_and_a_mode_change_ends_it(case):
    settings = SETTINGS
    if case == 'off_by_parameter':
        settings = replace_in_section(SETTINGS, {'control.relaxation.duration': 0.0})
    controller = JointController(settings, 'vertex_joint', 'a')
    if case == 'same_base':
        controller.command(Mode.HOLD, 'a')
    else:
        controller.command(Mode.HOLD, 'b')
    if case == 'latched_hold':
        controller.hold('input stale')
    elif case == 'tracking':
        controller.command(Mode.FINE, 'b')
    assert not controller.relaxing
    controller.command(Mode.HOLD, controller.base_gripper)  # HOLD, same base: nothing starts
    assert not controller.relaxing


def test_the_same_hold_again_leaves_a_relaxation_running():
    controller = JointController(SETTINGS, 'vertex_joint', 'a')
    controller.command(Mode.HOLD, 'b')
    controller.command(Mode.HOLD, 'b')  # told again (a repeated mode command)
    assert controller.relaxing


@pytest.mark.parametrize('field, value, words', [
    ('control.relaxation.frequency', 100.0, 'quarter of timing.control_rate'),
    ('control.relaxation.amplitude', -1.0, 'amplitude'),
    ('control.relaxation.duration', 9.0, 'duration'),
])
def test_bad_relaxation_settings_are_refused(field, value, words):
    with pytest.raises(ParameterError, match=words):
        replace_in_section(SETTINGS, {field: value})


def test_the_input_shaper_shapes_joint_1s_setpoints_as_its_impulses_say():
    """control.shaping on J1: the setpoint the loop follows is the step convolved with ZVD."""
    from walker_control.core.input_shaping import DiscreteShaper, zvd
    shaped_settings = replace_in_section(SETTINGS, {
        'control.shaping.kind': 'zvd', 'control.shaping.frequency': [18.0, 0, 0, 0, 0]})
    joint = PHYSICAL_JOINT_NAMES[0]
    controller = JointController(shaped_settings, joint, 'a')  # role J1
    plant = RigidJoint(joint, position=0.0)
    controller.command(Mode.COARSE)
    expected = DiscreteShaper(zvd(18.0, 0.05), T)
    expected.reset_to(0.0)
    samples = len(expected.taps) + 10
    _, outputs = run(controller, plant, samples, Setpoint(0.01))
    shaped = [out.shaped_reference.position for out in outputs]
    assert shaped == pytest.approx(expected.filter([0.01] * samples), abs=1e-12)
    assert shaped[0] < 0.01 / 2  # the first impulse only: no jump to the setpoint
    assert shaped[-1] == pytest.approx(0.01, abs=1e-15)  # the step reached exactly
    assert outputs[-1].reference.position == 0.01  # the setpoint as received


def test_an_unshaped_file_leaves_the_setpoint_alone():
    controller = JointController(SETTINGS, PHYSICAL_JOINT_NAMES[0], 'a')
    plant = RigidJoint(PHYSICAL_JOINT_NAMES[0], position=0.0)
    controller.command(Mode.COARSE)
    _, outputs = run(controller, plant, 5, Setpoint(0.01))
    assert all(out.shaped_reference.position == 0.01 for out in outputs)


@pytest.mark.parametrize('changes,message', [
    ({'control.shaping.kind': 'zv', 'control.shaping.frequency': [5000.0, 0, 0, 0, 0]},
     'control.shaping.frequency'),
    ({'control.shaping.kind': 'bogus'}, 'control.shaping.kind')])
def test_a_shaper_that_cannot_be_designed_is_refused_when_the_settings_are_built(changes,
                                                                                   message):
    with pytest.raises((ParameterError, ValueError), match=message):
        replace_in_section(SETTINGS, changes)


# ------------------------------------------------------------- a drive stiffer than identified
def _stuck_joint_1(settings, stiction_factor, mode=Mode.FINE, seconds=2.0):
    """Joint 1 whose friction is ``stiction_factor`` times the identified, asked 3.6 mrad on.

    3.6 mrad of joint 1 are 3.2 mm of tip at the 0.9 m reach: a probe of the search on a jam
    one grid step across the step's direction (the campaigns draw up to 1.35 times the drive's
    friction).
    """
    controller = JointController(settings, 'a_yaw_joint', 'a')
    plant = RigidJoint('a_yaw_joint', 'a')
    plant.coulomb *= stiction_factor
    plant.stiction *= stiction_factor
    controller.command(mode, 'a')
    start = plant.position
    _, outputs = run(controller, plant, int(seconds / T), Setpoint(position=start + 0.0036))
    return plant.position - start, outputs


def test_joint_1_stuck_in_fine_under_a_higher_friction_breaks_away_and_arrives():
    """A fine line of joint 1 against 1.3 times the identified friction reaches its setpoint.

    Its fine gains (0.7 rad/s, Ti 4 s) add hundredths of a N*m over a few mrad: without the
    compensation's rise the joint does not move at all.
    """
    moved, outputs = _stuck_joint_1(SETTINGS, 1.3)
    assert moved == pytest.approx(0.0036, abs=SETTINGS.control.in_position_tolerance[0])
    level = SETTINGS.friction_level(1)
    assert max(abs(o.friction_compensation) for o in outputs) > 1.3 * level
    assert max(abs(o.friction_compensation) for o in outputs) <= 1.5 * level + 1e-9
    off = replace_in_section(SETTINGS, {'control.friction_compensation.breakaway_limit':
                                        [0.0, 0.0, 0.0, 0.0, 0.0]})
    stuck, _ = _stuck_joint_1(off, 1.3)
    assert stuck == 0.0


def test_the_compensation_rises_only_while_stuck_in_fine_and_never_past_its_limit():
    """The compensation rises only while stuck in FINE, and never past its limit.

    In COARSE it never rises; stuck beyond the limit, it stops at ``1 + breakaway_limit`` of
    its level; once the joint has arrived (the error within the ramp) it is back at its level.
    """
    level = SETTINGS.friction_level(1)
    _, outputs = _stuck_joint_1(SETTINGS, 1.3, seconds=4.0)
    assert abs(outputs[-1].friction_compensation) <= level + 1e-9
    _, outputs = _stuck_joint_1(SETTINGS, 1.3, mode=Mode.COARSE)
    assert max(abs(o.friction_compensation) for o in outputs) <= level + 1e-9
    moved, outputs = _stuck_joint_1(SETTINGS, 2.0, seconds=4.0)  # the mode switch's transfer
    assert moved == 0.0                                          # decays by then
    assert abs(outputs[-1].friction_compensation) == pytest.approx(1.5 * level, rel=1e-3)
