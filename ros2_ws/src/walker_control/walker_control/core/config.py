"""The controllers' parameter sections, validated as a whole, stability check included.

The ``control:`` group of ``walker_core/config/walker.yaml`` holds *design quantities*, per mode
and per joint role J1..J5 (lists of five), not raw gains:

* ``control.<mode>.bandwidth`` ``wc`` [rad/s], ``damping`` ``zc`` and ``integral_time`` ``Ti``
  [s] (0: no integral action) for the modes ``coarse``, ``fine`` and ``hold``;
  ``control.coarse.acceleration_feedback`` ``Ka`` (paper: joint 1 only);
* ``control.filter``: ``kind`` (``bessel``, ``critical`` or ``butterworth``), ``order``
  and ``corner`` ``wf`` [rad/s] per role;
* ``control.friction_compensation``: the fraction of the identified breakaway friction
  (``robot.drive.*.stiction_torque``) to apply, and the deadband and ramp per role [rad];
* ``control.relaxation``: the decaying dither that relaxes the closed chain when a HOLD command
  changes the base gripper (a step's end: both grippers attached);
* ``control.stability``: the inertia mismatch the loops must tolerate and the minimum damping;
* tolerances, the bumpless transfer time constant and the input timeouts.

The gains follow from the rigid model at the current configuration: ``Kp = I wc^2``,
``Kd = 2 zc wc I``, ``Ki = Kp / Ti``, with ``I = I_ii(q)`` of eqs (9)-(13). The design is thus
the same at every configuration, and the file says what a control engineer designs with.

:class:`ControllerSettings` joins the robot, timing and control sections. Building it runs the
stability check (:func:`check_controller_settings`) on every role and mode, so an unstable set
can never be constructed: the node refuses to start with it and refuses a runtime update to it.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any
from collections.abc import Mapping

from walker_core.parameter_file import ParameterFile
from walker_core.parameter_schema import ParameterError, parameter, section_from_flat
from walker_core.robot_parameters import Drive, RobotParameters, TimingParameters
from walker_control.core.input_shaping import ShaperDesignError, ShaperKind, design_shaper
from walker_control.core.lowpass import FILTER_KINDS, FilterDesignError, design_lowpass_sos
from walker_control.core.modes import GAIN_MODES, Mode
from walker_control.core.relaxation import RelaxationDither
from walker_control.core.stability import (
    LoopDesign, LoopReport, UnstableLoopError, check_loop, inertia_ratio_grid)

__all__ = [
    'ROLES', 'UnstableControllerError', 'ModeGains', 'CoarseGains', 'FilterSettings',
    'FrictionCompensationSettings', 'RelaxationSettings', 'StabilitySettings', 'ShapingSettings',
    'ControlParameters', 'ControllerSettings', 'check_controller_settings',
    'load_controller_settings', 'relaxation_frequency_factor',
]

ROLES = (1, 2, 3, 4, 5)
_INERTIA_RATIO_POINTS = 9


class UnstableControllerError(ParameterError):
    """A controller parameter set fails the stability check; the message says where and why."""


def _require_five(section: Any, *names: str) -> None:
    for name in names:
        values = getattr(section, name)
        if len(values) != len(ROLES):
            raise ValueError(f'{name} needs one value per joint role J1..J5 (5), '
                             f'got {len(values)}: {list(values)}')


@dataclasses.dataclass(frozen=True)
class ModeGains:
    """Design quantities of one mode, per joint role J1..J5."""

    bandwidth: tuple[float, ...] = parameter(
        'desired closed-loop frequency wc of roles J1..J5', 'rad/s', 0.01, 500.0, read_only=False,
        source='chosen: the largest passing the stability check (coarse lower than fine, as '
               'paper section 2)')
    damping: tuple[float, ...] = parameter(
        'desired closed-loop damping ratio zc of roles J1..J5', '', 0.05, 10.0, read_only=False,
        source='paper eq (16): unit damping')
    integral_time: tuple[float, ...] = parameter(
        'integral time Ti of roles J1..J5, Ki = Kp / Ti (0: no integral action)',
        's', 0.0, 1000.0, read_only=False,
        source='paper section 2: integral action in fine motion; chosen: Ti wc from 2.8 to 5')

    def __post_init__(self) -> None:
        _require_five(self, 'bandwidth', 'damping', 'integral_time')


@dataclasses.dataclass(frozen=True)
class CoarseGains(ModeGains):
    """Coarse-motion design: low gains and acceleration feedback (paper sections 2 and 4)."""

    acceleration_feedback: tuple[float, ...] = parameter(
        'acceleration feedback gain Ka of roles J1..J5 in coarse motion',
        '', 0.0, 20.0, read_only=False,
        source="paper section 4: Ka on J1; chosen: 0.25, the check's best damping")

    def __post_init__(self) -> None:
        super().__post_init__()
        _require_five(self, 'acceleration_feedback')


@dataclasses.dataclass(frozen=True)
class FilterSettings:
    """The digital low-pass filter of each role (paper section 3)."""

    kind: str = parameter(
        "low-pass filter family of the filtered roles (critical is eq (14)'s)",
        choices=FILTER_KINDS, read_only=False,
        source='chosen: Bessel, the flattest group delay at the same attenuation')
    order: tuple[int, ...] = parameter(
        'filter order of roles J1..J5 (0: unfiltered)', '', 0, 8, read_only=False,
        source='paper section 3: J1 of higher order than J2-J3, J4-J5 unfiltered')
    corner: tuple[float, ...] = parameter(
        'filter corner frequency wf of roles J1..J5 (ignored when unfiltered)',
        'rad/s', 0.0, 1000.0, read_only=False,
        source='paper section 3: J1 lower than J2-J3; chosen: -31 dB at 18 rad/s, -17 dB at 80 '
               'rad/s')
    reference: bool = parameter(
        'shape each setpoint with the role filter too (two-degree-of-freedom control)',
        read_only=False,
        source="chosen: J1 would lag a sweep by the filter's delay; false is the paper's "
               'structure')
    setpoint_order: tuple[int, ...] = parameter(
        'order of a filter the setpoints of roles J1..J5 pass outside the loop (0: none)',
        '', 0, 8, read_only=False,
        source='paper: none')
    setpoint_corner: tuple[float, ...] = parameter(
        'corner frequency of the setpoint filter of roles J1..J5 (ignored without one)',
        'rad/s', 0.0, 1000.0, read_only=False,
        source='paper: none')

    def __post_init__(self) -> None:
        _require_five(self, 'order', 'corner', 'setpoint_order', 'setpoint_corner')
        for what, orders, corners in (('', self.order, self.corner),
                                      ('setpoint_', self.setpoint_order,
                                       self.setpoint_corner)):
            for role, (order, corner) in enumerate(zip(orders, corners, strict=True), 1):
                if order > 0 and corner <= 0.0:
                    raise ValueError(f'{what}corner of role J{role} must be > 0 rad/s when its '
                                     f'{what}order is {order}')


@dataclasses.dataclass(frozen=True)
class FrictionCompensationSettings:
    """The friction compensator (paper section 3), per role."""

    fraction: float = parameter(
        'compensation torque as a fraction of the breakaway friction '
        'robot.drive.*.stiction_torque', '', 0.0, 1.5, read_only=False,
        source='paper section 3: a constant torque signed by the error; chosen: the breakaway '
               'level')
    deadband: tuple[float, ...] = parameter(
        'position error of roles J1..J5 below which no compensation is applied',
        'rad', 0.0, 1.0, read_only=False,
        source='chosen: J1-J3 stop within 0.45 mm of tip, J4 within 0.2 mm')
    ramp: tuple[float, ...] = parameter(
        'error range of roles J1..J5 over which the compensation rises to its full level',
        'rad', 1e-6, 1.0, read_only=False,
        source='chosen: continuous, so it cannot chatter at rest')
    feedforward_speed: float = parameter(
        'setpoint speed at which the friction feed-forward reaches tanh(1) of it (0: none)',
        'rad/s', 0.0, 10.0, read_only=False,
        source='chosen: 1 % of the cruise speed')
    breakaway_limit: tuple[float, ...] = parameter(
        'rise of the compensation of roles J1..J5 over its level while stuck in FINE (0: none)',
        '', 0.0, 1.0, read_only=False,
        source='chosen: J1, whose fine gains break no stiction, up to the 1.35 times the '
               'campaigns draw')
    breakaway_rate: float = parameter(
        "rise of a stuck joint's compensation in FINE, in multiples of its level per second",
        '1/s', 0.0, 100.0, read_only=False,
        source='chosen: 30 % of the level within a fine line')

    def __post_init__(self) -> None:
        _require_five(self, 'deadband', 'ramp', 'breakaway_limit')


@dataclasses.dataclass(frozen=True)
class RelaxationSettings:
    """The decaying dither after a base change (:mod:`walker_control.core.relaxation`)."""

    amplitude: float = parameter(
        "initial dither amplitude, in multiples of each joint's breakaway friction",
        '', 0.0, 10.0, read_only=False,
        source='chosen: relaxes a 1.0 mm bend to 0.01 mm on the plant')
    frequency: float = parameter(
        'dither frequency of role J1; role Jk dithers at (1 + (k - 1) / 4) times it',
        'Hz', 0.1, 250.0, read_only=False,
        source='chosen: the joints dither in step, so none slides')
    duration: float = parameter(
        'time over which the dither after a change of base decays to zero (0: none)',
        's', 0.0, 5.0, read_only=False,
        source='chosen: about four cycles')


@dataclasses.dataclass(frozen=True)
class ShapingSettings:
    """The input shaper on the setpoints of each role, outside the loop (input_shaping)."""

    kind: str = parameter(
        "input shaper family of the shaped roles (none: the paper's structure, no shaper)",
        choices=tuple(kind.value for kind in ShaperKind), read_only=False,
        source='paper: none; chosen: see docs/controllers.md, command shaping')
    frequency: tuple[float, ...] = parameter(
        "flexible-mode frequency each role's shaper cancels (0: that role unshaped)",
        'rad/s', 0.0, 1000.0, read_only=False,
        source='paper: none; chosen: 18 rad/s, the joint-1 mode (robot.flexibility.joint1_mode)')
    damping: float = parameter(
        'damping ratio of the shaped modes (SI: the bound holds from 0 to it)',
        '', 0.0, 0.5, read_only=False,
        source="chosen: the structure's 5 % (robot.flexibility.damping_ratio)")
    tolerance: float = parameter(
        'residual vibration EI and SI allow, per unit of the unshaped residual',
        '', 0.001, 0.5, read_only=False,
        source='chosen: 5 %, the usual EI tolerance')
    insensitivity: float = parameter(
        'SI: the relative half-width of the frequency range it holds the tolerance over',
        '', 0.01, 0.9, read_only=False,
        source="chosen: the campaigns' +-15 % mode dispersion")

    def __post_init__(self) -> None:
        _require_five(self, 'frequency')

    def design(self, role: int, sample_time: float):
        """Return the role's shaper (:class:`.input_shaping.Shaper`), or None unshaped."""
        frequency = self.frequency[role - 1]
        if self.kind == ShaperKind.NONE.value or frequency <= 0.0:
            return None
        return design_shaper(ShaperKind(self.kind), frequency, self.damping, self.tolerance,
                             self.insensitivity, sample_time)


@dataclasses.dataclass(frozen=True)
class StabilitySettings:
    """What the stability check demands of every loop."""

    inertia_ratio_min: float = parameter(
        'smallest ratio of model to true inertia every loop must tolerate',
        '', 0.05, 1.0, read_only=False,
        source='chosen: a gain margin of 2 (6 dB)')
    inertia_ratio_max: float = parameter(
        'largest ratio of model to true inertia every loop must tolerate',
        '', 1.0, 20.0, read_only=False,
        source="chosen: a gain margin of 2 (6 dB); covers the diagonal model's neglect of "
               'coupling')
    minimum_damping: float = parameter(
        'smallest acceptable damping ratio of any closed-loop pole of the sampled loop',
        '', 0.0, 1.0, read_only=False,
        source='chosen: an oscillation decays to 1/e within about 1.6 periods')


@dataclasses.dataclass(frozen=True)
class ControlParameters:
    """Everything under ``control.`` in the parameter file."""

    filter: FilterSettings
    coarse: CoarseGains
    fine: ModeGains
    hold: ModeGains
    friction_compensation: FrictionCompensationSettings
    relaxation: RelaxationSettings
    stability: StabilitySettings
    shaping: ShapingSettings
    in_position_tolerance: tuple[float, ...] = parameter(
        'fine-motion position tolerance of roles J1..J5: the joint has arrived within it',
        'rad', 1e-6, 1.0, read_only=False,
        source='chosen: J1-J3 about 1 mm at the 0.9 m reach; J4 0.3 mm of tip')
    bumpless_time_constant: float = parameter(
        'time constant of the decay of the transfer offset after a mode or role change',
        's', 0.001, 10.0, read_only=False,
        source="chosen: about J1's filter delay")
    setpoint_timeout: float = parameter(
        'a tracking controller holds when no setpoint arrived for this long',
        's', 0.005, 60.0, read_only=False,
        source='chosen: stalls of up to 0.4 s were measured on a loaded 2-core machine')
    state_timeout: float = parameter(
        'a controller holds when no joint state arrived for this long',
        's', 0.005, 60.0, read_only=False,
        source='chosen: as setpoint_timeout')
    setpoint_extrapolation: float = parameter(
        'longest time a late streamed setpoint is carried along its velocity (0: held)',
        's', 0.0, 1.0, read_only=False,
        source='chosen: 25 periods')
    sim_time_setpoint_wait: float = parameter(
        'sim time: longest wall-clock wait of a state for the setpoint its stream owes (0: none)',
        's', 0.0, 10.0, read_only=False,
        source='chosen: a starved planner slows the simulation instead of changing the motion')
    state_rate: float = parameter(
        'rate of the controller state messages (plots and bags)',
        'Hz', 1.0, 5000.0, read_only=False,
        source='chosen: every 5th period; each message costs CPU')

    def __post_init__(self) -> None:
        _require_five(self, 'in_position_tolerance')
        if self.setpoint_extrapolation > self.setpoint_timeout:
            raise ParameterError(
                f'control.setpoint_extrapolation ({self.setpoint_extrapolation:g} s) must not '
                f'exceed control.setpoint_timeout ({self.setpoint_timeout:g} s): a stream that '
                f'stopped is held, then refused as stale, never carried on')
        if self.sim_time_setpoint_wait >= self.state_timeout:
            raise ParameterError(
                f'control.sim_time_setpoint_wait ({self.sim_time_setpoint_wait:g} s) must be '
                f'below control.state_timeout ({self.state_timeout:g} s): while one joint waits '
                f'for its setpoint the plant sends no state, and the other joints would take '
                f'the state stream for stopped')

    def gains(self, mode: Mode) -> ModeGains:
        """Return the gain section of ``mode`` (HOLD, COARSE or FINE)."""
        if mode not in GAIN_MODES:
            raise ValueError(f'mode {Mode(mode).name} has no gains')
        return getattr(self, Mode(mode).key)


@dataclasses.dataclass(frozen=True)
class ControllerSettings:
    """The sections a joint controller uses, validated together (stability check included)."""

    robot: RobotParameters
    timing: TimingParameters
    control: ControlParameters

    def __post_init__(self) -> None:
        check_controller_settings(self)
        filters = self.control.filter
        for role, (order, corner) in enumerate(zip(filters.setpoint_order,
                                                   filters.setpoint_corner, strict=True), 1):
            try:  # built on a role's first tracking sample: refused here, not in the loop
                design_lowpass_sos(order, corner, self.sample_time, filters.kind)
            except FilterDesignError as error:
                raise ParameterError(f'control.filter.setpoint_corner of role J{role}: '
                                     f'{error}') from None
        for role in ROLES:  # designed once here (cached): refused here, not in the loop
            try:
                self.control.shaping.design(role, self.sample_time)
            except ShaperDesignError as error:
                raise ParameterError(f'control.shaping of role J{role}: {error}') from None
        relaxation = self.control.relaxation
        highest = relaxation.frequency * relaxation_frequency_factor(ROLES[-1])
        if relaxation.duration > 0.0 and highest > self.timing.control_rate / 4:
            raise ParameterError(
                f'control.relaxation.frequency ({relaxation.frequency:g} Hz) makes role '
                f'J{ROLES[-1]} dither at {highest:g} Hz, above a quarter of timing.control_rate '
                f'({self.timing.control_rate:g} Hz)')

    @classmethod
    def from_flat(cls, flat: Mapping[str, Any]) -> 'ControllerSettings':
        """Build and validate from flat dotted names (``control.fine.bandwidth``, ...)."""
        return section_from_flat(cls, flat)

    @property
    def sample_time(self) -> float:
        """Control period [s]."""
        return 1.0 / self.timing.control_rate

    def drive(self, role: int) -> Drive:
        """Drive (torque limit, friction, joint limits) of role ``role``."""
        return self.robot.drive.for_role(role)

    def loop_design(self, role: int, mode: Mode) -> LoopDesign:
        """Normalised loop design of role ``role`` (1..5) in ``mode`` (HOLD, COARSE, FINE)."""
        if role not in ROLES:
            raise ValueError(f'joint role must be 1..5, got {role!r}')
        gains = self.control.gains(mode)
        i = role - 1
        ka = gains.acceleration_feedback[i] if isinstance(gains, CoarseGains) else 0.0
        return LoopDesign(
            bandwidth=gains.bandwidth[i], damping=gains.damping[i],
            integral_time=gains.integral_time[i], acceleration_feedback=ka,
            filter_order=self.control.filter.order[i], filter_corner=self.control.filter.corner[i],
            filter_kind=self.control.filter.kind)

    def friction_level(self, role: int) -> float:
        """Friction compensation torque of role ``role`` [N*m]."""
        return self.control.friction_compensation.fraction * self.drive(role).stiction_torque

    def relaxation(self, role: int) -> RelaxationDither:
        """Return the relaxation dither of role ``role`` (amplitude clamped at its torque limit).

        Each role dithers at its own frequency, ``frequency * (1 + (role - 1) / 4)``: in the
        closed chain, dithers in step push the links as one and no joint slides (measured on
        the plant), while distinct frequencies let each joint in turn find a net torque.
        """
        drive, relax = self.drive(role), self.control.relaxation
        amplitude = min(relax.amplitude * drive.stiction_torque, drive.torque_limit)
        return RelaxationDither(amplitude, relax.frequency * relaxation_frequency_factor(role),
                                relax.duration)


def relaxation_frequency_factor(role: int) -> float:
    """Ratio of role ``role``'s relaxation frequency to ``control.relaxation.frequency``."""
    return 1.0 + (role - 1) / 4.0


def _parameter_names(mode: Mode, role: int) -> str:
    key = mode.key
    extra = f', control.{key}.acceleration_feedback' if mode == Mode.COARSE else ''
    return (f'control.{key}.bandwidth/damping/integral_time{extra} and control.filter.* '
            f'(element {role - 1}, role J{role})')


def check_controller_settings(settings: ControllerSettings) -> dict[tuple[int, Mode], LoopReport]:
    """Run the stability check on every role and mode; return the report of each loop.

    For each role J1..J5 and each of hold, coarse and fine: the paper's condition eq (15) with
    the filter corner as ``wf`` where it applies (a 2nd-order critically damped filter; the
    report of a loop says what judged it), and the closed-loop poles of the sampled loop
    (:func:`walker_control.core.stability.check_loop`) at the control period, with and without
    one period of delay, over the inertia ratios of ``control.stability``.

    Raises
    ------
    UnstableControllerError
        Naming the role, the mode, the parameters and the failing figure.
    ParameterError
        If a filter cannot be built at the control rate (corner above Nyquist).
    """
    stability = settings.control.stability
    ratios = inertia_ratio_grid(stability.inertia_ratio_min, stability.inertia_ratio_max,
                                _INERTIA_RATIO_POINTS)
    reports = {}
    for role in ROLES:
        for mode in GAIN_MODES:
            design = settings.loop_design(role, mode)
            label = f'joint role J{role}, mode {mode.key}'
            try:
                reports[role, mode] = check_loop(
                    design, settings.sample_time, label=label, inertia_ratios=ratios,
                    minimum_damping=stability.minimum_damping)
            except UnstableLoopError as error:
                raise UnstableControllerError(
                    f'{error} -- refused; check {_parameter_names(mode, role)}') from None
            except ValueError as error:
                raise ParameterError(f'{label}: {error}') from None
    return reports


def load_controller_settings(path: str | Path | None = None) -> ControllerSettings:
    """Load and validate the controller settings from a ``ros__parameters`` YAML file.

    Raises
    ------
    ParameterError
        Naming the missing or invalid parameter, or the loop that fails the stability check.
    """
    return ParameterFile.read(path).section(ControllerSettings)
