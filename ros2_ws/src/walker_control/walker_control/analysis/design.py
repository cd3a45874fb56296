"""``control_analysis design``: the stability check of every loop of a parameter file."""

from __future__ import annotations

import argparse


__all__ = ['run_design']


def run_design(args: argparse.Namespace) -> int:
    """Print the stability check of every loop of ``args.params_file``; 2 if refused."""
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
