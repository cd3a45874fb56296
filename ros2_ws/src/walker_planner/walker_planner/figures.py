"""Figures of the bang-bang node-to-node planner (paper section 5, Figures 8 and 9).

``planner_figures --out DIR`` (or ``python -m walker_planner.figures --out DIR``) writes:

* ``figure8_torques_and_trajectory.png``: the bang-bang torques (tau1 circular, tau3 radial,
  normalised) and rho, Theta against the dimensionless time phi for a 180 deg step;
* ``figure9_family_180deg.png``: tip paths of 180 deg steps in the x-y plane (in units of 2l)
  for several start radii rho(0) and midpoint radii rho_min, with the torque ratio tau found;
* ``duration_vs_midpoint.png``: duration of a 180 deg and a 90 deg step on the default robot
  against the midpoint radius, under the torque limits alone (the time-optimal bound) and with
  the joint rate limits of nominal plans.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from walker_planner.core.bang_bang import PlanarProfile
from walker_planner.core.node_to_node import PlanarModel, _duration

__all__ = ['figure8', 'figure9', 'duration_figure', 'main', 'FIGURE8_CASE', 'FIGURE9_CASES']

#: rho(0), rho(phi2) and half the sweep of Figure 8 (a 180 deg step).
FIGURE8_CASE = (0.75, 0.5, 0.5 * math.pi)
#: (rho(0), rho(phi2)) of the 180 deg family of Figure 9.
FIGURE9_CASES = ((0.75, 0.75), (0.75, 0.6), (0.75, 0.45), (0.75, 0.3),
                 (0.6, 0.6), (0.6, 0.4), (0.9, 0.9), (0.9, 0.5))


def _pyplot():
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    return plt


def figure8(path: Path) -> Path:
    """Torques and trajectories against phi for the 180 deg case of :data:`FIGURE8_CASE`."""
    plt = _pyplot()
    profile = PlanarProfile.solve(*FIGURE8_CASE)
    phi = np.linspace(0.0, profile.phi_end, 1201)
    samples = profile.sample(phi)
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7.5, 6.5), sharex=True)
    # the larger of the two torques is tau_ref; their ratio is tau = tau1 / tau3
    scale = max(profile.tau, 1.0)
    top.step(phi, profile.circular_sign(phi) * profile.tau / scale, where='post',
             label=r'$S_1\tau_1/\tau_{ref}$ (circular, joint 1)', color='tab:blue')
    top.step(phi, profile.radial_sign(phi) / scale, where='post',
             label=r'$S_3\tau_3/\tau_{ref}$ (radial, joint 3; < 0 pulls in)', color='tab:red')
    top.set_ylabel('torque / tau_ref')
    top.set_ylim(-1.3, 1.3)
    top.legend(loc='lower left', fontsize=8)
    top.set_title(f'Bang-bang node-to-node, 180 deg: rho(0) = {profile.rho_start}, '
                  f'rho(phi2) = {profile.rho_mid}, tau = tau1/tau3 = {profile.tau:.4f}',
                  fontsize=9)
    for mark in (profile.phi1, profile.phi2, profile.phi_end - profile.phi1):
        top.axvline(mark, color='grey', lw=0.6, ls=':')
        bottom.axvline(mark, color='grey', lw=0.6, ls=':')
    lines = bottom.plot(phi, samples.rho, color='tab:red', label=r'$\rho = r/2l$')
    bottom.set_ylabel('rho')
    bottom.set_xlabel(r'dimensionless time $\phi = \sqrt{\tau_3/(m l^2)}\,t$')
    twin = bottom.twinx()
    lines += twin.plot(phi, np.degrees(samples.theta), color='tab:blue', label=r'$\Theta$')
    twin.set_ylabel('Theta [deg]')
    bottom.legend(lines, [line.get_label() for line in lines], loc='center right', fontsize=8)
    bottom.text(profile.phi1, samples.rho.max(), r' $\phi_1$', fontsize=8, va='top')
    bottom.text(profile.phi2, samples.rho.max(), r' $\phi_2$', fontsize=8, va='top')
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def figure9(path: Path) -> Path:
    """Tip paths of 180 deg steps for the parameter sets of :data:`FIGURE9_CASES`."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(7.0, 9.0))
    for rho_start, rho_mid in FIGURE9_CASES:
        profile = PlanarProfile.solve(rho_start, rho_mid, 0.5 * math.pi)
        samples = profile.sample(np.linspace(0.0, profile.phi_end, 600))
        x, y = -samples.rho * np.sin(samples.theta), samples.rho * np.cos(samples.theta)
        detail = ('pure rotation, phi scaled by tau1' if profile.pure_rotation
                  else f'tau = {profile.tau:.3g}, phi_end = {profile.phi_end:.3g}')
        ax.plot(x, y, label=f'rho(0) = {rho_start}, rho_min = {rho_mid}: {detail}')
        ax.plot([x[0], x[-1]], [y[0], y[-1]], 'k.', ms=4)
    ax.plot(0.0, 0.0, 'ks', ms=7, label='base gripper (yaw axis)')
    ax.set_aspect('equal')
    ax.set_xlabel('x / 2l')
    ax.set_ylabel('y / 2l')
    ax.set_title('Figure 9: 180 deg node-to-node tip paths for several parameters', fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc='upper center', bbox_to_anchor=(0.5, -0.08), ncol=1)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def duration_figure(path: Path, params=None, nominal=None) -> Path:
    """Step duration against the midpoint radius, for the default robot and planner."""
    from walker_core.parameter_file import ParameterFile
    from walker_core.robot_parameters import WalkerParameters
    from walker_planner.core.parameters import PREFIX, PlannerParameters

    plt = _pyplot()
    defaults = ParameterFile.read()
    params = params or defaults.section(WalkerParameters)
    nominal = nominal or defaults.section(PlannerParameters, PREFIX).bang_bang
    rho_start = params.truss.spacing / (2.0 * params.robot.geometry.l2)
    torques_alone = PlanarModel.from_parameters(params)
    planned = PlanarModel.from_parameters(params, nominal.torque_fraction,
                                          nominal.velocity_fraction)
    rho_min = nominal.min_radius / (2.0 * params.robot.geometry.l2)
    rhos = np.linspace(0.2, rho_start, 120)
    fig, ax = plt.subplots(figsize=(7.5, 4.5))
    for sweep, style in ((180.0, '-'), (90.0, '--')):
        half = 0.5 * math.radians(sweep)
        ax.plot(rhos, [_duration(torques_alone, rho_start, r, half) for r in rhos], style,
                color='tab:blue', label=f'{sweep:.0f} deg, torque limits alone')
        ax.plot(rhos, [_duration(planned, rho_start, r, half) for r in rhos], style,
                color='tab:orange', label=f'{sweep:.0f} deg, nominal (torque and rate limits)')
    ax.axvline(rho_min, color='grey', ls=':', label='rho_min (planner.bang_bang.min_radius)')
    ax.set_xlabel('midpoint radius rho(phi2) = r / 2 l2')
    ax.set_ylabel('step duration [s]')
    ax.set_title(f'Node-to-node step on the default robot, rho(0) = {rho_start:.3f}',
                 fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def main(argv: list[str] | None = None) -> int:
    """Write the figures into ``--out`` and print their paths."""
    parser = argparse.ArgumentParser(description='Write the bang-bang planner figures '
                                                 '(paper Figures 8 and 9) as PNG files.')
    parser.add_argument('--out', type=Path, default=Path('planner_figures'),
                        help='output directory (created if missing)')
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    for write, name in ((figure8, 'figure8_torques_and_trajectory.png'),
                        (figure9, 'figure9_family_180deg.png'),
                        (duration_figure, 'duration_vs_midpoint.png')):
        print(write(args.out / name))
    return 0


if __name__ == '__main__':
    sys.exit(main())
