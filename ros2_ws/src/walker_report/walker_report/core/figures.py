"""The report's figures, drawn with matplotlib's Agg canvas (no display, no pyplot state).

Each function draws one figure from the arrays of :mod:`walker_report.core.walk_data` and the
results of :mod:`walker_report.core.analysis` and writes it as a PNG of a fixed width
(:data:`DPI` times the figure's width in inches). Lengths are drawn in mm near the targets
and in m over the truss, angles in mrad, torques in N*m, times in s from the bag's start.
"""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib
import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, Patch

from walker_core.gripper_state import GripperState
from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_core.truss import Truss, UnknownNodeError
from walker_report.core.analysis import (
    COARSE, EXTRACTION, FINE, IDLE, INSERTION, SAFE_HOLD, JointLimits, PhaseInterval, StepSpan,
    TargetVibration, phase_name)
from walker_report.core.steps import StepRow, table_cells
from walker_report.core.walk_data import ControllerSeries, WalkData

__all__ = ['DPI', 'PHASE_COLORS', 'timeline_figure', 'tip_path_figure', 'joints_figure',
           'vibration_figure', 'step_table_figure', 'step_figure']

#: Resolution of every figure [dots per inch].
DPI = 100
#: Colour of each phase, by ``walker_msgs/StepPhase`` constant.
PHASE_COLORS = {IDLE: '#d9d9d9', EXTRACTION: '#8c6bb1', COARSE: '#e6550d', FINE: '#3182bd',
                INSERTION: '#31a354', SAFE_HOLD: '#d62728'}
_GRIPPER_COLORS = {GripperState.FREE: '#f0f0f0', GripperState.SCREWING: '#fdd49e',
                   GripperState.ATTACHED: '#74c476', GripperState.UNSCREWING: '#fdd49e',
                   GripperState.JAMMED: '#d62728'}
#: Each ``walker_msgs/GripperState`` code's label and color
_GRIPPER_STATES = {state.code: (str(state), color) for state, color in _GRIPPER_COLORS.items()}
_MODES = {0: ('off', '#bdbdbd'), 1: ('hold', '#969696'), 2: ('coarse', PHASE_COLORS[COARSE]),
          3: ('fine', PHASE_COLORS[FINE])}
_STEP_COLORS = matplotlib.colormaps['tab10'].colors
_LABEL_BOX = {'facecolor': 'white', 'alpha': 0.85, 'lw': 0, 'pad': 1.5}


def _short(text: str, length: int = 70) -> str:
    """Shorten a long reason for a label (the report's tables give it whole)."""
    return text if len(text) <= length else text[:length - 3].rstrip() + '...'


def _save(figure: Figure, path: Path) -> Path:
    path = Path(path)
    figure.savefig(path, dpi=DPI, facecolor='white')
    return path


def _phase_legend() -> list[Patch]:
    return [Patch(color=PHASE_COLORS[p], label=phase_name(p))
            for p in (EXTRACTION, COARSE, FINE, INSERTION, SAFE_HOLD)]


def _shade_phases(axes, intervals: list[PhaseInterval], alpha: float = 0.12) -> None:
    for interval in intervals:
        if interval.phase != IDLE:
            axes.axvspan(interval.start, interval.end, color=PHASE_COLORS.get(interval.phase),
                         alpha=alpha, lw=0)


def timeline_figure(path: Path, spans: list[StepSpan], intervals: list[PhaseInterval],
                    walk: WalkData) -> Path:
    """Draw the phase timeline: a bar per phase, a row per step; grippers and modes below.

    SAFE_HOLD intervals are drawn hatched in red, with the reason beside them.
    """
    rows = max(1, len(spans))
    figure = Figure(figsize=(12.0, 2.6 + 0.45 * rows))
    grid = figure.add_gridspec(2, 1, height_ratios=[max(1.2, 0.45 * rows), 1.3], hspace=0.08)
    top = figure.add_subplot(grid[0])
    bottom = figure.add_subplot(grid[1], sharex=top)
    end = walk.end_time
    for row, span in enumerate(spans):
        for interval in span.intervals:
            hold = interval.phase == SAFE_HOLD
            top.barh(row, interval.duration, left=interval.start, height=0.6,
                     color=PHASE_COLORS.get(interval.phase, 'k'), hatch='//' if hold else None,
                     edgecolor='k' if hold else 'none', lw=0.5)
            if hold:
                late = interval.start > 0.6 * end  # write the reason where it fits
                top.annotate(f'SAFE HOLD: {_short(interval.reason)}', (interval.start, row),
                             xytext=(-4 if late else 4, 9), textcoords='offset points',
                             ha='right' if late else 'left', fontsize=8,
                             color=PHASE_COLORS[SAFE_HOLD], bbox=_LABEL_BOX)
            elif interval.duration > 0.06 * max(end, 1e-9):
                top.text(interval.start + 0.5 * interval.duration, row,
                         f'{interval.duration:.1f} s', ha='center', va='center', fontsize=7,
                         color='white')
    for interval in intervals:  # a SAFE_HOLD outside any step
        if interval.phase == SAFE_HOLD and not any(interval in s.intervals for s in spans):
            top.axvspan(interval.start, interval.end, color=PHASE_COLORS[SAFE_HOLD], alpha=0.3)
            top.annotate(f'SAFE HOLD: {_short(interval.reason)}', (interval.start, rows - 0.5),
                         fontsize=8, color=PHASE_COLORS[SAFE_HOLD])
    top.set_yticks(range(len(spans)), [s.label for s in spans])
    top.set_ylim(rows - 0.5, -0.5)
    if not spans:
        top.text(0.5, 0.5, 'no step in this bag' if walk.phases else 'no phase recorded',
                 transform=top.transAxes, ha='center', va='center', color='0.4')
        top.set_yticks([])
    top.legend(handles=_phase_legend(), loc='lower center', bbox_to_anchor=(0.5, 1.0), ncol=5,
               frameon=False, fontsize=9)
    top.grid(axis='x', alpha=0.3)
    top.tick_params(labelbottom=False)
    _draw_states(bottom, walk, end)
    bottom.set_xlabel('time [s]')
    bottom.set_xlim(min(0.0, *(i.start for i in intervals)) if intervals else 0.0,
                    max(end, 1e-3))
    figure.subplots_adjust(left=0.16, right=0.98, top=0.9, bottom=0.3 / (1 + 0.2 * rows))
    return _save(figure, path)


def _draw_states(axes, walk: WalkData, end: float) -> None:
    labels = ['gripper a', 'gripper b', 'controllers']
    events = walk.gripper_events
    for row, name in enumerate(('a', 'b')):
        for i, event in enumerate(events):
            stop = events[i + 1].time if i + 1 < len(events) else end
            state, node = event.states.get(name, (-1, ''))
            text, color = _GRIPPER_STATES.get(state, ('?', 'w'))
            axes.barh(row, stop - event.time, left=event.time, height=0.6, color=color,
                      edgecolor='0.6', lw=0.4)
            if stop - event.time > 0.05 * max(end, 1e-9):
                axes.text(0.5 * (event.time + stop), row, f'{text} {node}'.strip(),
                          ha='center', va='center', fontsize=7)
    for i, event in enumerate(walk.modes):
        stop = walk.modes[i + 1].time if i + 1 < len(walk.modes) else end
        text, color = _MODES.get(event.mode, ('?', 'w'))
        axes.barh(2, stop - event.time, left=event.time, height=0.6, color=color, lw=0)
        if stop - event.time > 0.05 * max(end, 1e-9):
            axes.text(0.5 * (event.time + stop), 2, f'{text} (base {event.base_gripper})',
                      ha='center', va='center', fontsize=7, color='white')
    if not events and not walk.modes:
        axes.text(0.5, 0.5, 'no gripper states or control modes recorded', ha='center',
                  va='center', transform=axes.transAxes, color='0.4')
    axes.set_yticks(range(3), labels)
    axes.set_ylim(2.5, -0.5)
    axes.grid(axis='x', alpha=0.3)


def _draw_truss(axes, truss: Truss, labels: bool = True) -> None:
    for name in truss.node_names:
        x, y, _ = truss.position(name)
        column, row = truss.index(name)
        if column + 1 < truss.columns:
            axes.plot([x, x + truss.spacing], [y, y], color='0.8', lw=3, zorder=0)
        if row + 1 < truss.rows:
            axes.plot([x, x], [y, y + truss.spacing], color='0.8', lw=3, zorder=0)
        axes.plot(x, y, 's', color='#6b7b99', ms=8, zorder=1)
        if labels:
            axes.annotate(name, (x, y), xytext=(5, -11), textcoords='offset points',
                          fontsize=7, color='0.4')


def _node_position(truss: Truss, name: str) -> np.ndarray | None:
    try:
        return truss.position(name)
    except UnknownNodeError:
        return None


def tip_path_figure(path: Path, walk: WalkData, spans: list[StepSpan], truss: Truss,
                    tolerance: float) -> Path:
    """Draw the tip path over the truss (top view) and each step's final approach to its hole.

    Left: the truss grid, the tip's path during every step coloured by phase, the step targets
    numbered, where the grippers stood at the start. Right: the tip relative to each target
    hole from the settling above it to the end of the step [mm], with the insertion tolerance
    ``tolerance`` [m] as a circle.
    """
    figure = Figure(figsize=(13.0, 6.0))
    grid = figure.add_gridspec(1, 2, width_ratios=[1.6, 1.0], wspace=0.22)
    axes = figure.add_subplot(grid[0])
    _draw_truss(axes, truss)
    tip = walk.tip
    for span in spans:
        for interval in span.intervals:
            inside = (tip.time >= interval.start) & (tip.time <= interval.end)
            if np.any(inside):
                axes.plot(tip.position[inside, 0], tip.position[inside, 1],
                          color=PHASE_COLORS.get(interval.phase, 'k'), lw=1.8, zorder=3)
        target = _node_position(truss, span.to_node)
        if target is not None:
            axes.add_patch(Circle(target[:2], 0.08, fill=False, color='k', lw=1.2, zorder=4))
            axes.annotate(str(span.number), target[:2], xytext=(7, 7),
                          textcoords='offset points', fontsize=10, weight='bold', zorder=5)
    handles = _phase_legend()[:4] + [
        Line2D([], [], ls='none', marker='o', ms=11, mfc='none', color='k',
               label='step target (number)')]
    for name, marker in (('a', '^'), ('b', 'D')):
        poses = walk.gripper_poses[name]
        if len(poses):
            axes.plot(*poses.position[0, :2], marker, color='k', mfc='none', ms=12, mew=1.5,
                      zorder=4)
            handles.append(Line2D([], [], ls='none', marker=marker, ms=9, mfc='none',
                                  color='k', label=f'gripper {name} at the start'))
    axes.legend(handles=handles, loc='upper left', bbox_to_anchor=(0.0, -0.09), ncol=4,
                fontsize=8, frameon=False)
    margin = 0.45 * truss.spacing
    axes.set_xlim(truss.origin[0] - margin, truss.origin[0] + (truss.columns - 1)
                  * truss.spacing + margin)
    axes.set_ylim(truss.origin[1] - margin, truss.origin[1] + (truss.rows - 1)
                  * truss.spacing + margin)
    axes.set_aspect('equal')
    axes.set_xlabel('x [m] (truss frame)')
    axes.set_ylabel('y [m]')
    axes.set_title('tip path over the truss (top view)')
    if not len(tip):
        axes.text(0.5, 0.5, 'no tip_pose recorded', transform=axes.transAxes, ha='center')
    _draw_approaches(figure.add_subplot(grid[1]), tip, spans, truss, tolerance)
    figure.subplots_adjust(left=0.06, right=0.98, top=0.93, bottom=0.2)
    return _save(figure, path)


def _approach(tip, span: StepSpan, truss: Truss):
    target = _node_position(truss, span.to_node)
    start = span.insertion_start
    if target is None or start is None:
        return None
    fine = [i.start for i in span.intervals if i.phase == FINE]
    since = fine[-1] if fine else start
    inside = (tip.time >= since) & (tip.time <= span.end)
    return (tip.position[inside] - target) * 1e3, tip.time[inside] >= start


def _draw_approaches(axes, tip, spans: list[StepSpan], truss: Truss, tolerance: float) -> None:
    extent = 2.0 * tolerance * 1e3
    drawn = False
    for k, span in enumerate(spans):
        approach = _approach(tip, span, truss)
        if approach is None or not len(approach[0]):
            continue
        offset, inserting = approach
        color = _STEP_COLORS[k % len(_STEP_COLORS)]
        axes.plot(offset[:, 0], offset[:, 1], color=color, lw=1.0, alpha=0.8,
                  label=f'step {span.number} -> {span.to_node}')
        if np.any(inserting):
            first = offset[np.argmax(inserting)]
            axes.plot(first[0], first[1], 'o', color=color, ms=7, mec='k')
            axes.plot(offset[-1, 0], offset[-1, 1], 's', color=color, ms=6, mec='k')
            settled = offset[inserting]
            extent = max(extent, 1.3 * float(np.max(np.abs(settled[:, :2]))))
        drawn = True
    axes.add_patch(Circle((0, 0), tolerance * 1e3, fill=False, color='k', ls='--', lw=1.0,
                          label=f'insertion tolerance ({tolerance * 1e3:.0f} mm)'))
    axes.plot(0, 0, '+', color='k', ms=12)
    axes.set_xlim(-extent, extent)
    axes.set_ylim(-extent, extent)
    axes.set_aspect('equal')
    axes.set_xlabel('x - hole [mm]')
    axes.set_ylabel('y - hole [mm]')
    axes.set_title('tip near the target hole, fine motion to the end\n'
                   '(dot: insertion starts, square: the step ends)', fontsize=10)
    axes.grid(alpha=0.3)
    if drawn:
        axes.legend(fontsize=8, loc='upper left', bbox_to_anchor=(0.0, -0.12), ncol=2,
                    frameon=False)
    else:
        axes.text(0.5, 0.9, 'no insertion recorded', transform=axes.transAxes, ha='center',
                  color='0.4')


def joints_figure(path: Path, controllers: dict[str, ControllerSeries], limits: JointLimits,
                  intervals: list[PhaseInterval], end_time: float) -> Path:
    """Draw every joint's position error and commanded torque against time, phases shaded.

    The error axis is symmetric-logarithmic (linear within +-1 mrad), so both the coarse
    motion's lag and the fine motion's sub-mrad errors show; the torque axis carries the
    joint's limit as dashed lines, and clamped samples are marked.
    """
    figure = Figure(figsize=(13.0, 11.0))
    axes = figure.subplots(len(PHYSICAL_JOINT_NAMES), 2, sharex=True)
    for row, joint in enumerate(PHYSICAL_JOINT_NAMES):
        error_axes, effort_axes = axes[row]
        for ax in (error_axes, effort_axes):
            _shade_phases(ax, intervals)
            ax.grid(alpha=0.3)
        limit = limits.torque[joint]
        series = controllers.get(joint)
        if series is None:
            for ax in (error_axes, effort_axes):
                ax.text(0.5, 0.5, 'no controller state recorded', transform=ax.transAxes,
                        ha='center', va='center', color='0.4')
        else:
            error_axes.plot(series.time, series.position_error * 1e3, color='k', lw=0.8)
            effort_axes.plot(series.time, series.effort, color='k', lw=0.8)
            clamped = series.saturated
            if np.any(clamped):
                effort_axes.plot(series.time[clamped], series.effort[clamped], 'x',
                                 color=PHASE_COLORS[SAFE_HOLD], ms=4)
        error_axes.set_yscale('symlog', linthresh=1.0)
        error_axes.set_ylabel(f'{joint}\nerror [mrad]', fontsize=9)
        for sign in (1, -1):
            effort_axes.axhline(sign * limit, color=PHASE_COLORS[SAFE_HOLD], ls='--', lw=1.0)
        effort_axes.set_ylim(-1.15 * limit, 1.15 * limit)
        effort_axes.set_ylabel('torque [N m]', fontsize=9)
        effort_axes.text(0.005, 0.97, f'limit \u00b1{limit:g} N m', ha='left', va='top',
                         transform=effort_axes.transAxes, fontsize=8,
                         color=PHASE_COLORS[SAFE_HOLD])
    axes[0, 0].set_title('position error (setpoint - measured), linear within \u00b11 mrad',
                         fontsize=10)
    axes[0, 1].set_title(f'commanded torque and its limit (from {limits.source})', fontsize=10)
    for ax in axes[-1]:
        ax.set_xlabel('time [s]')
        ax.set_xlim(0.0, max(end_time, 1e-3))
    figure.legend(handles=_phase_legend()[:4], loc='upper center', ncol=4, frameon=False,
                  fontsize=9)
    figure.subplots_adjust(left=0.09, right=0.98, top=0.93, bottom=0.05, hspace=0.12,
                           wspace=0.2)
    return _save(figure, path)


def _draw_vibration(axes, vibration: TargetVibration, title: bool = True) -> None:
    deviation = vibration.deviation * 1e3
    start, end = vibration.window[0] - vibration.insertion_start, 0.0
    axes.axvspan(start, end, color=PHASE_COLORS[FINE], alpha=0.12, lw=0)
    for k, (name, color) in enumerate((('x', '#1f77b4'), ('y', '#ff7f0e'), ('z', '#2ca02c'))):
        axes.plot(vibration.time, deviation[:, k], color=color, lw=0.9, label=name)
    norm = np.linalg.norm(deviation, axis=1)
    axes.plot(vibration.time, norm, color='k', lw=1.0, label='distance')
    amplitude = vibration.amplitude * 1e3
    if math.isfinite(amplitude):
        axes.axhline(amplitude, color='k', ls=':', lw=1.0)
        axes.axhline(-amplitude, color='k', ls=':', lw=1.0)
        in_window = vibration.time >= start
        reach = 3.0 * max(amplitude, 0.05)
        low = float(np.min(deviation[in_window])) if np.any(in_window) else -reach
        axes.set_ylim(min(-reach, 1.2 * low), reach)
    axes.set_xlim(min(start, float(vibration.time[0])) if len(vibration.time) else start, 0.05)
    axes.text(0.02, 0.95, f'amplitude {amplitude:.2f} mm over the last {end - start:.1f} s',
              transform=axes.transAxes, va='top', fontsize=8,
              bbox={'facecolor': 'white', 'alpha': 0.8, 'lw': 0})
    axes.set_xlabel('time to insertion start [s]')
    axes.set_ylabel('deviation [mm]')
    axes.grid(alpha=0.3)
    if title:
        axes.set_title(f'step {vibration.step} -> {vibration.to_node}', fontsize=10)


def vibration_figure(path: Path, vibrations: list[TargetVibration]) -> Path:
    """Draw the tip near each target: deviation from the settling window's mean, per step.

    The shaded span is the settling window before insertion starts; the dotted lines are the
    amplitude, the largest distance from the mean in that window.
    """
    count = max(1, len(vibrations))
    columns = min(3, count)
    rows = math.ceil(count / columns)
    figure = Figure(figsize=(max(8.0, 4.4 * columns + 0.6), 3.4 * rows + 0.8))
    axes = np.atleast_1d(figure.subplots(rows, columns, squeeze=False)).ravel()
    for ax, vibration in zip(axes, vibrations, strict=False):
        _draw_vibration(ax, vibration)
    for ax in axes[len(vibrations):]:
        ax.set_axis_off()
    if not vibrations:
        axes[0].text(0.5, 0.5, 'no step reached insertion', ha='center', va='center',
                     transform=axes[0].transAxes, color='0.4')
    else:
        axes[0].legend(fontsize=8, loc='lower left', ncol=4)
    figure.suptitle('tip vibration near each target:\ndeviation from its mean over the '
                    'settling window (shaded) before insertion', fontsize=11)
    figure.tight_layout(rect=(0, 0, 1, 0.93))
    return _save(figure, path)


def step_table_figure(path: Path, rows: list[StepRow]) -> Path:
    """Draw the per-step table (the one the report prints) as an image."""
    header, body = table_cells(rows)
    figure = Figure(figsize=(12.0, 0.9 + 0.3 * (len(body) + 1)))
    axes = figure.add_subplot()
    axes.set_axis_off()
    if not body:
        axes.text(0.5, 0.5, 'no step report in this bag', ha='center', va='center',
                  color='0.4')
        return _save(figure, path)
    table = axes.table(cellText=body, colLabels=header, loc='center', cellLoc='center')
    table.auto_set_font_size(False)
    table.set_fontsize(9)
    table.auto_set_column_width(list(range(len(header))))
    table.scale(1.3, 1.4)
    for (row, _), cell in table.get_celld().items():
        if row == 0:
            cell.set_facecolor('#e8e8e8')
            cell.set_text_props(weight='bold')
        elif body[row - 1][-1] == 'NO':
            cell.set_facecolor('#fbe3e3')
    axes.set_title('steps (times in s; insertion error and vibration at screw-in from the '
                   'step reports, mm)', fontsize=10)
    figure.subplots_adjust(left=0.01, right=0.99, top=0.85, bottom=0.02)
    return _save(figure, path)


def step_figure(path: Path, span: StepSpan, walk: WalkData, truss: Truss, tolerance: float,
                vibration: TargetVibration | None) -> Path:
    """Draw one step: its phases, the tip's height and distance to the target, its vibration."""
    figure = Figure(figsize=(13.0, 4.2))
    axes = figure.subplots(1, 3, gridspec_kw={'width_ratios': [1.4, 1.0, 1.0]})
    tip = walk.tip
    inside = (tip.time >= span.start) & (tip.time <= span.end)
    target = _node_position(truss, span.to_node)
    ax = axes[0]
    _shade_phases(ax, list(span.intervals), alpha=0.18)
    if target is not None and np.any(inside):
        offset = tip.position[inside] - target
        ax.plot(tip.time[inside], np.linalg.norm(offset[:, :2], axis=1) * 1e3, color='k',
                lw=1.0, label='horizontal distance')
        ax.plot(tip.time[inside], offset[:, 2] * 1e3, color='#2ca02c', lw=1.0,
                label='height above the hole')
        ax.set_yscale('symlog', linthresh=1.0)
        ax.legend(fontsize=8, loc='upper right')
    ax.set_xlabel('time [s]')
    ax.set_ylabel('tip to target hole [mm]')
    ax.set_title(f'{span.label}: the tip and its target', fontsize=10)
    ax.grid(alpha=0.3)
    _draw_approaches(axes[1], tip, [span], truss, tolerance)
    if vibration is not None:
        _draw_vibration(axes[2], vibration, title=False)
        axes[2].set_title('vibration near the target', fontsize=10)
    else:
        axes[2].text(0.5, 0.5, 'insertion never began', ha='center', va='center',
                     transform=axes[2].transAxes, color='0.4')
        axes[2].set_axis_off()
    hold = span.safe_hold
    if hold is not None:
        figure.text(0.01, 0.01, f'SAFE HOLD at {hold.start:.2f} s: {_short(hold.reason, 150)}',
                    color=PHASE_COLORS[SAFE_HOLD], fontsize=9)
    figure.tight_layout(rect=(0, 0.04 if hold is not None else 0, 1, 1))
    return _save(figure, path)

