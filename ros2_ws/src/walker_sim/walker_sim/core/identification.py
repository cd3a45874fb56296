"""Measure the structural modes seen at each joint on the simulated plant.

The test, as one would run it on the hardware's test rig: gripper a screwed into a node,
gripper b free at its neighbour, the default stance.

* **Held-arm modes** (the modes seen at the joints, as defined in
  :mod:`walker_sim.core.flexibility`): joint i, frictionless, is struck with a torque doublet
  (``+tau`` then ``-tau``, each ``pulse_width`` long: no net impulse, so the stance does not
  drift) while the other four joints are held; then all five joints are held and the reaction
  torque at joint i's brake is recorded at the control rate while the links ring. That torque
  (pybullet's applied motor torque of the held joint, ``PlantState.friction``) is what a joint
  torque sensor or the motor current shows. The strike excites only joint i's bending plane
  (the planes decouple at the stance), so every mode in the record is of that plane.
* **Free-joint resonances** (for information): the same strike, joint i left free while it
  rings, the other four held; joint i's velocity is recorded.

Each record is fitted with a sum of exponentially decaying sinusoids (poles by the matrix
pencil method, amplitudes by linear least squares), giving each mode's natural frequency,
damping ratio and amplitude. The mode *seen* in a record is the lowest whose weight is not
negligible: for the held arm the weight is its torque amplitude at the brake (how strongly it
rings at the joint); for the free joint it is its residue (the velocity amplitude over the
doublet's spectrum at the mode). The measured figures can then be compared with the
eigen-analysis the springs were sized with and with the paper's 18 and 80 rad/s.
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

__all__ = ['FittedMode', 'JointModes', 'Excitation', 'strike_and_hold', 'ring_free_joint',
           'fit_modes', 'identify_joint', 'identify_modes', 'target_mode',
           'RIG_SOLVER_ITERATIONS', 'RIG_SOLVER_RESIDUAL', 'MAX_DAMPING', 'NYQUIST_MARGIN']

# Longest record the matrix pencil sees (longer ones are decimated) and the width of its
# Hankel matrix: enough for a handful of modes, and an SVD of well under a second.
_MAX_SAMPLES = 1500
_PENCIL_COLUMNS = 400
#: The held joints' brakes need a well converged constraint solver: with pybullet's default
#: 50 iterations the joints-2/3 modes come out about 2% off and spurious poles appear; with
#: these they match the linearised model to 0.1%.
RIG_SOLVER_ITERATIONS = 300
RIG_SOLVER_RESIDUAL = 1e-12
#: Largest damping ratio of a fitted pole that counts as a mode (structural modes here are
#: damped 0.02 to 0.2; the brakes' catch is a transient damped near 1).
MAX_DAMPING = 0.5
#: Fraction of the Nyquist frequency above which a fitted pole is not trusted.
NYQUIST_MARGIN = 0.9


@dataclasses.dataclass(frozen=True)
class Excitation:
    """The torque doublet and the records.

    Attributes
    ----------
    torque : float
        Doublet amplitude [N*m] (small: the response stays linear).
    pulse_width : float
        Length [s] of each half of the doublet.
    duration : float
        Length [s] of each record after the doublet.
    """

    torque: float = 1.0
    pulse_width: float = 0.02
    duration: float = 4.0

    def __post_init__(self) -> None:
        for name in ('torque', 'pulse_width', 'duration'):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f'excitation {name} must be a positive number, got {value!r}')

    def spectrum(self, frequency: float) -> float:
        """Magnitude [N*m*s] of the doublet's Fourier transform at ``frequency`` [rad/s]."""
        return 4.0 * self.torque * math.sin(0.5 * frequency * self.pulse_width) ** 2 / frequency


@dataclasses.dataclass(frozen=True)
class FittedMode:
    """One mode fitted to a free response.

    Attributes
    ----------
    frequency : float
        Undamped natural frequency [rad/s].
    damping : float
        Damping ratio.
    amplitude : float
        Amplitude of the mode in the record at time 0 of the record, in the record's unit
        (brake torque [N*m] for the held arm, joint velocity [rad/s] for the free joint).
    weight : float
        What decides whether the mode is seen: the amplitude for the held arm, the residue
        [1/(kg*m^2)] (amplitude over the doublet's spectrum at the mode) for the free joint.
    """

    frequency: float
    damping: float
    amplitude: float
    weight: float


@dataclasses.dataclass(frozen=True)
class JointModes:
    """What the identification found at one joint.

    Attributes
    ----------
    joint : str
        Physical joint name.
    modes : tuple of FittedMode
        Every mode fitted to the brake torque of the held arm, ascending in frequency.
    seen : FittedMode
        The mode seen at the joint: the lowest held-arm mode that rings at its brake.
    target : float or None
        The paper's figure for this joint [rad/s] (None for joints 4-5).
    free_modes : tuple of FittedMode
        Every mode fitted to the joint's velocity with the joint free, the others held.
    free_joint : FittedMode or None
        The free-joint (collocated) resonance: the lowest of ``free_modes`` with a
        non-negligible residue (None when the joint's free response does not ring).
    """

    joint: str
    modes: tuple[FittedMode, ...]
    seen: FittedMode
    target: float | None
    free_modes: tuple[FittedMode, ...] = ()
    free_joint: FittedMode | None = None

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


def _strike(plant: WalkerPlant, index: int, excitation: Excitation,
            sample_period: float) -> None:
    """Apply the doublet to joint ``index``, frictionless, the other joints held."""
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


def strike_and_hold(plant: WalkerPlant, joint: str, excitation: Excitation,
                    sample_period: float) -> tuple[np.ndarray, np.ndarray]:
    """Strike one joint, then hold all five and record the torque at its brake.

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
        Sample times [s] from the moment the joints are all held.
    torque : ndarray
        Reaction torque [N*m] of joint ``joint``'s brake at those times.
    """
    index = PHYSICAL_JOINT_NAMES.index(joint)
    _strike(plant, index, excitation, sample_period)
    plant.hold_joints(np.ones(5, dtype=bool))
    zero = np.zeros(5)
    samples = round(excitation.duration / sample_period)
    torque = np.empty(samples)
    for k in range(samples):
        torque[k] = plant.step(zero, sample_period).friction[index]
    return np.arange(1, samples + 1) * sample_period, torque


def ring_free_joint(plant: WalkerPlant, joint: str, excitation: Excitation,
                    sample_period: float) -> tuple[np.ndarray, np.ndarray]:
    """Strike one joint, the others held, and record its velocity while it rings free.

    Parameters and returns as :func:`strike_and_hold`, but the record is the joint's velocity
    [rad/s] from the end of the doublet.
    """
    index = PHYSICAL_JOINT_NAMES.index(joint)
    _strike(plant, index, excitation, sample_period)
    zero = np.zeros(5)
    samples = round(excitation.duration / sample_period)
    velocity = np.empty(samples)
    for k in range(samples):
        velocity[k] = plant.step(zero, sample_period).velocity[index]
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
              rank_tolerance: float = 1e-3, max_damping: float = MAX_DAMPING
              ) -> list[FittedMode]:
    """Fit decaying sinusoids to a free response.

    Parameters
    ----------
    time : array_like
        Uniformly spaced sample times [s], from the start of the free response (amplitudes are
        given at time 0).
    signal : array_like
        The response (brake torque [N*m] or joint velocity [rad/s]).
    excitation : Excitation, optional
        The doublet that excited a free joint: each mode's weight is then its residue, the
        amplitude over the doublet's spectrum at the mode. Without it (the held arm, whose
        brake torque is itself how strongly a mode rings at the joint) the weight is the
        amplitude.
    min_frequency : float
        Lowest frequency [rad/s] considered a mode (below it: the rigid drift).
    rank_tolerance : float
        Singular values below this fraction of the largest are noise (the solver's residual
        motion of the held joints is below 1e-4 of the response).
    max_damping : float
        Poles damped more than this do not ring: they are transients (the brakes catching the
        joint), not structural modes, and are left out. So are poles above
        :data:`NYQUIST_MARGIN` times the Nyquist frequency, which sampling cannot resolve.

    Returns
    -------
    list of FittedMode
        Ascending in frequency.

    Raises
    ------
    ValueError
        If the record is malformed (lengths differ, too short, not finite, not uniformly
        sampled) or no oscillation is found (nothing rang).

    Notes
    -----
    The poles come from the matrix pencil of the samples (decimated to at most
    :data:`_MAX_SAMPLES`), the amplitudes from a linear least-squares fit of the whole record.
    """
    time = np.asarray(time, dtype=float)
    signal = np.asarray(signal, dtype=float)
    if time.ndim != 1 or time.shape != signal.shape or len(time) < 10:
        raise ValueError(f'a record needs matching 1-D time and signal of at least 10 samples, '
                         f'got shapes {time.shape} and {signal.shape}')
    if not (np.all(np.isfinite(time)) and np.all(np.isfinite(signal))):
        raise ValueError('the record has non-finite samples')
    steps = np.diff(time)
    if not (steps[0] > 0 and np.allclose(steps, steps[0], rtol=1e-6, atol=0.0)):
        raise ValueError('the record must be sampled uniformly, in increasing time')
    stride = max(1, math.ceil(len(signal) / _MAX_SAMPLES))
    period = steps[0] * stride
    poles = _matrix_pencil(signal[::stride], period, rank_tolerance)
    nyquist = math.pi / period
    poles = poles[(poles.imag >= min_frequency) & (poles.real < 0.0)
                  & (poles.imag <= NYQUIST_MARGIN * nyquist)
                  & (-poles.real <= max_damping * np.abs(poles))]
    if len(poles) == 0:
        raise ValueError('the response has no decaying oscillation: nothing rang')
    linear, *_ = np.linalg.lstsq(_basis(time, poles), signal, rcond=None)
    modes = []
    for pole, (cosine, sine) in zip(poles, linear[1:].reshape(-1, 2), strict=True):
        natural = abs(pole)
        amplitude = math.hypot(cosine, sine)
        weight = amplitude if excitation is None else amplitude / excitation.spectrum(natural)
        modes.append(FittedMode(frequency=natural, damping=-pole.real / natural,
                                amplitude=amplitude, weight=weight))
    return sorted(modes, key=lambda mode: mode.frequency)


def _lowest_seen(modes: list[FittedMode]) -> FittedMode:
    frequency = first_visible_mode([m.frequency for m in modes], [m.weight for m in modes])
    return next(m for m in modes if m.frequency == frequency)


def identify_joint(plant: WalkerPlant, joint: str, start: StartConfiguration,
                   excitation: Excitation | None = None, free_joint: bool = True
                   ) -> JointModes:
    """Measure the modes seen at one joint (held arm) and, optionally, its free resonance.

    Parameters
    ----------
    plant : WalkerPlant
        The plant (reset to ``start`` before each record).
    joint : str
        Physical joint name.
    start : StartConfiguration
        The stance of the test.
    excitation : Excitation, optional
        The doublet and the record length (default ``Excitation()``).
    free_joint : bool
        Also measure the free-joint resonance (a second record).
    """
    excitation = Excitation() if excitation is None else excitation
    sample_period = 1.0 / plant.params.timing.control_rate
    # the rig holds the free gripper clear of its node: a strike must not ring it on the face
    plant.enable_contact(False)
    plant.reset(start)
    modes = fit_modes(*strike_and_hold(plant, joint, excitation, sample_period))
    free_modes: list[FittedMode] = []
    free_seen = None
    if free_joint:
        plant.reset(start)
        try:
            free_modes = fit_modes(*ring_free_joint(plant, joint, excitation, sample_period),
                                   excitation)
        except ValueError:
            free_modes = []
        free_seen = _lowest_seen(free_modes) if free_modes else None
    return JointModes(joint=joint, modes=tuple(modes), seen=_lowest_seen(modes),
                      target=target_mode(plant.params, joint), free_modes=tuple(free_modes),
                      free_joint=free_seen)


def identify_modes(params, sim: SimParameters, joints=IDENTIFIED_JOINTS,
                   excitation: Excitation | None = None, free_joint: bool = True
                   ) -> list[JointModes]:
    """Measure the modes seen at each joint, at the default stance, with a fresh plant.

    Gripper a is screwed into ``sim.start.base_node`` and gripper b rests, free, at the first
    neighbour of that node (one truss spacing away: the stance of
    :func:`walker_sim.core.flexibility.default_stance`).

    Raises
    ------
    ValueError
        If a joint name is unknown.
    """
    unknown = [joint for joint in joints if joint not in PHYSICAL_JOINT_NAMES]
    if unknown:
        raise ValueError(f'unknown joints {unknown}: expected names of {PHYSICAL_JOINT_NAMES}')
    plant = WalkerPlant(params, sim)
    plant.set_solver(RIG_SOLVER_ITERATIONS, RIG_SOLVER_RESIDUAL)
    try:
        base = sim.start.base_node
        start = StartConfiguration(base_gripper='a', base_node=base,
                                   other_node=plant.truss.neighbors(base)[0],
                                   other_attached=False, other_height=0.0)
        return [identify_joint(plant, joint, start, excitation, free_joint)
                for joint in joints]
    finally:
        plant.close()
