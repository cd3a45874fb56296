"""Measure the structural modes seen at each joint on the simulated plant.

The test, as one would run it on the hardware's test rig: gripper a screwed into a node,
gripper b free at its neighbour, the default stance; the joint under test frictionless and
driven by a torque doublet (``+tau`` then ``-tau``, each ``pulse_width`` long: no net impulse,
so the stance does not drift), the other four joints held still; its velocity is recorded at
the control rate while it rings. The record is fitted with a sum of exponentially decaying
sinusoids (poles by the matrix pencil method, amplitudes by linear least squares), giving each
mode's natural frequency, damping ratio and residue. The mode
*seen at the joint* is the lowest one whose residue is not negligible, as defined in
:mod:`walker_sim.core.flexibility`, so the measured figure can be compared with the predicted
one and with the paper's 18 and 80 rad/s.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import scipy.linalg

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_sim.core.config import SimParameters, StartConfiguration
from walker_sim.core.flexibility import IDENTIFIED_JOINTS, first_visible_mode
from walker_sim.core.plant import WalkerPlant

__all__ = ['FittedMode', 'JointModes', 'Excitation', 'ring_joint', 'fit_modes',
           'identify_joint', 'identify_modes', 'target_mode', 'RIG_SOLVER_ITERATIONS',
           'RIG_SOLVER_RESIDUAL']

# Longest record the matrix pencil sees (longer ones are decimated) and the width of its
# Hankel matrix: enough for a handful of modes, and an SVD of well under a second.
_MAX_SAMPLES = 1500
_PENCIL_COLUMNS = 400
#: The held joints' brakes need a well converged constraint solver: with pybullet's default
#: 50 iterations the joints-2/3 modes come out about 2% off and spurious poles appear; with
#: these they match the linearised model to 0.1%.
RIG_SOLVER_ITERATIONS = 300
RIG_SOLVER_RESIDUAL = 1e-12


@dataclasses.dataclass(frozen=True)
class Excitation:
    """The torque doublet and the record.

    Attributes
    ----------
    torque : float
        Doublet amplitude [N*m] (small: the response stays linear).
    pulse_width : float
        Length [s] of each half of the doublet.
    duration : float
        Length [s] of the record after the doublet.
    """

    torque: float = 1.0
    pulse_width: float = 0.02
    duration: float = 4.0

    def spectrum(self, frequency: float) -> float:
        """Magnitude [N*m*s] of the doublet's Fourier transform at ``frequency`` [rad/s]."""
        return 4.0 * self.torque * math.sin(0.5 * frequency * self.pulse_width) ** 2 / frequency


@dataclasses.dataclass(frozen=True)
class FittedMode:
    """One mode fitted to a joint's free response.

    Attributes
    ----------
    frequency : float
        Undamped natural frequency [rad/s].
    damping : float
        Damping ratio.
    amplitude : float
        Amplitude [rad/s] of the mode in the joint velocity at the end of the excitation
        (time 0 of the record).
    residue : float
        Residue [1/(kg*m^2)] of the mode in the joint's response, estimated as the amplitude
        over the excitation's spectrum at the mode.
    """

    frequency: float
    damping: float
    amplitude: float
    residue: float


@dataclasses.dataclass(frozen=True)
class JointModes:
    """What the identification found at one joint.

    Attributes
    ----------
    joint : str
        Physical joint name.
    modes : tuple of FittedMode
        Every mode fitted, ascending in frequency.
    seen : FittedMode
        The first mode seen at the joint (lowest with a non-negligible residue).
    target : float or None
        The paper's figure for this joint [rad/s] (None for joints 4-5).
    """

    joint: str
    modes: tuple[FittedMode, ...]
    seen: FittedMode
    target: float | None

    @property
    def error(self) -> float | None:
        """Relative difference of the seen mode from the target (None without a target)."""
        return None if self.target is None else self.seen.frequency / self.target - 1.0


def target_mode(params, joint: str) -> float | None:
    """Return the paper's mode for a joint, gripper a as base: 18 rad/s at J1, 80 at J2-J3."""
    flexibility = params.robot.flexibility
    targets = dict(zip(IDENTIFIED_JOINTS, (flexibility.joint1_mode, flexibility.joints23_mode,
                                           flexibility.joints23_mode), strict=True))
    return targets.get(joint)


def ring_joint(plant: WalkerPlant, joint: str, excitation: Excitation, sample_period: float
               ) -> tuple[np.ndarray, np.ndarray]:
    """Strike one joint with the doublet, the others held, and record its velocity.

    Parameters
    ----------
    plant : WalkerPlant
        The plant, at the stance to test; it is modified (friction, holds, time).
    joint : str
        Physical joint name.
    excitation : Excitation
        The doublet and the record length.
    sample_period : float
        Sampling period [s] (a whole number of physics steps).

    Returns
    -------
    time : ndarray
        Sample times [s] from the end of the doublet.
    velocity : ndarray
        Joint velocity [rad/s] at those times.
    """
    index = PHYSICAL_JOINT_NAMES.index(joint)
    held = np.ones(5, dtype=bool)
    held[index] = False
    plant.hold_joints(held)
    plant.enable_friction(held)
    pulse_steps = max(1, round(excitation.pulse_width / sample_period))
    torque = np.zeros(5)
    for sign in (1.0, -1.0):
        torque[index] = sign * excitation.torque
        for _ in range(pulse_steps):
            plant.step(torque, sample_period)
    torque[index] = 0.0
    samples = round(excitation.duration / sample_period)
    velocity = np.empty(samples)
    for k in range(samples):
        velocity[k] = plant.step(torque, sample_period).velocity[index]
    return np.arange(1, samples + 1) * sample_period, velocity


def _basis(time: np.ndarray, poles: np.ndarray) -> np.ndarray:
    """Columns: a constant, then cos and sin decaying at each pole ``-decay + i frequency``."""
    columns = [np.ones_like(time)]
    for pole in poles:
        envelope = np.exp(pole.real * time)
        columns += [envelope * np.cos(pole.imag * time), envelope * np.sin(pole.imag * time)]
    return np.column_stack(columns)


def _matrix_pencil(signal: np.ndarray, period: float, rank_tolerance: float) -> np.ndarray:
    """Poles [1/s] of a sum of damped exponentials (matrix pencil method, Hua and Sarkar).

    The Hankel matrix of the samples has rank equal to the number of exponentials; the
    shift-invariance of its dominant right singular vectors gives ``z = exp(pole * period)``.
    """
    count = len(signal)
    columns = min(count // 3, _PENCIL_COLUMNS)
    hankel = scipy.linalg.hankel(signal[:count - columns], signal[count - columns - 1:])
    _, singular, right = np.linalg.svd(hankel, full_matrices=False)
    rank = int(np.sum(singular > rank_tolerance * singular[0]))
    basis = right[:rank].T
    shift = np.linalg.lstsq(basis[:-1], basis[1:], rcond=None)[0]
    return np.log(np.linalg.eigvals(shift).astype(complex)) / period


def fit_modes(time, signal, excitation: Excitation | None = None, min_frequency: float = 2.0,
              rank_tolerance: float = 1e-3) -> list[FittedMode]:
    """Fit decaying sinusoids to a free response.

    Parameters
    ----------
    time : array_like
        Uniformly spaced sample times [s], from the end of the excitation (amplitudes are
        given at time 0).
    signal : array_like
        The response (joint velocity [rad/s]).
    excitation : Excitation, optional
        The excitation, to turn amplitudes into residues (default: ``Excitation()``).
    min_frequency : float
        Lowest frequency [rad/s] considered a mode (below it: the rigid drift).
    rank_tolerance : float
        Singular values below this fraction of the largest are noise (the solver's residual
        motion of the held joints is below 1e-4 of the response).

    Returns
    -------
    list of FittedMode
        Ascending in frequency.

    Raises
    ------
    ValueError
        If no oscillation is found (nothing rang).

    Notes
    -----
    The poles come from the matrix pencil of the samples (decimated to at most
    :data:`_MAX_SAMPLES`), the amplitudes from a linear least-squares fit of the whole record.
    """
    time = np.asarray(time, dtype=float)
    signal = np.asarray(signal, dtype=float)
    excitation = Excitation() if excitation is None else excitation
    stride = max(1, math.ceil(len(signal) / _MAX_SAMPLES))
    period = (time[1] - time[0]) * stride
    poles = _matrix_pencil(signal[::stride], period, rank_tolerance)
    poles = poles[(poles.imag >= min_frequency) & (poles.real < 0.0)]
    if len(poles) == 0:
        raise ValueError('the response has no decaying oscillation: nothing rang')
    linear, *_ = np.linalg.lstsq(_basis(time, poles), signal, rcond=None)
    modes = []
    for pole, (cosine, sine) in zip(poles, linear[1:].reshape(-1, 2), strict=True):
        natural = abs(pole)
        amplitude = math.hypot(cosine, sine)
        modes.append(FittedMode(frequency=natural, damping=-pole.real / natural,
                                amplitude=amplitude,
                                residue=amplitude / excitation.spectrum(natural)))
    return sorted(modes, key=lambda mode: mode.frequency)


def identify_joint(plant: WalkerPlant, joint: str, start: StartConfiguration,
                   excitation: Excitation | None = None) -> JointModes:
    """Reset the plant to ``start``, ring one joint and fit its modes."""
    excitation = Excitation() if excitation is None else excitation
    plant.reset(start)
    sample_period = 1.0 / plant.params.timing.control_rate
    time, velocity = ring_joint(plant, joint, excitation, sample_period)
    modes = fit_modes(time, velocity, excitation)
    seen_frequency = first_visible_mode([m.frequency for m in modes],
                                        [m.residue for m in modes])
    seen = next(m for m in modes if m.frequency == seen_frequency)
    return JointModes(joint=joint, modes=tuple(modes), seen=seen,
                      target=target_mode(plant.params, joint))


def identify_modes(params, sim: SimParameters, joints=IDENTIFIED_JOINTS,
                   excitation: Excitation | None = None) -> list[JointModes]:
    """Measure the modes seen at each joint, at the default stance, with a fresh plant.

    Gripper a is screwed into ``sim.start.base_node`` and gripper b rests, free, at the first
    neighbour of that node (one truss spacing away: the stance of
    :func:`walker_sim.core.flexibility.default_stance`).
    """
    plant = WalkerPlant(params, sim)
    plant.set_solver(RIG_SOLVER_ITERATIONS, RIG_SOLVER_RESIDUAL)
    try:
        base = sim.start.base_node
        start = StartConfiguration(base_gripper='a', base_node=base,
                                   other_node=plant.truss.neighbors(base)[0],
                                   other_attached=False, other_height=0.0)
        return [identify_joint(plant, joint, start, excitation) for joint in joints]
    finally:
        plant.close()
