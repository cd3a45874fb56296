"""Reproduce the paper's section 4: eq (14), Routh-Hurwitz (15)/(16), Figure 5, Figure 6.

Command line (console script ``control_analysis``)::

    control_analysis routh   [--out DIR]   eq (15) against Routh arrays and poles over a grid
    control_analysis bode    [--out DIR]   Figure 5 (wf/wc = 5, several Ka) with its table
    control_analysis design  [--params-file F]  the stability check of every loop in the file
    control_analysis figure6 [--out DIR] [--model two-mass]   Figure 6 (needs the plant)
    control_analysis floor   [--radius R] [--tolerance E]   joint 1's fastest sweeps

Each subcommand prints a table and writes PNG figures (matplotlib, Agg backend) into ``--out``
(default ``runs/analysis``). The functions behind them are importable and ROS-free.
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import math
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Protocol

import numpy as np
from scipy import signal
from scipy.optimize import brentq

from walker_control.core.stability import (
    LoopDesign,
    discrete_closed_loop_poles,
    eq14_poles,
    eq14_transfer_function,
    eq15_margin,
    routh_hurwitz_stable,
)

__all__ = [
    'RouthGridResult', 'routh_grid', 'BodeCurve', 'figure5_curves', 'achievable_ratio',
    'PlantCore', 'Figure6Run', 'figure6_experiment', 'dominant_frequency',
    'TwoMassJoint1Model', 'SweepFloor', 'sweep_floors', 'main',
]

DEFAULT_OUT = Path('runs') / 'analysis'
FIGURE5_RATIO = 5.0               # wf / wc of the paper's Figure 5
FIGURE5_KA = (0.0, 0.25, 0.5, 1.0, 2.0, 4.0)
PEAK_LIMIT_DB = 3.0               # resonance peak allowed in the "achievable" comparison
FIGURE6_DISTANCE = 0.5            # [rad] joint-1 move of the Figure 6 experiment


# ------------------------------------------------------------------------------- routh
@dataclasses.dataclass(frozen=True)
class RouthGridResult:
    """Verdicts over a grid of (Ka, wc/wf, zc).

    Attributes
    ----------
    points : int
        Grid points checked.
    stable : int
        Points where eq (14) is stable by its poles.
    marginal : int
        Points exactly on the eq (15) boundary (poles on the imaginary axis), left out of the
        comparisons: there the verdict is rounding noise.
    eq15_disagreements, routh_disagreements : list of tuple
        ``(Ka, wc/wf, zc)`` where eq (15), or the Routh array, disagrees with the poles.
    sampled_disagreements : list of tuple
        ``(Ka, wc/wf, zc, margin, wc T)`` where the sampled loop (paper's filter, control
        period, no delay) disagrees with eq (15); ``margin`` is the eq (15) margin.
    """

    points: int
    stable: int
    marginal: int
    eq15_disagreements: list
    routh_disagreements: list
    sampled_disagreements: list


def routh_grid(ka_values: Sequence[float], ratios: Sequence[float], dampings: Sequence[float],
               wf: float = 30.0, sample_time: float = 0.002) -> RouthGridResult:
    """Check eq (15) against Routh-Hurwitz and the poles of eq (14) over a grid.

    Parameters
    ----------
    ka_values, ratios, dampings : sequences
        ``Ka``, ``wc / wf`` and ``zc`` values.
    wf : float
        Filter corner [rad/s] for the sampled-loop comparison (the joints 2-3 corner).
    sample_time : float
        Control period [s] of the sampled loop.
    """
    eq15_bad, routh_bad, sampled_bad = [], [], []
    stable = marginal = 0
    cases = list(itertools.product(ka_values, ratios, dampings))
    for ka, ratio, zc in cases:
        wc = ratio * wf
        margin = eq15_margin(wc, zc, wf, ka)
        if abs(margin) < 1e-9:
            marginal += 1
            continue
        by_poles = bool(np.all(eq14_poles(wc, zc, wf, ka).real < 0.0))
        stable += by_poles
        if (margin > 0.0) != by_poles:
            eq15_bad.append((ka, ratio, zc))
        if routh_hurwitz_stable(eq14_transfer_function(wc, zc, wf, ka)[1]) != by_poles:
            routh_bad.append((ka, ratio, zc))
        design = LoopDesign(wc, zc, 0.0, ka, 2, wf, 'critical')
        sampled = bool(np.max(np.abs(discrete_closed_loop_poles(design, sample_time))) < 1.0)
        if sampled != (margin > 0.0):
            sampled_bad.append((ka, ratio, zc, margin, wc * sample_time))
    return RouthGridResult(points=len(cases), stable=stable, marginal=marginal,
                           eq15_disagreements=eq15_bad,
                           routh_disagreements=routh_bad, sampled_disagreements=sampled_bad)


def _run_routh(args: argparse.Namespace) -> int:
    ka_values = np.round(np.linspace(0.0, 4.0, 21), 6)
    ratios = np.round(np.linspace(0.05, 2.5, 50), 6)
    dampings = (0.5, 1.0, 2.0)
    result = routh_grid(ka_values, ratios, dampings)
    print('Eq (15) against Routh-Hurwitz and the poles of eq (14)')
    print(f'  grid: Ka in [0, 4] ({len(ka_values)}), wc/wf in [0.05, 2.5] ({len(ratios)}), '
          f'zc in {dampings}: {result.points} points, {result.marginal} exactly on the '
          f'boundary left out, {result.stable} stable by the poles')
    print(f'  eq (15) disagrees with the poles at {len(result.eq15_disagreements)} points')
    print(f'  the Routh array disagrees with the poles at {len(result.routh_disagreements)} '
          'points')
    optimistic = [d for d in result.sampled_disagreements if d[3] > 0.0]
    pessimistic = [d for d in result.sampled_disagreements if d[3] <= 0.0]
    print('  the sampled loop (2nd-order critical filter at 30 rad/s, T = 2 ms, no delay) '
          f'disagrees with eq (15) at {len(result.sampled_disagreements)} points:')
    if optimistic:
        print(f'    {len(optimistic)} where eq (15) says stable and the sampled loop is not '
              f'(eq (15) margin up to {max(d[3] for d in optimistic):.3f}, at wc T >= '
              f'{min(d[4] for d in optimistic):.3f}: sampling costs phase that eq (15) does '
              'not see)')
    if pessimistic:
        print(f'    {len(pessimistic)} where eq (15) says unstable and the sampled loop is '
              f'stable (eq (15) margin down to {min(d[3] for d in pessimistic):.3f})')
    _plot_stability_map(args.out / 'routh_hurwitz.png')
    print(f'  figure: {args.out / "routh_hurwitz.png"}')
    return 0 if not (result.eq15_disagreements or result.routh_disagreements) else 1


def _plot_stability_map(path: Path) -> None:
    plt = _pyplot()
    ka = np.linspace(0.0, 4.0, 161)
    ratio = np.linspace(0.02, 2.5, 200)
    fig, axes = plt.subplots(1, 3, figsize=(13, 4), sharey=True)
    for ax, zc in zip(axes, (0.5, 1.0, 2.0), strict=True):
        growth = np.array([[max(eq14_poles(r, zc, 1.0, k).real) for k in ka] for r in ratio])
        ax.contourf(ka, ratio, growth < 0.0, levels=[-0.5, 0.5, 1.5],
                    colors=['#f4c7c3', '#c9e7c9'])
        ax.plot(ka, (1.0 + ka) * zc / (1.0 + zc ** 2), 'k-', lw=2, label='eq (15) boundary')
        ax.set_title(f'zc = {zc:g}: green stable by the poles of eq (14)')
        ax.set_xlabel('Ka')
        ax.legend(loc='upper left')
    axes[0].set_ylabel('wc / wf')
    fig.tight_layout()
    _save(fig, path)


# -------------------------------------------------------------------------------- bode
@dataclasses.dataclass(frozen=True)
class BodeCurve:
    """One curve of Figure 5: frequency response of eq (14) and its figures of merit.

    Frequencies are in units of wc; ``bandwidth`` is the first -3 dB crossing, solved on the
    transfer function between the grid points that bracket it.
    """

    ka: float
    frequency: np.ndarray
    magnitude_db: np.ndarray
    phase_deg: np.ndarray
    bandwidth: float
    peak_db: float
    peak_frequency: float


def _bandwidth(numerator, denominator, w, magnitude) -> float:
    """Frequency where the gain first falls to -3 dB, solved between the grid points.

    The grid brackets the first crossing; ``brentq`` solves ``20 log10 |H(jw)| = -3`` inside
    the bracket on the transfer function itself. ``inf`` when the gain never falls that low
    on the grid.
    """
    below = np.nonzero(magnitude < -3.0)[0]
    if not len(below):
        return math.inf
    if below[0] == 0:
        return float(w[0])

    def excess(frequency):
        _, value = signal.freqs(numerator, denominator, worN=[frequency])
        return 20.0 * math.log10(abs(value[0])) + 3.0

    return float(brentq(excess, w[below[0] - 1], w[below[0]], xtol=1e-12, rtol=1e-12))


def _curve(numerator, denominator, ka, w) -> BodeCurve:
    _, response = signal.freqs(numerator, denominator, worN=w)
    magnitude = 20.0 * np.log10(np.abs(response))
    bandwidth = _bandwidth(numerator, denominator, w, magnitude)
    peak = int(np.argmax(magnitude))
    return BodeCurve(ka=ka, frequency=w, magnitude_db=magnitude,
                     phase_deg=np.degrees(np.unwrap(np.angle(response))), bandwidth=bandwidth,
                     peak_db=float(max(magnitude[peak], 0.0)),
                     peak_frequency=float(w[peak]) if magnitude[peak] > 0.0 else 0.0)


def figure5_curves(ratio: float = FIGURE5_RATIO, ka_values: Sequence[float] = FIGURE5_KA,
                   zc: float = 1.0, feedforward: bool = True,
                   w: np.ndarray | None = None) -> list[BodeCurve]:
    """Curves of Figure 5: theta / theta_r of eq (14) with ``wc = 1`` and ``wf = ratio``.

    Parameters
    ----------
    feedforward : bool
        True: eq (14) as printed (full feed-forward ``s^2 + 2 zc wc s + wc^2``). False: the
        same loop without the acceleration feed-forward, numerator ``(2 zc wc s + wc^2) wf^2``.
    """
    w = np.logspace(-2, 2, 8000) if w is None else w
    curves = []
    for ka in ka_values:
        numerator, denominator = eq14_transfer_function(1.0, zc, ratio, ka)
        if not feedforward:
            numerator = np.array([0.0, 2.0 * zc, 1.0]) * ratio ** 2
        curves.append(_curve(numerator, denominator, ka, w))
    return curves


def achievable_ratio(ka: float, zc: float = 1.0, peak_limit_db: float = PEAK_LIMIT_DB,
                     feedforward: bool = True) -> tuple[float, float]:
    """Largest ``wc/wf`` of eq (14) whose resonance peak stays within ``peak_limit_db``.

    Returns
    -------
    (float, float)
        That ratio and the -3 dB bandwidth it gives, in units of ``wf``.
    """
    w = np.logspace(-3, 2, 4000)
    best = (0.0, 0.0)
    for ratio in np.linspace(0.01, 2.0, 400):
        if eq15_margin(ratio, zc, 1.0, ka) <= 0.0:
            break
        numerator, denominator = eq14_transfer_function(ratio, zc, 1.0, ka)
        if not feedforward:
            numerator = np.array([0.0, 2.0 * zc * ratio, ratio ** 2])
        curve = _curve(numerator, denominator, ka, w)
        if curve.peak_db <= peak_limit_db:
            best = (float(ratio), curve.bandwidth)
    return best


def _run_bode(args: argparse.Namespace) -> int:
    with_ff = figure5_curves()
    without_ff = figure5_curves(feedforward=False)
    print(f'Figure 5: eq (14) with wf/wc = {FIGURE5_RATIO:g}, zc = 1 (frequencies in units '
          'of wc)')
    print('        |   eq (14) as printed (feed-forward)   |   without acceleration feed-forward')
    print('   Ka   | -3 dB bandwidth | peak [dB] at w/wc  | -3 dB bandwidth | peak [dB] at w/wc')
    for a, b in zip(with_ff, without_ff, strict=True):
        print(f' {a.ka:6.2f} | {a.bandwidth:15.3f} | {a.peak_db:6.2f} at {a.peak_frequency:6.3f}'
              f'  | {b.bandwidth:15.3f} | {b.peak_db:6.2f} at {b.peak_frequency:6.3f}')
    print(f'\nAt a fixed filter (wf = 1): the largest wc/wf whose resonance peak stays within '
          f'{PEAK_LIMIT_DB:g} dB, and the bandwidth it gives (units of wf)')
    print('   Ka   |  feed-forward: wc/wf  bandwidth |  without: wc/wf  bandwidth')
    for ka in FIGURE5_KA:
        cells = []
        for feedforward, width in ((True, 20), (False, 15)):
            ratio, bandwidth = achievable_ratio(ka, feedforward=feedforward)
            cells.append(f'{ratio:{width}.3f} {bandwidth:10.3f}' if ratio > 0.0
                         else f'{"none":>{width}s} {"-":>10s}')
        print(f' {ka:6.2f} | {cells[0]} | {cells[1]}')
    _plot_bode(with_ff, without_ff, args.out / 'figure5_bode.png')
    print(f'\nfigure: {args.out / "figure5_bode.png"}')
    return 0


def _plot_bode(with_ff: list[BodeCurve], without_ff: list[BodeCurve], path: Path) -> None:
    plt = _pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(12, 7), sharex=True)
    for column, (curves, title) in enumerate(((with_ff, 'eq (14) as printed'),
                                              (without_ff, 'without acceleration feed-forward'))):
        for curve in curves:
            axes[0, column].semilogx(curve.frequency, curve.magnitude_db,
                                     label=f'Ka = {curve.ka:g}')
            axes[1, column].semilogx(curve.frequency, curve.phase_deg)
        axes[0, column].axhline(-3.0, color='grey', ls=':', lw=1)
        axes[0, column].set_ylim(-40, 10)
        axes[0, column].set_title(f'{title}, wf/wc = {FIGURE5_RATIO:g}, zc = 1')
        axes[0, column].set_ylabel('|theta / theta_r| [dB]')
        axes[1, column].set_ylabel('phase [deg]')
        axes[1, column].set_xlabel('w / wc')
        axes[0, column].legend(fontsize=8)
        for ax in axes[:, column]:
            ax.grid(True, which='both', alpha=0.3)
    fig.tight_layout()
    _save(fig, path)


# ------------------------------------------------------------------------------ design
def _run_design(args: argparse.Namespace) -> int:
    from walker_core.parameter_schema import ParameterError

    from walker_control.core.config import check_controller_settings, load_controller_settings

    try:
        settings = load_controller_settings(args.params_file)
    except ParameterError as error:
        print(f'refused: {error}')
        return 2
    stability = settings.control.stability
    print(f'Stability check of every loop (T = {settings.sample_time * 1e3:g} ms, inertia '
          f'ratio {stability.inertia_ratio_min:g}..{stability.inertia_ratio_max:g}, delay 0 or '
          f'1 period, minimum damping {stability.minimum_damping:g})')
    print(' role | mode   |  wc   zc    Ti    Ka  | filter        | max |z|  | min damping '
          '(where)                          | eq (15) margin (2nd-order critical filter only)')
    for (role, mode), report in check_controller_settings(settings).items():
        d = settings.loop_design(role, mode)
        filt = (f'{d.filter_kind[:4]} {d.filter_order} @ {d.filter_corner:g}'
                if d.filter_order else 'none')
        margin = (f'{report.eq15_margin:+.3f}' if report.eq15_margin is not None
                  else 'does not apply' if d.filter_order else '-')
        print(f'  J{role}  | {mode.key:6s} | {d.bandwidth:4.1f} {d.damping:4.1f} '
              f'{d.integral_time:5.1f} {d.acceleration_feedback:4.2f} | {filt:13s} | '
              f'{report.largest_pole_magnitude:.5f} | {report.smallest_damping:.3f} '
              f'({report.worst_case:34s}) | {margin}')
    return 0


# ----------------------------------------------------------------------------- figure 6
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


def _plant_factory(args: argparse.Namespace, settings):
    if args.model == 'two-mass':
        return lambda: TwoMassJoint1Model(settings), 'two-mass model of joint 1 (NOT the plant)'
    try:
        from walker_sim.core import make_plant
    except ImportError:
        return None, ('the Figure 6 experiment runs on the pybullet plant (walker_sim.core), '
                      'which this installation does not have')
    from walker_core.robot_parameters import load_walker_parameters

    # Gripper a screwed in, gripper b free at the approach height above its node: the arm is
    # free to turn about joint 1, as in the paper's experiment.
    height = load_walker_parameters(args.params_file).gripper.approach_height
    return (lambda: make_plant(args.params_file, other_attached=False,
                               other_height=height)), 'pybullet plant'


def _run_figure6(args: argparse.Namespace) -> int:
    from walker_control.core.config import load_controller_settings

    settings = load_controller_settings(args.params_file)
    factory, what = _plant_factory(args, settings)
    if factory is None:
        print(f'figure6: {what}; run "control_analysis figure6 --model two-mass" for the model')
        return 2
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
    plt = _pyplot()
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
    _save(fig, args.out / 'figure6.png')
    print(f'figure: {args.out / "figure6.png"}')
    return 0


# -------------------------------------------------------------------------------- main
def _pyplot():
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    _pyplot().close(fig)


# ------------------------------------------------------------------------------- floor
#: Sweeps of a step about the base [deg]: the quarter and the half turn of the default truss.
FLOOR_SWEEPS = (90.0, 180.0)
FLOOR_SAMPLE_TIME = 0.01  # [s] the programme's period (2 ms and 10 ms agree within 6 ms)


@dataclasses.dataclass(frozen=True)
class SweepFloor:
    """Joint 1's fastest sweep [s], with no filter and through its command filter."""

    sweep: float        # [deg]
    unfiltered: float   # [s] until the tip is within the tolerance for good, no filter
    filtered: float     # [s] the same, through joint 1's command filter


def sweep_floors(settings, radius: float, tip_tolerance: float,
                 sweeps: Sequence[float] = FLOOR_SWEEPS,
                 sample_time: float = FLOOR_SAMPLE_TIME) -> list[SweepFloor]:
    """Joint 1's fastest sweeps at a stance, at the drive's full limits, with and without filter.

    The acceleration limit is the torque the yaw drive has left after its Coulomb friction over
    joint 1's inertia with the tip at ``radius`` (eq (9)); the rate limit is its velocity limit;
    the move has arrived once the shaped reference is within ``tip_tolerance / radius`` of its
    end for good (:func:`~walker_control.core.fastest_move.fastest_move_through_filter`). No
    plan beats it with the paper's controller structure (the whole command filtered).
    """
    from walker_core.dynamics import RigidModel, role_inertia
    from walker_core.kinematics import WalkerKinematics

    from walker_control.core.fastest_move import fastest_move_through_filter
    from walker_control.core.lowpass import design_lowpass_sos

    geometry = settings.robot.geometry
    joints = WalkerKinematics(geometry.l1, geometry.l2).inverse([0.0, radius, 0.0, 0.0, 0.0])
    inertia = role_inertia(joints, RigidModel.from_parameters(settings), 1)
    drive = settings.drive(1)
    acceleration = (drive.torque_limit - drive.friction_torque) / inertia
    filters = settings.control.filter
    designs = (design_lowpass_sos(0, 0.0, sample_time),
               design_lowpass_sos(filters.order[0], filters.corner[0], sample_time,
                                  filters.kind))
    floors = []
    for sweep in sweeps:
        unfiltered, filtered = (
            fastest_move_through_filter(math.radians(sweep), drive.velocity_limit,
                                        acceleration, sos, sample_time,
                                        tip_tolerance / radius).arrival
            for sos in designs)
        floors.append(SweepFloor(sweep, unfiltered, filtered))
    return floors


def _run_floor(args: argparse.Namespace) -> int:
    from walker_core.robot_parameters import load_walker_parameters

    from walker_control.core.config import load_controller_settings

    try:
        settings = load_controller_settings(args.params_file)
        radius = args.radius or load_walker_parameters(args.params_file).truss.spacing
        floors = sweep_floors(settings, radius, args.tolerance)
    except ValueError as error:  # invalid parameters, a tip out of reach: said, nothing shown
        print(f'refused: {error}')
        return 2
    filters = settings.control.filter
    print(f"Joint 1's fastest sweep with the tip at {radius:g} m, until the tip is within "
          f'{args.tolerance * 1e3:g} mm of the target for good (full torque and rate; '
          f'{FLOOR_SAMPLE_TIME * 1e3:g} ms programme)')
    print(f' sweep | no filter | through its filter ({filters.kind} {filters.order[0]} '
          f'@ {filters.corner[0]:g} rad/s)')
    for floor in floors:
        print(f' {floor.sweep:5.0f} | {floor.unfiltered:7.2f} s | {floor.filtered:.2f} s')
    return 0


def _positive(text: str) -> float:
    """Return an option's value as a finite number > 0 (argparse refuses anything else)."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0.0):
        raise argparse.ArgumentTypeError(f'expected a finite number > 0, got {text!r}')
    return value


def main(argv: Sequence[str] | None = None) -> int:
    """Run a subcommand; return the exit code."""
    parser = argparse.ArgumentParser(prog='control_analysis',
                                     description=__doc__.split('\n\n')[0])
    sub = parser.add_subparsers(dest='command', required=True)
    for name, text in (('routh', 'eq (15) against Routh-Hurwitz and the poles'),
                       ('bode', 'Figure 5 and its bandwidth table'),
                       ('design', 'the stability check of the parameter file'),
                       ('figure6', 'Figure 6: joint-1 motion with and without Ka'),
                       ('floor', "joint 1's fastest sweeps, with and without its filter")):
        command = sub.add_parser(name, help=text)
        command.add_argument('--out', type=Path, default=DEFAULT_OUT,
                             help='directory for figures (default: runs/analysis)')
        command.add_argument('--params-file', default=None,
                             help='parameter file (default: walker_core/config/walker.yaml)')
        if name == 'figure6':
            command.add_argument('--model', choices=('plant', 'two-mass'), default='plant',
                                 help='plant to run on (default: the pybullet plant)')
        if name == 'floor':
            command.add_argument('--radius', type=_positive, default=None,
                                 help='tip distance from the base yaw axis [m] (default: the '
                                      'truss spacing)')
            command.add_argument('--tolerance', type=_positive, default=0.0005,
                                 help='arrival band at the tip [m] (default: 0.0005, the '
                                      "supervisor's insertion_alignment)")
    args = parser.parse_args(argv)
    runner = {'routh': _run_routh, 'bode': _run_bode, 'design': _run_design,
              'figure6': _run_figure6, 'floor': _run_floor}[args.command]
    return runner(args)


if __name__ == '__main__':
    sys.exit(main())
