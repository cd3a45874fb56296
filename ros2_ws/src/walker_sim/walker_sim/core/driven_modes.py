"""The flexible modes joint 1's coarse motion excites, with the joint held or under its loop.

:mod:`walker_sim.core.flexibility` sizes the links' springs on the *held* arm at the default
stance (joint 1's mode, 18 rad/s, is the lowest out-of-plane mode with all five joints held).
During the coarse motion joint 1 is not held: it slides (Coulomb friction is then a constant
torque, no stiffness) under its coarse loop, a soft PD whose command passes a low-pass filter
(paper eq (14)), so the mode its command excites is another. An input shaper on joint 1's
setpoints must be designed for *that* mode, over the configurations the motion passes and the
plant's dispersion. This module computes it by linearisation, on the plant core's own model.

The linearised loop
-------------------
The plant: :func:`walker_sim.core.flexibility.linear_model` (pybullet's mass matrix of the URDF
the plant loads, rotors folded into their joints) with the bending springs and dampers of
:func:`walker_sim.core.flexibility.tune_flexibility`; no gravity (the walker's zero g), no
friction (a sliding joint's Coulomb friction is a constant torque, which does not change the
modes). Each actuated joint is either *held* (its degree of freedom removed: a brake, or a joint
stuck in its stiction) or under its *loop*, the controller as it runs, sampled at the control
period ``T`` (sim-time lock-step):

    v = -I wc^2 theta - 2 zc wc I omega - Ka I m + u,      tau = F(z) v

(:mod:`walker_control.core.stability`'s loop on the flexible plant: ``I = I_ii(q)`` the rigid
model's diagonal inertia, eqs (9)-(13), ``m`` the mean acceleration of the last period,
``F(z)`` the discrete command filter, ``u`` the feed-forward torque, zero-order held). The
plant is discretised exactly under the zero-order hold. The closed loop's poles ``z`` give each
mode's natural frequency ``|s|`` and damping ratio ``-Re(s) / |s|``, ``s = ln(z) / T``.

Which poles are flexible modes, and which is dominant
-----------------------------------------------------
A pole is a *flexible mode* when, in its eigenvector, the bending springs' potential energy is
at least :data:`FLEXIBLE_ENERGY_SHARE` of the kinetic energy (a structural mode has them equal
on average; a loop or filter pole that moves the arm rigidly bends the links only
quasi-statically, ``(w / w_flex)^2`` of it) and it is damped less than
:data:`walker_sim.core.identification.MAX_DAMPING`. Its *weight* is how far it rings the tip
where the coarse motion sees it: the amplitude [m per N*m] of its ringing in the tip's
deflection by bending (the gripper's displacement that the joint angles do not account for)
after a unit step of joint 1's feed-forward torque ``u`` (the bang-bang plan's command is a
sequence of such steps). The *dominant* mode is the flexible mode of largest weight.

The held case (all five joints held, the springs' definition) has no input at joint 1; its modes
and weights are those of :meth:`LinearModel.held_joint_modes` (the reaction at joint 1's brake),
and its damping ratios follow from the stiffness-proportional damping,
``zeta_k = zeta w_k / w_target``.

The plant's dispersion
----------------------
The campaigns disperse the plant's modes (``robot.flexibility.joint1_mode`` and
``joints23_mode``) by a factor ``f``; the springs are then ``f^2`` times stiffer and the
dampers (``c = 2 zeta k / w_target``) ``f`` times stronger. ``mode_scale`` applies the same to
the nominal tuning, per plane, without re-tuning.
"""

from __future__ import annotations

import dataclasses
import enum
import math
from collections.abc import Mapping

import numpy as np
import pybullet
import scipy.linalg
from scipy import signal

from walker_core.dynamics import RigidModel, diagonal_inertia
from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_core.kinematics import WalkerKinematics
from walker_core.urdf import GRIPPER_LINKS
from walker_sim.core.flexibility import (
    IDENTIFIED_JOINTS, VISIBLE_RESIDUE, FlexTuning, LinearModel, linear_model, posed_plant)
from walker_sim.core.identification import MAX_DAMPING, NYQUIST_MARGIN

__all__ = ['Plane', 'JointLoop', 'ExcitedMode', 'StanceModel', 'stance_at', 'stance_model',
           'held_modes', 'driven_modes', 'dominant_mode', 'FLEXIBLE_ENERGY_SHARE',
           'MIN_FREQUENCY', 'DRIVEN_JOINT']

#: Joint 1 with gripper a as base: the joint whose coarse motion is shaped.
DRIVEN_JOINT = IDENTIFIED_JOINTS[0]
#: Smallest ratio of the bending springs' potential energy to the kinetic energy in a pole's
#: eigenvector for it to count as a flexible mode (a structural mode: 1 on average).
FLEXIBLE_ENERGY_SHARE = 0.5
#: Lowest frequency [rad/s] considered a flexible mode (as the identification's fit).
MIN_FREQUENCY = 2.0
_DEADBEAT = 1e-9


class Plane(enum.Enum):
    """Bending plane (the names of :data:`walker_sim.core.flexibility.JOINT_PLANES`)."""

    IN_PLANE = 'in_plane'
    OUT_OF_PLANE = 'out_of_plane'


@dataclasses.dataclass(frozen=True)
class JointLoop:
    """One joint's loop in one mode, in design quantities (normalised to unit inertia).

    Attributes
    ----------
    bandwidth : float
        ``wc`` [rad/s].
    damping : float
        ``zc``.
    acceleration_feedback : float
        ``Ka``.
    filter_sos : ndarray, shape (n, 6)
        The discrete command filter ``F(z)`` at the control period, second-order sections
        (:func:`walker_control.core.lowpass.design_lowpass_sos`); no rows for no filter.
    """

    bandwidth: float
    damping: float
    acceleration_feedback: float = 0.0
    filter_sos: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 6)))

    def __post_init__(self) -> None:
        for name in ('bandwidth', 'damping'):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f'joint loop {name} must be positive, got {value!r}')
        if not math.isfinite(self.acceleration_feedback) or self.acceleration_feedback < 0.0:
            raise ValueError(f'joint loop acceleration_feedback must be >= 0, '
                             f'got {self.acceleration_feedback!r}')
        sos = np.asarray(self.filter_sos, dtype=float)
        if sos.ndim != 2 or sos.shape[1] != 6 or not np.all(np.isfinite(sos)):
            raise ValueError(f'joint loop filter_sos must be finite second-order sections of '
                             f'shape (n, 6), got shape {sos.shape}')

    def filter_state_space(self) -> tuple[np.ndarray, ...]:
        """Return ``(A, B, C, D)`` of the discrete filter (a passthrough without sections)."""
        if len(self.filter_sos) == 0:
            return np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), np.ones((1, 1))
        return signal.tf2ss(*signal.sos2tf(np.asarray(self.filter_sos, dtype=float)))


@dataclasses.dataclass(frozen=True)
class ExcitedMode:
    """A flexible mode and how strongly joint 1's command rings it.

    Attributes
    ----------
    frequency : float
        Undamped natural frequency [rad/s].
    damping : float
        Damping ratio.
    weight : float
        Driven: the amplitude [m/(N*m)] of its ringing in the tip's bending deflection after a
        unit step of joint 1's feed-forward torque. Held: ``(M_1b phi)^2`` [kg*m^2], its
        reaction at joint 1's brake (:meth:`LinearModel.held_joint_modes`).
    plane : Plane
        The bending plane whose springs store most of the mode's energy (joint 1 turns the arm
        plane: its own modes are out of plane).
    """

    frequency: float
    damping: float
    weight: float
    plane: Plane = Plane.OUT_OF_PLANE


@dataclasses.dataclass(frozen=True)
class StanceModel:
    """The plant linearised at one stance, with the tip's bending Jacobian.

    Attributes
    ----------
    model : LinearModel
        Inertia over the five joints and the bending joints.
    tip_jacobian : ndarray, shape (3, len(model.names))
        Linear velocity [m/s] of gripper b's frame origin per unit rate of each degree of
        freedom, in the base frame.
    inertia : ndarray, shape (5,)
        The rigid model's diagonal inertia ``I_ii`` [kg*m^2] (eqs (9)-(13)) that scales the
        controllers' gains at this stance.
    """

    model: LinearModel
    tip_jacobian: np.ndarray
    inertia: np.ndarray


def stance_at(params, sweep: float, reach: float, height: float = 0.0) -> np.ndarray:
    """Joint angles [rad] with the tip at ``reach`` from the base yaw axis, turned by ``sweep``.

    Parameters
    ----------
    params : WalkerParameters
    sweep : float
        Joint 1's angle ``Theta`` [rad]: the tip at ``reach (-sin Theta, cos Theta, height)``
        (the node-to-node motion's polar coordinates).
    reach : float
        Horizontal distance ``r`` [m] of gripper b from the base yaw axis.
    height : float
        Height [m] of gripper b above gripper a.

    Raises
    ------
    ValueError
        If the point is out of reach or the stance outside the joint limits.
    """
    if not (math.isfinite(sweep) and math.isfinite(reach) and math.isfinite(height)
            and reach > 0.0):
        raise ValueError(f'stance needs a finite sweep and height and a positive reach, got '
                         f'sweep={sweep!r}, reach={reach!r}, height={height!r}')
    kinematics = WalkerKinematics.from_parameters(params)
    pose = [-reach * math.sin(sweep), reach * math.cos(sweep), height, 0.0, 0.0]
    return kinematics.inverse(pose, reference=[sweep, 0.0, 0.0, 0.0, 0.0])


def stance_model(params, stance) -> StanceModel:
    """Linearise the plant at ``stance`` [rad] (gripper a attached) and take its tip Jacobian."""
    stance = np.asarray(stance, dtype=float)
    model = linear_model(params, stance)
    gear = params.robot.drive.role_array('gear_ratio')
    with posed_plant(params, stance) as plant:
        zero = [0.0] * len(plant.positions)
        linear, _ = pybullet.calculateJacobian(
            plant.body, plant.index.links[GRIPPER_LINKS['b']], [0.0, 0.0, 0.0],
            plant.positions.tolist(), zero, zero, physicsClientId=plant.client)
    full = np.asarray(linear, dtype=float)
    transform = plant.reduced(model.names, gear)
    inertia = diagonal_inertia(stance, RigidModel.from_parameters(params))
    return StanceModel(model=model, tip_jacobian=full @ transform, inertia=inertia)


def _scale_of(mode_scale: Mapping[Plane, float] | None, plane: Plane) -> float:
    """Return the dispersion factor of one plane's modes (1 when not given), checked."""
    factor = 1.0 if mode_scale is None else mode_scale.get(plane, 1.0)
    if not (isinstance(factor, (int, float)) and math.isfinite(factor) and factor > 0.0):
        raise ValueError(f'mode_scale of {plane.value} must be a positive number, '
                         f'got {factor!r}')
    return float(factor)


def _springs(model: LinearModel, tuning: FlexTuning, mode_scale: Mapping[Plane, float]
             ) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness [N*m/rad] and damping [N*m*s/rad] of each bending joint, dispersed."""
    stiffness, damping = [], []
    for name in model.planes.values():
        factor = _scale_of(mode_scale, Plane(name))
        stiffness.append(tuning.stiffness_of(name) * factor ** 2)
        damping.append(tuning.damping_of(name) * factor)
    return np.array(stiffness), np.array(damping)


def held_modes(stance: StanceModel, tuning: FlexTuning, damping_ratio: float,
               mode_scale: Mapping[Plane, float] | None = None,
               targets: Mapping[Plane, float] | None = None,
               visible: float = VISIBLE_RESIDUE) -> list[ExcitedMode]:
    """Modes seen at joint 1's brake with all five joints held (the springs' definition).

    Parameters
    ----------
    stance : StanceModel
    tuning : FlexTuning
        The nominal springs (:func:`walker_sim.core.flexibility.tune_flexibility`).
    damping_ratio : float
        ``robot.flexibility.damping_ratio``: the damping of each plane's target mode.
    mode_scale : mapping Plane -> float, optional
        The plant's dispersion per plane (module docstring).
    targets : mapping Plane -> float, optional
        Each plane's target mode [rad/s] the dampers were sized for (default: joint 1's 18 and
        joints 2-3's 80 rad/s as the tuning predicts them).
    visible : float
        Fraction of the largest weight below which a mode is left out (0: every mode of
        joint 1's plane).

    Returns
    -------
    list of ExcitedMode
        The held arm's modes in joint 1's plane that ring at its brake (weight at least
        ``visible`` of the largest), ascending in frequency.
    """
    out_scale = _scale_of(mode_scale, Plane.OUT_OF_PLANE)
    in_scale = _scale_of(mode_scale, Plane.IN_PLANE)
    targets = ({Plane.OUT_OF_PLANE: tuning.predicted[DRIVEN_JOINT],
                Plane.IN_PLANE: tuning.predicted[IDENTIFIED_JOINTS[1]]}
               if targets is None else targets)
    frequencies, residues = stance.model.held_joint_modes(
        DRIVEN_JOINT, tuning.in_plane_stiffness * in_scale ** 2,
        tuning.out_of_plane_stiffness * out_scale ** 2)
    target = targets[Plane.OUT_OF_PLANE] * out_scale
    seen = residues >= visible * residues.max()
    return [ExcitedMode(frequency=float(w), damping=damping_ratio * float(w) / target,
                        weight=float(r))
            for w, r in zip(frequencies[seen], residues[seen], strict=True)]


def _closed_loop(stance: StanceModel, tuning: FlexTuning, loops: Mapping[str, JointLoop],
                 sample_time: float, mode_scale: Mapping[Plane, float]
                 ) -> tuple[np.ndarray, np.ndarray, list[str], int, np.ndarray, np.ndarray]:
    """Build the sampled closed loop ``x+ = A x + B u`` (u: joint 1's feed-forward torque)."""
    model = stance.model
    bends = list(model.planes)
    dofs = [name for name in PHYSICAL_JOINT_NAMES if name in loops] + bends
    index = [model.names.index(name) for name in dofs]
    n = len(dofs)
    mass = model.mass[np.ix_(index, index)]
    k_bend, c_bend = _springs(model, tuning, mode_scale)
    stiffness = np.diag(np.concatenate([np.zeros(n - len(bends)), k_bend]))
    damping = np.diag(np.concatenate([np.zeros(n - len(bends)), c_bend]))
    inverse = np.linalg.inv(mass)
    actuated = [dofs.index(name) for name in loops]
    a_c = np.block([[np.zeros((n, n)), np.eye(n)],
                    [-inverse @ stiffness, -inverse @ damping]])
    b_c = np.vstack([np.zeros((n, len(actuated))), inverse[:, actuated]])
    # exact zero-order-hold discretisation
    block = np.zeros((2 * n + len(actuated), 2 * n + len(actuated)))
    block[:2 * n, :2 * n] = a_c * sample_time
    block[:2 * n, 2 * n:] = b_c * sample_time
    exponential = scipy.linalg.expm(block)
    a_d, b_d = exponential[:2 * n, :2 * n], exponential[:2 * n, 2 * n:]
    # controller states per loop: the last velocity (for the measured acceleration), the filter
    parts = [(name, *loops[name].filter_state_space()) for name in loops]
    size = 2 * n + sum(1 + af.shape[0] for _, af, *_ in parts)
    a = np.zeros((size, size))
    b = np.zeros(size)
    a[:2 * n, :2 * n] = a_d
    offset = 2 * n
    for column, (name, af, bf, cf, df) in enumerate(parts):
        loop, joint = loops[name], dofs.index(name)
        inertia = stance.inertia[PHYSICAL_JOINT_NAMES.index(name)]
        nf = af.shape[0]
        previous, filter_slice = offset, slice(offset + 1, offset + 1 + nf)
        # v = k_row x + u (u only at joint 1); m = (omega - previous) / T
        k_row = np.zeros(size)
        k_row[joint] = -inertia * loop.bandwidth ** 2
        k_row[n + joint] = -2.0 * loop.damping * loop.bandwidth * inertia
        ka = loop.acceleration_feedback * inertia / sample_time
        k_row[n + joint] -= ka
        k_row[previous] += ka
        feed = 1.0 if name == DRIVEN_JOINT else 0.0
        torque_row = np.zeros(size)
        torque_row[filter_slice] = cf.ravel()
        torque_row += float(df.ravel()[0]) * k_row
        torque_feed = float(df.ravel()[0]) * feed
        a[:2 * n] += np.outer(b_d[:, column], torque_row)
        b[:2 * n] += b_d[:, column] * torque_feed
        a[previous, n + joint] = 1.0
        a[filter_slice, filter_slice] = af
        a[filter_slice] += np.outer(bf.ravel(), k_row)
        b[filter_slice] += bf.ravel() * feed
        offset += 1 + nf
    bend_columns = [model.names.index(name) for name in bends]
    tip = np.zeros((3, size))
    tip[:, n - len(bends):n] = stance.tip_jacobian[:, bend_columns]
    return a, b, dofs, n, tip, np.concatenate([np.zeros(n - len(bends)), k_bend])


def driven_modes(stance: StanceModel, tuning: FlexTuning, loops: Mapping[str, JointLoop],
                 sample_time: float, mode_scale: Mapping[Plane, float] | None = None,
                 visible: float = VISIBLE_RESIDUE) -> list[ExcitedMode]:
    """Flexible modes of the arm with joint 1 (and any other joint in ``loops``) under its loop.

    Parameters
    ----------
    stance : StanceModel
        The plant linearised at the stance (:func:`stance_model`).
    tuning : FlexTuning
        The nominal springs and dampers.
    loops : mapping joint name -> JointLoop
        The joints under their loops; it must contain joint 1 (``a_yaw_joint``); the joints not
        in it are held.
    sample_time : float
        Control period ``T`` [s].
    mode_scale : mapping Plane -> float, optional
        The plant's dispersion per plane (module docstring).
    visible : float
        Fraction of the largest weight below which a mode is left out (0: every flexible mode,
        of either plane).

    Returns
    -------
    list of ExcitedMode
        The closed loop's flexible modes (module docstring) rung by joint 1's command (weight at
        least ``visible`` of the largest), ascending in frequency.

    Raises
    ------
    ValueError
        If joint 1 has no loop, a joint name is unknown, the period is not positive, or the
        closed loop is unstable (a pole outside the unit circle).
    """
    unknown = [name for name in loops if name not in PHYSICAL_JOINT_NAMES]
    if unknown or DRIVEN_JOINT not in loops:
        raise ValueError(f'loops must name physical joints {PHYSICAL_JOINT_NAMES} and include '
                         f'{DRIVEN_JOINT}, got {sorted(loops)}')
    if not (math.isfinite(sample_time) and sample_time > 0.0):
        raise ValueError(f'sample_time must be a positive period [s], got {sample_time!r}')
    ordered = {name: loops[name] for name in PHYSICAL_JOINT_NAMES if name in loops}
    a, b, dofs, n, tip, k_diag = _closed_loop(stance, tuning, ordered, sample_time,
                                              {} if mode_scale is None else mode_scale)
    poles, right = np.linalg.eig(a)
    if np.max(np.abs(poles)) >= 1.0:
        raise ValueError(f'the closed loop is unstable: a pole of magnitude '
                         f'{np.max(np.abs(poles)):.6f} at the stance {stance.model.stance}')
    left_b = np.linalg.solve(right, b)
    index = [stance.model.names.index(name) for name in dofs]
    mass = stance.model.mass[np.ix_(index, index)]
    planes = list(stance.model.planes.values())
    nyquist = math.pi / sample_time
    modes = []
    for k, z in enumerate(poles):
        if abs(z) < _DEADBEAT:
            continue  # a pole at the origin: a pure delay, not a mode
        s = np.log(complex(z)) / sample_time
        frequency = abs(s)
        if s.imag <= 0.0 or frequency < MIN_FREQUENCY or s.imag > NYQUIST_MARGIN * nyquist:
            continue
        damping = -s.real / frequency
        vector = right[:, k]
        stored = np.real(np.conj(vector[:n]) * k_diag * vector[:n])
        potential = float(stored.sum())
        kinetic = float(np.real(np.vdot(vector[n:2 * n], mass @ vector[n:2 * n])))
        if damping > MAX_DAMPING or potential < FLEXIBLE_ENERGY_SHARE * kinetic:
            continue
        # step of u: the mode's part of the response is c v (w b) (1 - z^n) / (1 - z); the
        # conjugate pole doubles its amplitude
        amplitude = 2.0 * np.linalg.norm(tip @ vector * left_b[k] / (1.0 - z))
        out_of_plane = sum(stored[n - len(planes) + i] for i, name in enumerate(planes)
                           if name == Plane.OUT_OF_PLANE.value)
        plane = Plane.OUT_OF_PLANE if out_of_plane >= 0.5 * potential else Plane.IN_PLANE
        modes.append(ExcitedMode(frequency=float(frequency), damping=float(damping),
                                 weight=float(amplitude), plane=plane))
    if not modes:
        return []
    largest = max(mode.weight for mode in modes)
    return sorted((m for m in modes if m.weight >= visible * largest),
                  key=lambda mode: mode.frequency)


def dominant_mode(modes: list[ExcitedMode]) -> ExcitedMode:
    """Return the mode of largest weight.

    Raises
    ------
    ValueError
        If there is none.
    """
    if not modes:
        raise ValueError('no flexible mode is excited')
    return max(modes, key=lambda mode: mode.weight)
