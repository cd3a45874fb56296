"""The joint controller of Figure 3: feed-forward, PID, acceleration feedback, filter, friction.

Structure (one sample, ``I = I_ii(q)`` the rigid-model inertia of the joint's role at the
current configuration, eqs (9)-(13))::

    theta_r, omega_r, a_r                 the setpoint; through the role's input shaper and
                                          setpoint filter G first, outside the loop, if on
    e   = F theta_r - theta,  de = F omega_r - omega   (reference shaped by the filter F)
    v   = I a_r + effort_r + f(omega_r)       feed-forward (rigid model, Coulomb friction)
        + I wc^2 e + integral + 2 zc wc I de  PID (integral only with Ti > 0)
        - Ka I (a_measured - F a_r)           acceleration feedback (coarse, joint 1; F a_r = 0
                                          without reference shaping, as in the paper)
        + transfer                            bumpless-transfer offset (decays)
    y   = F(z) clamp(v, +-tau_max)            low-pass filter (joints 1-3)
    tau = clamp(y + friction(e) + friction transfer, +-tau_max)

The filter sits on the whole command, feed-forward and acceleration feedback included, exactly
where the paper's eq (14) puts it: ``s^2 theta = F(s) [u - Ka s^2 theta]``; so the analysis of
section 4 and the stability check describe the loop that runs, and no part of the command can
excite the structural modes that the filter is there to keep out. The feedback compares the
joint with the setpoint shaped by the same filter (``control.filter.reference``,
:mod:`~walker_control.core.reference_shaping`): the motion the filtered feed-forward produces,
so the filter's delay is not an error to fight. A role without a command filter can pass its
setpoints through a filter of their own first (``control.filter.setpoint_order`` and
``setpoint_corner``, none as shipped), outside its loop: joint 4 (the moving wrist) through
joints 2 and 3's command filter keeps step with them, and a Cartesian line stays straighter
(leading them by their filters' 56-58 ms, it swings a descent 2.4 mm off the hole's axis).
An input shaper (``control.shaping``, :mod:`~walker_control.core.input_shaping`) can shape a
role's setpoints before that, outside the loop too, against a flexible mode.
The Coulomb friction the setpoint's velocity will meet is part of the feed-forward
(``control.friction_compensation.feedforward_speed``,
:func:`~walker_control.core.friction_compensation.friction_feedforward`). The friction
compensator is added after the filter: it cancels a plant nonlinearity, and the filter's delay
(about 0.5 s for joint 1) would keep it pushing long after the error changed sign.

Modes (:class:`~walker_control.core.modes.Mode`): OFF (zero torque), HOLD (hold the position at
which HOLD was entered; no integral action), COARSE and FINE (follow the setpoint; before the
first setpoint, hold the position at which the mode was entered). A latched hold (stale input,
refused setpoint) forces HOLD until the next mode command. A HOLD command that changes the base
gripper (a step's end, both grippers attached) first runs the relaxation dither of
``control.relaxation`` (:mod:`~walker_control.core.relaxation`) alone, then holds where the joint
came to rest.

Bumpless transfer: on a change of mode, role or parameters, the integral is reset and an offset
``transfer = v_before - v_new`` makes the filter's input continuous; it then decays with the
time constant ``control.bumpless_time_constant``. When the change brings a different filter (a
role swap), the new filter is initialised at the steady state of the old filter's output and
the input is matched to that output. The acceleration feedback is left out of both sides: it
answers the acceleration measured now (carried as an offset, one ringing sample's answer would
be held for the time constant). The friction term gets its own decaying offset. The torque
therefore moves by no more than its normal change over one sample.
"""

from __future__ import annotations

import dataclasses
import math
import operator
from collections.abc import Sequence
from typing import NamedTuple

from walker_core.dynamics import RigidModel, role_inertia
from walker_core.joint_roles import role_of_joint, role_permutation, validate_gripper
from walker_control.core.accel_feedback import acceleration_feedback_torque
from walker_control.core.config import ControllerSettings
from walker_control.core.feedforward import RigidFeedForward
from walker_control.core.friction_compensation import FrictionCompensator, friction_feedforward
from walker_control.core.inputs import Setpoint
from walker_control.core.lowpass import LowPassFilter
from walker_control.core.modes import Mode
from walker_control.core.pid import Pid, PidGains
from walker_control.core.reference_shaping import InputShapedSetpoint, RestartingShaper
from walker_control.core.stability import LoopDesign

__all__ = ['Measurement', 'ControlOutput', 'RoleChangeError', 'MeasurementError',
           'MissingAccelerationError', 'JointController', 'STUCK_VELOCITY']


class RoleChangeError(ValueError):
    """The base gripper may change only while the controller holds or is off."""


class MeasurementError(ValueError):
    """A measurement the controller cannot use (non-finite, or missing an acceleration)."""


class MissingAccelerationError(MeasurementError):
    """Acceleration feedback is on but no measured acceleration was given."""


class Measurement(NamedTuple):
    """The joint's measured state, and the configuration of the whole robot (immutable).

    Attributes
    ----------
    position : float
        [rad]
    velocity : float
        [rad/s]
    acceleration : float or None
        [rad/s^2]; None when not available (only acceleration feedback needs it).
    joint_positions : sequence of 5 float
        Angles of the five physical joints [rad], in the order of
        :data:`walker_core.joint_roles.PHYSICAL_JOINT_NAMES`, for the inertia.
    """

    position: float
    velocity: float
    acceleration: float | None
    joint_positions: Sequence[float]


class ControlOutput(NamedTuple):
    """One controller sample: the command and every term, for the state message and plots.

    Torques in N*m, angles in rad, rates in rad/s. ``feedforward`` to ``acceleration_feedback``
    and ``transfer`` are before the filter; ``friction_compensation`` (with its transfer offset)
    and ``effort`` after it. ``reference`` is the setpoint in force as commanded;
    ``shaped_reference`` the same after the role's setpoint filter and reference shaping, which
    ``position_error`` is measured from (equal to ``reference`` when neither is on).
    """

    effort: float
    mode: Mode
    role: int
    reference: Setpoint
    position_error: float
    inertia: float
    feedforward: float
    proportional: float
    integral: float
    derivative: float
    acceleration_feedback: float
    transfer: float
    filtered: float
    friction_compensation: float
    saturated: bool
    shaped_reference: Setpoint | None = None


#: Most control periods the filters catch up in one sample (0.2 s at 500 Hz: longer gaps are
#: stale inputs, and the controller holds).
_MAX_CATCH_UP_PERIODS = 100
#: [rad/s] A joint slower than this under its full friction compensation is stuck in its
#: friction (the plant's stiction band is 1e-3 rad/s; a stuck joint reads 0).
STUCK_VELOCITY = 1e-4


@dataclasses.dataclass(frozen=True)
class _RoleDesign:
    """What one role in one mode takes from the settings: derived once, used every sample.

    The controller runs hundreds of times a second in a process shared with others; building
    these from the settings on every sample cost more than the control law itself.
    """

    loop: LoopDesign
    kp: float               # normalised gains (LoopDesign.kp, .ki, .kd)
    ki: float
    kd: float
    torque_limit: float     # [N*m]
    coulomb: float          # [N*m] drive friction, for the friction feed-forward
    friction: tuple         # (level, deadband, ramp) of the friction compensator
    compensator: FrictionCompensator
    shaping: tuple | None   # the reference shaper's design, None without shaping
    setpoint_filter: tuple | None  # the setpoint filter's design, None without one
    input_shaper: tuple | None  # (Shaper, sample_time) of control.shaping, None without one


def _clamp(value: float, limit: float) -> float:
    return max(-limit, min(limit, value))


class JointController:
    """Controller of one physical joint (paper Figure 3), in whichever role it plays.

    Parameters
    ----------
    settings : ControllerSettings
        Validated robot, timing and control parameters.
    joint_name : str
        Physical joint, one of :data:`walker_core.joint_roles.PHYSICAL_JOINT_NAMES`.
    base_gripper : {'a', 'b'}
        Gripper that is the base: sets the joint's role J1..J5.

    Raises
    ------
    ValueError
        For an unknown joint or gripper.
    """

    def __init__(self, settings: ControllerSettings, joint_name: str,
                 base_gripper: str = 'a') -> None:
        self._joint_name = joint_name
        self._set_base(validate_gripper(base_gripper))
        self._take_settings(settings)
        self._commanded = Mode.HOLD
        self._hold_reason = ''
        limit = settings.drive(self.role).torque_limit
        self._pid = Pid(PidGains(0.0, 0.0, 0.0, limit, limit))
        self._gains_of: tuple | None = None  # (inertia, role design) the PID's gains are of
        self._filter = self._new_filter(self.role)
        self._filter.reset_to(0.0)
        self._shaper = RestartingShaper()  # reference shaping (control.filter.reference)
        self._setpoint_filter = RestartingShaper()  # control.filter.setpoint_*
        self._input_shaper = RestartingShaper(InputShapedSetpoint)  # control.shaping
        self._key: tuple[int, Mode] | None = None
        self._design: object = None
        self._hold_position = 0.0
        self._last_command = 0.0  # [N*m] the filter's input before its clamp
        self._last_acceleration_feedback = 0.0
        self._last_friction = 0.0
        self._transfer = 0.0
        self._friction_transfer = 0.0
        self._breakaway_extra = 0.0  # the compensation's rise while stuck, in its level
        self._breakaway_sign = 1.0  # the sign of the error it rose for
        self._saturation = 0.0
        self._last_output: ControlOutput | None = None
        self._relaxing_for: float | None = None  # [s] into the relaxation dither, if on
        self._role_designs: dict[tuple[int, Mode], _RoleDesign] = {}
        self._design_used: _RoleDesign | None = None

    # ---------------------------------------------------------------------------- properties
    @property
    def joint_name(self) -> str:
        """Physical joint controlled."""
        return self._joint_name

    @property
    def base_gripper(self) -> str:
        """Gripper that is the base."""
        return self._base

    @property
    def role(self) -> int:
        """Role J1..J5 the joint plays for the current base."""
        return self._role

    def _set_base(self, base: str) -> None:
        """Take ``base`` as the base gripper: the joint's role and the role order of the joints.

        Raises
        ------
        ValueError
            For an unknown joint.
        """
        self._role = role_of_joint(self._joint_name, base)
        self._base = base
        self._in_role_order = operator.itemgetter(*role_permutation(base))

    @property
    def settings(self) -> ControllerSettings:
        """Parameters in force."""
        return self._settings

    @property
    def commanded_mode(self) -> Mode:
        """Mode last commanded (ControlMode)."""
        return self._commanded

    @property
    def hold_reason(self) -> str:
        """Why a hold is latched ('' when none)."""
        return self._hold_reason

    @property
    def mode(self) -> Mode:
        """Mode in effect: OFF if commanded, else HOLD while a hold is latched, else commanded."""
        if self._commanded == Mode.OFF:
            return Mode.OFF
        return Mode.HOLD if self._hold_reason else self._commanded

    @property
    def last_output(self) -> ControlOutput | None:
        """The output of the last :meth:`update`, or None before the first."""
        return self._last_output

    # ------------------------------------------------------------------------------ commands
    def command(self, mode: Mode, base_gripper: str | None = None) -> None:
        """Apply a mode command; it also releases a latched hold.

        Raises
        ------
        RoleChangeError
            If the base gripper changes while the controller tracks setpoints (COARSE or FINE)
            and is commanded to go on tracking: the role may change only on the way into, or
            out of, HOLD or OFF. Nothing changes.
        ValueError
            For an unknown mode or gripper; nothing changes.
        """
        mode = Mode(mode)
        base = self._base if base_gripper is None else validate_gripper(base_gripper)
        if base != self._base and self.mode.tracks_setpoints and mode.tracks_setpoints:
            raise RoleChangeError(
                f'{self._joint_name}: base gripper change {self._base!r} -> {base!r} refused '
                f'from {self.mode.name} to {mode.name}: the role may change only while holding '
                f'or off')
        if mode == Mode.HOLD and base != self._base \
                and self._settings.control.relaxation.duration > 0.0:
            self._relaxing_for = 0.0
        elif mode != Mode.HOLD:  # the same HOLD again leaves a relaxation running
            self._relaxing_for = None
        if base != self._base:
            self._set_base(base)
        self._commanded = mode
        self._hold_reason = ''

    def hold(self, reason: str) -> None:
        """Latch HOLD (a stale input, a refused setpoint) until the next :meth:`command`."""
        if not self._hold_reason:
            self._hold_reason = reason or 'hold requested'
        self._relaxing_for = None

    def apply_settings(self, settings: ControllerSettings) -> None:
        """Use new (validated) parameters from the next sample on, with bumpless transfer."""
        self._take_settings(settings)
        self._role_designs = {}

    def _take_settings(self, settings: ControllerSettings) -> None:
        """Keep the settings, and what every sample reads of them, once."""
        self._settings = settings
        self._feedforward = RigidFeedForward(RigidModel.from_parameters(settings))
        self._sample_time = settings.sample_time  # [s]
        self._feedforward_speed = settings.control.friction_compensation.feedforward_speed
        self._breakaway_limits = settings.control.friction_compensation.breakaway_limit
        self._breakaway_rate = settings.control.friction_compensation.breakaway_rate  # [1/s]
        self._bumpless_time_constant = settings.control.bumpless_time_constant  # [s]
        self._decay_of: tuple[float, float] = (math.nan, math.nan)  # (dt, its decay)

    def _breakaway(self, mode: Mode, role: int, compensator: FrictionCompensator,
                   error: float, velocity: float, dt: float) -> float:
        """Return the factor on the compensation: above 1 while a joint is stuck in FINE.

        The compensation cancels the identified breakaway friction; a drive whose friction is
        higher than identified (a cold drive, wear) stays stuck under its full compensation when
        its gains are too low for the PID to add the rest soon (joint 1 in FINE: a few mrad of
        error give hundredths of a N*m). While the error is past the compensation's ramp and the
        joint does not move (slower than :data:`STUCK_VELOCITY`), the factor rises by
        ``breakaway_rate`` [1/s] up to ``1 + breakaway_limit`` of the role; it is kept while
        the joint moves and falls back to 1 once the error is within the ramp or changes sign,
        or in another mode.
        """
        limit = self._breakaway_limits[role - 1]
        full = compensator.deadband + compensator.ramp
        if mode != Mode.FINE or limit <= 0.0 or abs(error) < full \
                or (error > 0.0) != (self._breakaway_sign > 0.0):
            self._breakaway_extra = 0.0
            self._breakaway_sign = 1.0 if error > 0.0 else -1.0
            return 1.0
        if abs(velocity) < STUCK_VELOCITY:
            self._breakaway_extra = min(limit, self._breakaway_extra + self._breakaway_rate * dt)
        return 1.0 + self._breakaway_extra

    # ------------------------------------------------------------------------------- update
    def update(self, measurement: Measurement, setpoint: Setpoint | None,
               dt: float) -> ControlOutput:
        """Compute the effort for one sample.

        Parameters
        ----------
        measurement : Measurement
            Measured state of the joint and the robot's configuration.
        setpoint : Setpoint or None
            The setpoint in force (already validated); None when there is none yet. Ignored in
            HOLD and OFF.
        dt : float
            Time since the previous sample [s], > 0.

        Returns
        -------
        ControlOutput

        Raises
        ------
        MeasurementError
            If the measurement is not finite, or acceleration feedback is on and the
            acceleration is missing. Nothing changes.
        ValueError
            If ``dt`` is not a positive number of seconds. Nothing changes.
        """
        if not (isinstance(dt, (int, float)) and math.isfinite(dt) and dt > 0.0):
            raise ValueError(f'dt must be a positive number of seconds, got {dt!r}')
        configuration = self._check_measurement(measurement)
        mode = self.mode
        if mode == Mode.OFF:
            return self._off(measurement)
        if self._relaxing_for is not None:
            output = self._relax(measurement, dt)
            if output is not None:
                return output
        role = self.role
        cached = self._role_design(role, mode)
        design = cached.loop
        if design.acceleration_feedback > 0.0 and measurement.acceleration is None:
            raise MissingAccelerationError(
                f'{self._joint_name}: acceleration feedback is on (role J{role}, mode '
                f'{mode.key}) but no joint acceleration was measured')
        transition = (role, mode) != self._key
        friction_design = cached.friction
        redesign = transition or (cached is not self._design_used
                                  and (design, friction_design) != self._design)
        if transition:
            self._hold_position = measurement.position
        periods = self._periods(dt)
        restart = not self._keeps_tracking(transition)
        if setpoint is not None and mode.tracks_setpoints:
            received = setpoint
            shaped = self._input_shaper.update(cached.input_shaper, restart, measurement.position,
                                               measurement.velocity, setpoint, periods)
            commanded = self._filter_setpoint(cached.setpoint_filter, restart, measurement,
                                              shaped, periods)
        else:
            self._setpoint_filter.stop()
            self._input_shaper.stop()
            received = commanded = Setpoint(position=self._hold_position)
        reference = self._shape(cached.shaping, restart, measurement, commanded, periods)

        # the configuration is checked (_check_measurement): the model's term directly
        inertia = role_inertia(configuration, self._feedforward.model, role)
        limit = cached.torque_limit
        if (inertia, cached) != self._gains_of:  # the gains scale with the inertia
            self._pid.set_gains(PidGains(p=inertia * cached.kp, i=inertia * cached.ki,
                                         d=inertia * cached.kd, output_limit=limit,
                                         integral_limit=limit))
            self._gains_of = (inertia, cached)
        error = reference.position - measurement.position
        error_rate = reference.velocity - measurement.velocity
        feedforward = self._feedforward.torque(
            inertia, commanded.acceleration,
            commanded.effort + friction_feedforward(
                cached.coulomb, commanded.velocity,
                self._feedforward_speed))
        acceleration = measurement.acceleration if measurement.acceleration is not None else 0.0
        if self._shaper.active:  # feed back the acceleration error (reference_shaping)
            acceleration -= reference.acceleration
        accel_term = acceleration_feedback_torque(design.acceleration_feedback, inertia,
                                                  acceleration)
        friction = cached.compensator.torque(error) * self._breakaway(
            mode, role, cached.compensator, error, measurement.velocity, dt)

        if redesign:
            self._bumpless_transfer(role, transition, cached.ki > 0.0,
                                    feedforward + accel_term + self._pid.gains.p * error
                                    + self._pid.gains.d * error_rate, friction, accel_term,
                                    limit)
            self._key, self._design = (role, mode), (design, friction_design)
        self._design_used = cached

        hold_integral = self._saturation != 0.0 and (error > 0.0) == (self._saturation > 0.0)
        terms = self._pid.compute_command(error, error_rate, dt, hold_integral=hold_integral)
        command = feedforward + terms.command + accel_term + self._transfer
        filter_input = _clamp(command, limit)
        filtered = self._filter.update(filter_input, periods)
        friction_total = friction + self._friction_transfer
        total = filtered + friction_total
        effort = _clamp(total, limit)
        if not math.isfinite(effort):  # cannot happen with finite inputs; never publish NaN
            raise FloatingPointError(f'{self._joint_name}: non-finite effort computed')
        clamped_input = filter_input != command
        clamped_output = effort != total
        if clamped_output:
            self._saturation = math.copysign(1.0, total)
        elif clamped_input:
            self._saturation = math.copysign(1.0, command)
        else:
            self._saturation = 0.0
        output = ControlOutput(  # in the order of its fields (by position: the faster)
            effort, mode, role, received, error, inertia, feedforward, terms.proportional,
            terms.integral, terms.derivative, accel_term, self._transfer, filtered,
            friction_total, clamped_input or clamped_output or terms.saturated, reference)
        decay_dt, decay = self._decay_of
        if dt != decay_dt:  # the same dt every period: exp once
            decay = math.exp(-dt / self._bumpless_time_constant)
            self._decay_of = (dt, decay)
        self._transfer *= decay
        self._friction_transfer *= decay
        self._last_command = command
        self._last_acceleration_feedback = accel_term
        self._last_friction = friction_total
        self._last_output = output
        return output

    # ------------------------------------------------------------------------------ helpers
    def _check_measurement(self, measurement: Measurement) -> tuple[float, ...]:
        """Return the configuration in role order; raise :class:`MeasurementError` if unusable.

        Plain floats, no arrays: this runs every control period.
        """
        positions = measurement.joint_positions
        acceleration = measurement.acceleration
        isfinite = math.isfinite
        try:
            valid = (isfinite(measurement.position) and isfinite(measurement.velocity)
                     and (acceleration is None or isfinite(acceleration))
                     and len(positions) == 5 and all(map(isfinite, positions)))
        except TypeError:
            valid = False
        if not valid:
            raise MeasurementError(f'{self._joint_name}: measurement refused, not finite or not '
                                   f'5 joint positions: {measurement!r}')
        return tuple(map(float, self._in_role_order(positions)))

    def _periods(self, dt: float) -> int:
        """Control periods a sample of ``dt`` seconds spans (1 to ``_MAX_CATCH_UP_PERIODS``).

        The filters are discrete at the control period. A controller that missed states (a
        starved process in real time) advances them over every period that passed, its input
        held, as the plant held the last effort: run once per sample instead, a filter would
        slow down with the controller (joint 1's 0.5 s delay doubling when every other state
        is missed) and the loop would lose the phase margin its stability check counted on.
        """
        return min(_MAX_CATCH_UP_PERIODS, max(1, round(dt / self._sample_time)))

    def _keeps_tracking(self, transition: bool) -> bool:
        """Return True unless this sample enters or leaves HOLD, or changes the role."""
        return not transition or (
            self._key is not None and self._key[0] == self.role
            and self._key[1].tracks_setpoints and self.mode.tracks_setpoints)

    def _filter_setpoint(self, design: tuple | None, restart: bool,
                         measurement: Measurement, setpoint: Setpoint,
                         periods: int) -> Setpoint:
        """Return the setpoint through the role's setpoint filter, if it has one.

        ``design`` is ``(order, corner, sample_time, kind)`` of ``control.filter.setpoint_*``,
        None for a role without. The filter is outside the loop: the feed-forward and the
        reference shaper take its output as the setpoint. It restarts at the joint's measured
        state when tracking begins (from HOLD, on a role change) and when its design changes,
        and advances by ``periods`` control periods, as the command filter does.
        """
        return self._setpoint_filter.update(design, restart, measurement.position,
                                            measurement.velocity, setpoint, periods)

    def _shape(self, design: tuple | None, restart: bool, measurement: Measurement,
               commanded: Setpoint, periods: int) -> Setpoint:
        """Return the setpoint the feedback compares with: shaped by the role's filter, if on.

        ``design`` is the shaper's ``(order, corner, sample_time, kind)``, None when
        ``control.filter.reference`` is off. The shaper keeps running through a change between
        tracking modes of the same role (a moving setpoint goes on moving); it restarts at the
        joint's measured state on the way into or out of HOLD, on a role change and when the
        filter's design changes. It advances by ``periods`` control periods (:meth:`_periods`),
        holding the setpoint over them, as the command filter does.
        """
        return self._shaper.update(design, restart, measurement.position,
                                   measurement.velocity, commanded, periods)

    def _role_design(self, role: int, mode: Mode) -> _RoleDesign:
        """Return the settings of ``role`` in ``mode``, derived once per settings (_RoleDesign)."""
        cached = self._role_designs.get((role, mode))
        if cached is None:
            settings = self._settings
            control = settings.control
            loop = settings.loop_design(role, mode)
            friction = (settings.friction_level(role),
                        control.friction_compensation.deadband[role - 1],
                        control.friction_compensation.ramp[role - 1])
            drive = settings.drive(role)
            # designing the shaper's filter with scipy costs far more than a sample: the design
            # is compared, and the filter built only when it changes
            shaping = ((control.filter.order[role - 1], control.filter.corner[role - 1],
                        settings.sample_time, control.filter.kind)
                       if control.filter.reference else None)
            setpoint_order = control.filter.setpoint_order[role - 1]
            setpoint_filter = ((setpoint_order, control.filter.setpoint_corner[role - 1],
                                settings.sample_time, control.filter.kind)
                               if setpoint_order > 0 else None)
            input_shaper = control.shaping.design(role, settings.sample_time)
            cached = _RoleDesign(loop=loop, kp=loop.kp, ki=loop.ki, kd=loop.kd,
                                 torque_limit=drive.torque_limit, coulomb=drive.friction_torque,
                                 friction=friction, compensator=FrictionCompensator(*friction),
                                 shaping=shaping, setpoint_filter=setpoint_filter,
                                 input_shaper=(None if input_shaper is None
                                               else (input_shaper, settings.sample_time)))
            self._role_designs[(role, mode)] = cached
        return cached

    def _new_filter(self, role: int) -> LowPassFilter:
        settings = self._settings
        return LowPassFilter(settings.control.filter.order[role - 1],
                             settings.control.filter.corner[role - 1], settings.sample_time,
                             settings.control.filter.kind)

    def _bumpless_transfer(self, role: int, transition: bool, integral_on: bool,
                           raw_without_integral: float, friction: float,
                           acceleration_feedback: float, limit: float) -> None:
        """Match the new command to the old one (see the module notes).

        The acceleration feedback is not carried over: it answers the acceleration measured
        now, in the mode that has it, and is left out of both sides. Carried as an offset it
        held one sample's reaction for ``bumpless_time_constant``: a 8 N*m answer to a ringing
        joint 1 at the end of a real-time coarse motion pushed the joint 30 mrad off in FINE.
        The old input without it is the old command without it, clamped at ``limit`` [N*m]
        as the filter's input is (not the clamped input less the feedback, which is off by
        what the clamp cut when the feedback drove the command past the limit).
        """
        new_filter = self._new_filter(role)
        if new_filter.same_design(self._filter):
            target = _clamp(self._last_command - self._last_acceleration_feedback, limit)
            raw_without_integral -= acceleration_feedback
        else:
            target = self._filter.output
            new_filter.reset_to(target)
            self._filter = new_filter
        if transition or not integral_on:
            self._pid.reset(0.0)
        self._transfer = target - (raw_without_integral + self._pid.integral_term)
        self._friction_transfer = self._last_friction - friction

    def _relax(self, measurement: Measurement, dt: float) -> ControlOutput | None:
        """One sample of the relaxation dither; None once it has ended (HOLD takes over).

        The dither alone drives the joint: feedback would hold it against the bend it is to
        slide out of. When it ends, HOLD starts afresh where the joint came to rest (as after
        OFF, from a zero torque).
        """
        dither = self._settings.relaxation(self.role)
        elapsed = self._relaxing_for
        if dither.done(elapsed):
            self._relaxing_for = None
            return None
        self._relaxing_for = elapsed + dt
        output = self._off(measurement)
        output = output._replace(effort=dither.torque(elapsed), mode=Mode.HOLD)
        self._last_output = output
        return output

    @property
    def relaxing(self) -> bool:
        """True while the relaxation dither runs (after a HOLD that changed the base)."""
        return self._relaxing_for is not None

    def _off(self, measurement: Measurement) -> ControlOutput:
        self._filter.reset_to(0.0)
        self._shaper.stop()
        self._setpoint_filter.stop()
        self._input_shaper.stop()
        self._pid.reset(0.0)
        self._transfer = self._friction_transfer = 0.0
        self._last_command = self._last_friction = 0.0
        self._last_acceleration_feedback = 0.0
        self._saturation = 0.0
        self._key, self._design = (self.role, Mode.OFF), None
        self._design_used = None
        output = ControlOutput(
            effort=0.0, mode=Mode.OFF, role=self.role,
            reference=Setpoint(position=measurement.position), position_error=0.0, inertia=0.0,
            feedforward=0.0, proportional=0.0, integral=0.0, derivative=0.0,
            acceleration_feedback=0.0, transfer=0.0, filtered=0.0, friction_compensation=0.0,
            saturated=False)
        self._last_output = output
        return output
