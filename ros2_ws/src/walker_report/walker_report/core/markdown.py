"""The report as Markdown: the bag's metadata, the step table, every figure, every step.

Images are linked by relative paths, so the report directory can be moved or served as is
(GitHub, GitLab and most Markdown viewers show the PNGs and play the GIF).
"""

from __future__ import annotations

import math
from pathlib import Path

from walker_bag.core.losses import loss_lines
from walker_report.core.analysis import JointStats
from walker_report.core.animation import AnimationResult
from walker_report.core.camera_figure import caption, title
from walker_report.core.steps import PHASES, format_markdown

__all__ = ['write_markdown']


def _xy(point) -> str:
    """x, y of a point [m] in mm; '-' when there is none."""
    return '-' if point is None else f'{point[0] * 1e3:+.2f}, {point[1] * 1e3:+.2f}'


def _mm(value: float) -> str:
    return '-' if not math.isfinite(value) else f'{value * 1e3:.2f}'


def _table(header: list[str], rows: list[list[str]]) -> list[str]:
    return (['| ' + ' | '.join(header) + ' |', '|' + '---|' * len(header)]
            + ['| ' + ' | '.join(cell.replace('|', '\\|') for cell in row) + ' |'
               for row in rows])


def _size(num_bytes: int) -> str:
    return (f'{num_bytes / 2**20:.1f} MiB' if num_bytes >= 2**20
            else f'{num_bytes / 2**10:.1f} KiB')


def _joint_rows(joints: list[JointStats]) -> list[list[str]]:
    rows = []
    for j in joints:
        errors = [f'{j.max_error[p] * 1e3:.2f}' if p in j.max_error else '-' for p in PHASES]
        rows.append([j.joint, f'{j.torque_limit:g}', f'{j.peak_effort:.2f}',
                     f'{100 * j.peak_fraction:.0f} %', str(j.saturated), *errors,
                     '-' if not math.isfinite(j.final_error) else f'{j.final_error * 1e3:.2f}',
                     str(j.stale)])
    return rows


def _camera_lines(content, figures: dict[str, Path]) -> list[str]:
    """Return the wrist camera's section: each screw-in's last frame (no frame: no section)."""
    if not content.screw_ins:
        return []
    lines = ['## The wrist camera before each screw-in', '',
             "Each step's last frame before its descent (the last of the look the descent went "
             "for), as the moving gripper's camera took it. Drawn over it through the nominal "
             'camera model: the hole the supervisor measured in this frame (solid, its centre '
             "a cross), the true hole (dashed: the simulation's truth, recorded beside each "
             "frame) and the gripper's axis where it meets the face. Offsets are the hole's axis "
             "from the gripper's axis, x and y in the gripper's frame, in mm. A frame measures "
             "a line of sight: the supervisor places it at the face's height the step assumed; "
             'carried along it to the true face it is what the image said, and its distance '
             'from the true hole is the vision error.', '']
    lines += _table(['step', 'node', 'camera', 'frame s', 'measured x, y mm (height assumed)',
                     'at the true face x, y mm', 'true x, y mm', 'apart mm'], [
        [str(f.step), f.to_node, f.gripper, f'{f.time:.2f}',
         'not seen' if f.measured is None else _xy(f.measured), _xy(f.seen),
         _xy(f.true), _mm(f.error)] for f in content.screw_ins]) + ['']
    for frame in content.screw_ins:
        name = f'camera_step_{frame.step:02d}'
        if name in figures:
            lines += [f'![{title(frame)}]({figures[name].name})', '', f'*{caption(frame)}*', '']
    return lines


def write_markdown(path: Path, content, figures: dict[str, Path],
                   animation: AnimationResult | None) -> Path:
    """Write ``report.md`` from a :class:`~walker_report.core.report.ReportContent`."""
    walk = content.walk
    bag = walk.bag
    lines = [f'# Walk report: {bag.path.parent.name}/{bag.path.name}', '']
    lines += [
        f'- bag: `{bag.path}` ({_size(bag.size_bytes)}), recorded on the '
        f'{bag.clock.replace("_", " ") or "(unknown)"} clock',
        f'- duration: {bag.duration:.2f} s, {bag.message_count} messages on '
        f'{len(bag.topics)} topics (namespace `{walk.namespace}`)',
        f'- steps in the phase timeline: {len(content.spans)}; step reports: '
        f'{len(walk.step_reports)}',
        f'- parameter file: `{content.params_file}` (truss layout, insertion tolerance '
        f'{content.tolerance * 1e3:g} mm, settling window {content.settle_time:g} s); torque '
        f'limits from {content.limits.source}',
        '']
    if content.notes:
        lines += ['**What is missing or went wrong:**', '']
        lines += [f'- {note}' for note in content.notes] + ['']
    lacking = loss_lines(bag.losses)
    if lacking:
        lines += ['**What the bag lacks** (its own record, `custom_data`):', '']
        lines += [f'- {line}' for line in lacking] + ['']

    lines += ['## Steps', '',
              "Times in s (the phases as the supervisor timed them), the step's time-optimal "
              'lower bound (the screw actions, and its extraction, coarse motion and insertion '
              "at the robot's limits: no step can be faster; not the paper's bang-bang "
              'family minimum) and the ratio of the step time to it; insertion error (tip '
              'distance from the hole axis, plant measurement) and residual vibration (largest '
              'tip deviation from its mean over the last settling before screw-in) in mm, from '
              'the step reports.', '']
    lines += [format_markdown(content.rows) if content.rows else '*No step report in the bag.*',
              '', '![steps](steps.png)', '']

    lines += ['## Phase timeline', '',
              'A row per step, a bar per phase (SAFE_HOLD hatched red, with its reason); below, '
              "the grippers' states and the controllers' mode.", '',
              '![phase timeline](timeline.png)', '']
    lines += _table(['step', 'phase', 'start s', 'end s', 'duration s', 'reason'], [
        [str(span.number), i.name, f'{i.start:.2f}', f'{i.end:.2f}', f'{i.duration:.2f}',
         i.reason] for span in content.spans for i in span.intervals]) + ['']

    lines += ['## Tip path over the truss', '',
              'Top view: the tip (the moving gripper) during every step, coloured by phase; the '
              'targets numbered by step. Right: the tip near each target hole from fine motion '
              'to the end of the step, with the insertion tolerance.', '',
              '![tip path](tip_path.png)', '']

    lines += ['## Joint errors and torques', '',
              'Position error (setpoint minus measured) and commanded torque of every joint '
              'against time, phases shaded; the torque limits dashed.', '',
              '![joints](joints.png)', '']
    lines += _table(['joint', 'limit N m', 'peak N m', 'of limit', 'clamped']
                    + [f'max err {p} mrad' for p in PHASES] + ['final err mrad', 'stale'],
                    _joint_rows(content.joints)) + ['']

    lines += ['## Tip vibration near each target', '',
              f"The tip's deviation from its mean over the settling window, the "
              f'{content.settle_time:g} s before insertion starts (joints still, links '
              f"possibly ringing; the plant's `tip_pose`).", '',
              '![vibration](vibration.png)', '']
    lines += _table(['step', 'target', 'window s', 'samples', 'amplitude mm',
                     'mean offset from the hole axis mm', 'mean height above the hole mm',
                     'residual at screw-in mm (step report)'], [
        [str(v.step), v.to_node, f'{v.window[0]:.2f} - {v.window[1]:.2f}',
         str(v.window_samples), _mm(v.amplitude), _mm(v.hole_offset), _mm(v.height),
         _mm(float(span.report.message.residual_vibration)) if span.report else '-']
        for span in content.spans if (v := content.vibrations.get(span.number))]) + ['']

    lines += _camera_lines(content, figures)
    lines += ['## Animation', '']
    if animation is not None:
        plan = animation.plan
        speed = ('real time' if abs(plan.speedup - 1.0) < 0.05
                 else f'{plan.speedup:.1f} times real time')
        lines += [f'{animation.frames} frames, one every {plan.interval:.2f} s of the walk, '
                  f'played at {speed}; rendered headless from the recorded joint states and '
                  f"gripper a's pose (links drawn straight: their bending is not recorded) in "
                  f'{animation.seconds:.1f} s.', '',
                  f'![walk]({animation.path.name})', '',
                  f'The last frame: ![last frame]({animation.still.name})', '']
    else:
        lines += ['*Not rendered.*', '']

    lines += ['## Every step', '']
    for span in content.spans:
        lines += [f'### {span.label}', '']
        report = span.report
        if report is not None:
            m = report.message
            phases = ', '.join(f'{name} {float(d):.2f} s'
                               for name, d in zip(m.phase_names, m.phase_durations,
                                                  strict=False))
            lines += [
                f'- gripper {m.moving_gripper} moved about {m.base_gripper} at {m.base_node}, '
                f'sweep {math.degrees(float(m.sweep)):+.0f} deg: '
                f'{"done" if m.success else "FAILED: " + m.message}',
                f'- {float(m.duration):.2f} s ({phases}); bound {float(m.time_optimal_bound):.3f}'
                f' s, ratio {float(m.bound_ratio):.2f}',
                f'- insertion error {_mm(float(m.insertion_error))} mm (estimated from the '
                f'joints: {_mm(float(m.insertion_error_estimated))} mm), '
                f'{int(m.insertion_attempts)} attempt(s)'
                + (f', {int(m.search_probes)} search probe(s), the hole found '
                   f'{_mm(float(m.hole_offset))} mm from the estimate'
                   if int(getattr(m, 'search_probes', 0)) else '')]
        else:
            lines += ['- no step report']
        vibration = content.vibrations.get(span.number)
        if vibration is not None:
            lines += [f'- insertion began at {vibration.insertion_start:.2f} s; tip vibration '
                      f'over the settling window {_mm(vibration.amplitude)} mm, mean '
                      f'{_mm(vibration.hole_offset)} mm off the hole axis, '
                      f'{_mm(vibration.height)} mm above the hole']
        if span.safe_hold is not None:
            lines += [f'- SAFE_HOLD at {span.safe_hold.start:.2f} s: {span.safe_hold.reason}']
        name = f'step_{span.number:02d}'
        if name in figures:
            lines += ['', f'![{span.label}]({figures[name].name})']
        lines += ['']

    lines += ['## Bag contents', '']
    lines += _table(['topic', 'type', 'messages'],
                    [[topic, kind, str(count)] for topic, (kind, count) in bag.topics.items()])
    path = Path(path)
    path.write_text('\n'.join(lines) + '\n')
    return path
