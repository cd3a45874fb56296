"""Figure 6 of the paper: joint 1 moves 0.5 rad in COARSE mode, with and without Ka.

The experiment runs on any plant core with ``reset()``, ``step(torques, dt)`` and ``state()``
(:class:`PlantCore`); :class:`TwoMassJoint1Model` is a labelled two-mass model of joint 1 (not
the plant). The command that runs it on the pybullet plant is ``walker_headless``'s
``figure6`` (:mod:`walker_headless.figure6`), where the plant and the controllers may meet:
``walker_control`` does not depend on ``walker_sim``. :func:`report_figure6` prints its table
and draws its figure.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Protocol

import numpy as np

from walker_control.analysis.plotting import pyplot, save_figure

__all__ = ['PlantCore', 'Figure6Run', 'figure6_experiment', 'dominant_frequency',
           'TwoMassJoint1Model', 'report_figure6', 'FIGURE6_DISTANCE', 'FINAL_REST_WINDOW']

FIGURE6_DISTANCE = 0.5            # [rad] joint-1 move of the Figure 6 experiment


class PlantCore(Protocol):
    """What :func:`figure6_experiment` needs of a plant (the walker_sim core has this shape).

    ``state()`` returns an object with ``position``, ``velocity``, ``acceleration`` (five
    physical joints, rad, rad/s, rad/s^2) and ``tip_position`` (3, m, base frame).
    """

    def reset(self) -> None:
        """Put the robot at its initial state."""

    def step(self, torques: Sequence[float], dt: float) -> None:
        """Apply the five joint torques [N*m] for ``dt`` seconds."""

    def state(self) -> object:
        """Return the current state."""


@dataclasses.dataclass(frozen=True)
class Figure6Run:
    """One run of the Figure 6 experiment.

    Attributes
    ----------
    ka : float
        Acceleration feedback gain of joint 1 in coarse motion.
    time, joint1, tip_deviation : ndarray
        Time [s], joint-1 angle [rad], tip distance from its final rest [m].
    tip_position : ndarray, shape (N, 3)
        Tip position [m] in the base frame.
    move_time : float
        When the motion to the target ends [s].
    residual_amplitude : float
        Largest tip distance from its final rest in the residual window (from ``move_time``
        plus the settling allowance to the end) [m]: the vibration near the target. The final
        rest is where the tip ends, its mean position over the last
        :data:`FINAL_REST_WINDOW` of the run; a late arrival counts as residual.
    residual_frequency : float
        Dominant angular frequency [rad/s] of the tip's motion in the residual window (the
        peak of its spectrum along the direction it moves most); 0 when it does not move.
    joint1_motion : float
        Peak-to-peak joint-1 angle [rad] in the residual window: 0 when joint 1 has stopped
        (stuck in its friction) and only the structure rings.
    """

    ka: float
    time: np.ndarray
    joint1: np.ndarray
    tip_deviation: np.ndarray
    tip_position: np.ndarray
    move_time: float
    residual_amplitude: float
    residual_frequency: float
    joint1_motion: float


#: The tip's final rest is its mean position over this last stretch of a Figure 6 run [s]
#: (a little over one period of the 18 rad/s mode).
FINAL_REST_WINDOW = 0.5


def dominant_frequency(time: np.ndarray, points: np.ndarray) -> float:
    """Angular frequency [rad/s] of the largest spectral peak of a moving point.

    The points (N, 3) are projected on the direction they move most (their principal axis),
    the mean removed, a Hann window applied and the spectrum zero-padded 8 times; the peak is
    refined by a parabola through its neighbours. Returns 0 when the points do not move.

    Raises
    ------
    ValueError
        If fewer than 8 samples or non-uniform times are given.
    """
    time = np.asarray(time, dtype=float)
    points = np.asarray(points, dtype=float).reshape(len(time), -1)
    if len(time) < 8 or not np.allclose(np.diff(time), time[1] - time[0], rtol=1e-6):
        raise ValueError('dominant_frequency needs at least 8 uniformly spaced samples')
    centred = points - points.mean(axis=0)
    if not np.any(centred):
        return 0.0
    _, _, axes = np.linalg.svd(centred, full_matrices=False)
    signal_1d = centred @ axes[0]
    padded = 8 * len(signal_1d)
    spectrum = np.abs(np.fft.rfft(signal_1d * np.hanning(len(signal_1d)), padded))
    peak = int(np.argmax(spectrum[1:])) + 1
    offset = 0.0
    if 1 <= peak < len(spectrum) - 1:
        left, centre, right = spectrum[peak - 1:peak + 2]
        denominator = left - 2.0 * centre + right
        offset = 0.5 * (left - right) / denominator if denominator != 0.0 else 0.0
    return float(2.0 * math.pi * (peak + offset) / (padded * (time[1] - time[0])))


def _smooth_move(start: float, distance: float, duration: float, t: float):
    """Cosine (half-wave) motion profile: position, velocity, acceleration at time ``t``."""
    if t >= duration:
        return start + distance, 0.0, 0.0
    phase = math.pi * t / duration
    rate = math.pi / duration
    return (start + 0.5 * distance * (1.0 - math.cos(phase)),
            0.5 * distance * rate * math.sin(phase),
            0.5 * distance * rate * rate * math.cos(phase))


def figure6_experiment(make_plant: Callable[[], PlantCore], settings, ka: float, *,
                       distance: float = FIGURE6_DISTANCE, move_time: float = 4.0,
                       settle_time: float = 6.0, allowance: float = 1.0) -> Figure6Run:
    """Joint 1 moves to a target in coarse mode with acceleration feedback ``ka``.

    The five joint controllers (base gripper ``a``) run at the control rate on the plant;
    joint 1 follows a smooth move of ``distance`` rad in ``move_time`` s in COARSE mode with
    ``Ka = ka``, the other joints HOLD. The controllers are the paper's (Figure 3): the
    reference shaping and the friction feed-forward the walker adds
    (``control.filter.reference``, ``control.friction_compensation.feedforward_speed``) are
    off, so that Ka alone makes the difference; the rest of the parameter file is unchanged.

    Raises
    ------
    ParameterError
        If the settings with this ``Ka`` fail the stability check.
    """
    from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
    from walker_core.parameter_schema import replace_in_section

    from walker_control.core.inputs import Setpoint
    from walker_control.core.joint_controller import JointController, Measurement
    from walker_control.core.modes import Mode

    coarse_ka = list(settings.control.coarse.acceleration_feedback)
    coarse_ka[0] = float(ka)
    settings = replace_in_section(settings, {'control.coarse.acceleration_feedback': coarse_ka,
                                             'control.filter.reference': False,
                                             'control.friction_compensation.feedforward_speed':
                                                 0.0})
    plant = make_plant()
    plant.reset()
    controllers = [JointController(settings, name, 'a') for name in PHYSICAL_JOINT_NAMES]
    controllers[0].command(Mode.COARSE, 'a')
    dt = settings.sample_time
    state = plant.state()
    start = float(state.position[0])
    steps = int(round((move_time + settle_time) / dt))
    times, joint1, tips = [], [], []
    for k in range(steps):
        t = k * dt
        position, velocity, acceleration = _smooth_move(start, distance, move_time, t)
        setpoint = Setpoint(position, velocity, acceleration)
        torques = []
        for index, controller in enumerate(controllers):
            measurement = Measurement(float(state.position[index]),
                                      float(state.velocity[index]),
                                      float(state.acceleration[index]),
                                      tuple(float(v) for v in state.position))
            torques.append(controller.update(measurement, setpoint if index == 0 else None,
                                             dt).effort)
        plant.step(torques, dt)
        state = plant.state()
        times.append(t + dt)
        joint1.append(float(state.position[0]))
        tips.append(np.asarray(state.tip_position, dtype=float))
    tips = np.array(tips)
    times = np.array(times)
    joint1 = np.array(joint1)
    after = times >= move_time + allowance
    final_rest = tips[times > times[-1] - FINAL_REST_WINDOW].mean(axis=0)
    deviation = np.linalg.norm(tips - final_rest, axis=1)
    return Figure6Run(ka=float(ka), time=times, joint1=joint1, tip_deviation=deviation,
                      tip_position=tips, move_time=move_time,
                      residual_amplitude=float(np.max(deviation[after])),
                      residual_frequency=dominant_frequency(times[after], tips[after]),
                      joint1_motion=float(np.ptp(joint1[after])))


class TwoMassJoint1Model:
    """A model (not the plant) for trying :func:`figure6_experiment` before the plant exists.

    Joint 1 is a two-mass system: the reflected rotor inertia ``n^2 I_m`` on the joint side, the
    rest of the rigid ``I_11`` at the stance on the link side, joined by a torsional spring
    tuned to the paper's 18 rad/s mode (link side clamped), damping ratio from
    ``robot.flexibility``, Coulomb friction and stiction of the drive on the joint side. The
    tip moves with the link-side angle at the stance's reach. Joints 2-5 are rigid and still.
    """

    def __init__(self, settings, stance: Sequence[float] = (0.0, 0.85, 1.45, 0.85, 0.0),
                 substeps: int = 10) -> None:
        from walker_core.dynamics import RigidModel, diagonal_inertia
        from walker_core.kinematics import WalkerKinematics

        model = RigidModel.from_parameters(settings)
        self._stance = np.array(stance, dtype=float)
        total = float(diagonal_inertia(self._stance, model)[0])
        self._rotor = float(model.reflected_motor_inertia[0])
        self._link = total - self._rotor
        mode = settings.robot.flexibility.joint1_mode
        self._stiffness = self._link * mode ** 2
        self._damping = 2.0 * settings.robot.flexibility.damping_ratio * self._link * mode
        drive = settings.drive(1)
        self._coulomb, self._stiction = drive.friction_torque, drive.stiction_torque
        self._reach = float(np.hypot(*WalkerKinematics.from_parameters(settings)
                                     .forward(self._stance)[:2]))
        self._substeps = substeps
        self.reset()

    def reset(self) -> None:
        """Start at rest at the stance."""
        self._x = np.zeros(4)  # joint angle, joint rate, link angle, link rate
        self._acceleration = 0.0

    def step(self, torques: Sequence[float], dt: float) -> None:
        """Integrate ``dt`` seconds with semi-implicit Euler sub-steps."""
        h = dt / self._substeps
        rate_before = self._x[1]
        for _ in range(self._substeps):
            q, w, ql, wl = self._x
            spring = self._stiffness * (q - ql) + self._damping * (w - wl)
            drive = float(torques[0]) - spring
            if w == 0.0 and abs(drive) <= self._stiction:
                w_next = 0.0
            else:
                direction = math.copysign(1.0, w if w != 0.0 else drive)
                w_next = w + h * (drive - direction * self._coulomb) / self._rotor
                if w != 0.0 and w_next * w < 0.0:
                    w_next = 0.0
            wl_next = wl + h * spring / self._link
            self._x = np.array([q + h * w_next, w_next, ql + h * wl_next, wl_next])
        self._acceleration = (self._x[1] - rate_before) / dt

    def state(self):
        """Joint angles, rates, accelerations and the tip position."""
        position = self._stance.copy()
        position[0] += self._x[0]
        velocity = np.zeros(5)
        velocity[0] = self._x[1]
        acceleration = np.zeros(5)
        acceleration[0] = self._acceleration
        angle = self._x[2]
        tip = np.array([-math.sin(angle) * self._reach, math.cos(angle) * self._reach, 0.0])
        return _ModelState(position, velocity, acceleration, tip)


@dataclasses.dataclass(frozen=True)
class _ModelState:
    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    tip_position: np.ndarray


def report_figure6(make_plant: Callable[[], PlantCore], what: str, settings, out: Path) -> None:
    """Run the experiment with Ka = 0 and the file's Ka; print the table, draw ``figure6.png``.

    ``what`` names the plant in the table and the figure; ``out`` is the figures' directory.
    """
    factory = make_plant
    ka_file = settings.control.coarse.acceleration_feedback[0]
    runs = [figure6_experiment(factory, settings, ka) for ka in sorted({0.0, ka_file})]
    print(f'Figure 6 on the {what}: joint 1 moves 0.5 rad in 4 s (coarse mode), then holds')
    print('   Ka  | residual tip vibration [mm] | its frequency [rad/s] | joint 1 moves [mrad] '
          '| joint-1 error at the end [mrad]')
    for run in runs:
        error = run.joint1[-1] - (run.joint1[0] + FIGURE6_DISTANCE)
        print(f' {run.ka:5.2f} | {run.residual_amplitude * 1e3:27.3f} | '
              f'{run.residual_frequency:21.1f} | {run.joint1_motion * 1e3:20.4f} | '
              f'{error * 1e3:+.3f}')
    print(f'(residual: largest tip distance from its final rest, its mean over the last '
          f'{FINAL_REST_WINDOW:g} s, from 1 s after the move to the end, 6 s after it)')
    plt = pyplot()
    fig, axes = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
    for run in runs:
        axes[0].plot(run.time, run.joint1, label=f'Ka = {run.ka:g}')
        axes[1].plot(run.time, run.tip_deviation * 1e3, label=f'Ka = {run.ka:g}')
    axes[0].set_ylabel('joint 1 [rad]')
    axes[1].set_ylabel('tip distance from its final rest [mm]')
    axes[1].set_xlabel('time [s]')
    axes[1].set_yscale('log')
    axes[0].set_title(f'Figure 6 experiment on the {what}')
    for ax in axes:
        ax.legend()
        ax.grid(True, alpha=0.3)
    fig.tight_layout()
    save_figure(fig, out / 'figure6.png')
    print(f'figure: {out / "figure6.png"}')
