"""The walk report from a bag: read, compute, draw, animate, write Markdown and JSON.

:func:`make_report` is the whole job behind ``walk_report`` and the end of ``run_all.py``. It
checks its inputs first (parameter file, bag, options, output directory) and refuses bad ones
with a :class:`~walker_report.core.errors.ReportError` before writing anything. A bag that lacks
some topics still gives every figure it can; the report says what is missing and what that
costs.

What it writes into the output directory:

========================  ================================================================
``report.md``             the report: bag metadata, step table, every figure, every step
``report.json``           the numbers of the report (steps, phases, vibration, joints)
``timeline.png``          phase timeline (a row per step), grippers' states, controller modes
``tip_path.png``          tip path over the truss (top view) and the final approaches
``joints.png``            position errors and commanded torques of every joint, with limits
``vibration.png``         tip vibration near each target
``steps.png``             the per-step table as an image
``step_NN.png``           one figure per step
``camera_step_NN.png``    with wrist cameras: the last frame before step NN's screw-in, the
                          hole measured and the true one drawn over it
``walk.gif``              the animation (``walk_final.png``: its last frame, larger)
========================  ================================================================
"""

from __future__ import annotations

import dataclasses
import math
import os
import time
from collections.abc import Callable
from pathlib import Path

from walker_core.camera import CameraModel
from walker_core.parameter_file import ParameterFile, default_parameter_file
from walker_core.parameter_schema import ParameterError
from walker_core.robot_parameters import WalkerParameters
from walker_core.settling import SETTLING_PREFIX, SettlingWindow
from walker_core.truss import Truss
from walker_report.core import camera_figure, figures
from walker_report.core.analysis import (
    JointLimits, JointStats, PhaseInterval, StepSpan, TargetVibration, joint_limits,
    joint_stats, phase_intervals, step_spans, target_vibration)
from walker_report.core.animation import AnimationOptions, AnimationResult, render_animation
from walker_report.core.errors import ReportError
from walker_report.core.screw_in_frames import ScrewInFrame, screw_in_frames
from walker_report.core.steps import StepRow, format_table, rows_from_reports, write_json
from walker_report.core.walk_data import TOPICS, WalkData, load_walk

__all__ = ['ReportOptions', 'ReportContent', 'ReportResult', 'default_output_dir',
           'make_report', 'prepare_output', 'analyse', 'summary_text', 'Progress']

#: ``progress(stage, done, total)``: what the report is doing and how far it is.
Progress = Callable[[str, int, int], None]
_STEP_FIGURE = 'step_{:02d}.png'
_CAMERA_FIGURE = 'camera_step_{:02d}.png'


@dataclasses.dataclass(frozen=True)
class ReportOptions:
    """What goes into the report.

    Attributes
    ----------
    animation : bool
        Render the animation (the slowest part).
    animation_options : AnimationOptions
        Its rate, frame limit and size.
    namespace : str or None
        The robot's namespace in the bag (found from the topics when ``None``).
    settle_time : float or None
        The settling window before insertion for the vibration figures [s]; ``None``: the
        parameter file's ``supervisor.settle_time``, the window the supervisor waits.
    """

    animation: bool = True
    animation_options: AnimationOptions = AnimationOptions()
    namespace: str | None = None
    settle_time: float | None = None

    def __post_init__(self) -> None:
        if self.settle_time is not None and (
                isinstance(self.settle_time, bool) or not isinstance(self.settle_time,
                                                                     (int, float))
                or not math.isfinite(self.settle_time) or not 0.0 < self.settle_time <= 60.0):
            raise ReportError(f'the settling window must be 0 to 60 s, got '
                              f'{self.settle_time!r}')


@dataclasses.dataclass(frozen=True)
class ReportContent:
    """Everything the report shows, computed from the bag (no files).

    ``screw_ins`` are the camera's last frame before each screw-in (none without camera
    frames in the bag), ``camera`` the nominal camera model they are drawn with.
    """

    walk: WalkData
    params_file: Path
    truss: Truss
    tolerance: float
    settle_time: float
    intervals: list[PhaseInterval]
    spans: list[StepSpan]
    rows: list[StepRow]
    vibrations: dict[int, TargetVibration]
    limits: JointLimits
    joints: list[JointStats]
    notes: list[str]
    camera: CameraModel | None = None
    screw_ins: tuple[ScrewInFrame, ...] = ()


@dataclasses.dataclass(frozen=True)
class ReportResult:
    """What :func:`make_report` wrote.

    Attributes
    ----------
    directory, markdown, json : Path
        The output directory, ``report.md`` and ``report.json``.
    figures : dict of str to Path
        Every PNG written, by name (``timeline``, ..., ``step_01``).
    animation : AnimationResult or None
        The GIF, when rendered.
    content : ReportContent
        What the report shows.
    seconds : float
        Wall time the report took [s].
    """

    directory: Path
    markdown: Path
    json: Path
    figures: dict[str, Path]
    animation: AnimationResult | None
    content: ReportContent
    seconds: float

    @property
    def summary(self) -> str:
        """The text the command line prints: the step table, the vibration, the notes."""
        return summary_text(self.content)


def default_output_dir(bag_dir: str | Path) -> Path:
    """Return where the report of a bag goes by default: ``<bag>_report`` beside the bag."""
    bag_dir = Path(bag_dir)
    if bag_dir.suffix == '.mcap':
        bag_dir = bag_dir.parent
    bag_dir = bag_dir.resolve()
    return bag_dir.with_name(bag_dir.name + '_report')


def prepare_output(out: Path) -> Path:
    """Create the output directory, or clear the files of a former report out of it."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ReportError(f'the output {out} exists and is not a directory')
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise ReportError(f'cannot create the output directory {out}: {error.strerror}') \
            from None
    if not os.access(out, os.W_OK | os.X_OK):
        raise ReportError(f'the output directory {out} is not writable')
    # A former report's files that this one may not write again (fewer steps, no animation).
    for stale in [*out.glob('step_[0-9][0-9].png'), *out.glob('camera_step_[0-9][0-9].png'),
                  out / 'walk.gif', out / 'walk_final.png']:
        if stale.is_file():
            stale.unlink()
    return out


def analyse(walk: WalkData, params_file: Path, params, settle_time: float) -> ReportContent:
    """Compute everything the report shows from a walk read from its bag."""
    truss = Truss.from_parameters(params)
    intervals = phase_intervals(walk.phases, walk.end_time)
    spans = step_spans(intervals, walk.step_reports)
    rows = rows_from_reports([r.message for r in walk.step_reports])
    vibrations = {}
    for span in spans:
        vibration = target_vibration(span, walk.tip, settle_time, truss)
        if vibration is not None:
            vibrations[span.number] = vibration
    limits = joint_limits(walk.robot_description, params)
    joints = [joint_stats(series, limits.torque[name], intervals)
              for name, series in walk.controllers.items()]
    notes = [f'the bag has no {walk.namespace.rstrip("/")}/{topic}: {TOPICS[topic]}'
             for topic in walk.missing]
    if not walk.step_reports and 'step_reports' not in walk.missing:
        notes.append('the bag holds no step report (no step ended while it was recorded): '
                     'the step table is empty; the phases and figures show what was recorded')
    for span in spans:
        if span.report is None and 'step_reports' not in walk.missing:
            notes.append(f'{span.label} has no step report (the recording ended before the '
                         f'step did, or the report was not recorded)')
        if span.safe_hold is not None:
            notes.append(f'{span.label} ended in SAFE_HOLD at {span.safe_hold.start:.2f} s: '
                         f'{span.safe_hold.reason}')
        if span.number not in vibrations:
            notes.append(f'{span.label} never began insertion: no vibration near its target')
    return ReportContent(walk, params_file, truss, params.gripper.insertion_position_tolerance,
                         settle_time, intervals, spans, rows, vibrations, limits, joints, notes,
                         CameraModel.from_parameters(params.gripper.camera))


def make_report(bag: str | Path, out: str | Path | None = None,
                params_file: str | Path | None = None,
                options: ReportOptions = ReportOptions(),
                progress: Progress | None = None) -> ReportResult:
    """Make the walk report of a bag.

    Parameters
    ----------
    bag : str or Path
        The bag directory (or its MCAP file).
    out : str or Path, optional
        The output directory (default :func:`default_output_dir`); created if needed, and the
        report's own files in it replaced.
    params_file : str or Path, optional
        The parameter file the walk ran with, for the truss layout, the insertion tolerance,
        the settling window and the torque limits the bag does not carry (default: the
        installed ``walker.yaml``).
    options : ReportOptions
        What to include.
    progress : callable, optional
        ``progress(stage, done, total)`` while reading, drawing and rendering.

    Raises
    ------
    ReportError
        If the bag, the parameter file, an option or the output directory is unusable
        (nothing is written then).
    """
    started = time.monotonic()
    if not isinstance(options, ReportOptions):
        raise ReportError(f'options must be ReportOptions, got {type(options).__name__}')
    params_file = Path(params_file or default_parameter_file())
    try:
        # The walk's own file, which the walk's configuration loader accepted: the report
        # reads the two sections it needs and no more, so it runs without the supervisor,
        # planner or controllers (test_layers.py).
        file = ParameterFile.read(params_file)  # once, for every section the report needs
        params = file.section(WalkerParameters)
        settle_time = options.settle_time or file.section(SettlingWindow,
                                                          SETTLING_PREFIX).settle_time
    except ParameterError as error:
        raise ReportError(f'the parameter file {params_file}: {error}') from None
    say = progress or (lambda *_: None)
    walk = load_walk(bag, options.namespace,
                     progress=lambda done, total: say('reading the bag', done, total))
    if walk.bag.message_count == 0:
        raise ReportError(f'the bag {walk.bag.path} holds no message: nothing to report')
    content = analyse(walk, params_file, params, settle_time)
    content = dataclasses.replace(content, screw_ins=tuple(screw_in_frames(
        walk, content.spans,
        progress=lambda done, total: say('reading the camera frames', done, total),
        camera_centre=content.camera.mount[:3, 3] if content.camera is not None else None)))
    out = prepare_output(Path(out) if out is not None else default_output_dir(walk.bag.path))
    written = _draw(out, content, say)
    animation = None
    if options.animation:
        try:
            animation = render_animation(
                out / 'walk.gif', walk, params, content.intervals, options.animation_options,
                progress=lambda done, total: say('rendering the animation', done, total))
        except ValueError as error:
            content.notes.append(f'no animation: {error}')
    from walker_report.core.markdown import write_markdown

    markdown = write_markdown(out / 'report.md', content, written, animation)
    json_path = out / 'report.json'
    write_json(content.rows, json_path, _json_extra(content, written, animation))
    say('writing the report', 1, 1)
    return ReportResult(out, markdown, json_path, written, animation, content,
                        time.monotonic() - started)


def _draw(out: Path, content: ReportContent, say: Progress) -> dict[str, Path]:
    walk = content.walk
    jobs = [
        ('timeline', lambda p: figures.timeline_figure(p, content.spans, content.intervals,
                                                       walk)),
        ('tip_path', lambda p: figures.tip_path_figure(p, walk, content.spans, content.truss,
                                                       content.tolerance)),
        ('joints', lambda p: figures.joints_figure(p, walk.controllers, content.limits,
                                                   content.intervals, walk.end_time)),
        ('vibration', lambda p: figures.vibration_figure(p, list(content.vibrations.values()))),
        ('steps', lambda p: figures.step_table_figure(p, content.rows)),
    ]
    for span in content.spans:
        jobs.append((Path(_STEP_FIGURE.format(span.number)).stem,
                     lambda p, s=span: figures.step_figure(
                         p, s, walk, content.truss, content.tolerance,
                         content.vibrations.get(s.number))))
    for frame in content.screw_ins:
        jobs.append((Path(_CAMERA_FIGURE.format(frame.step)).stem,
                     lambda p, f=frame: camera_figure.screw_in_figure(
                         p, f, content.camera, content.tolerance)))
    written = {}
    for k, (name, draw) in enumerate(jobs):
        say('drawing the figures', k, len(jobs))
        written[name] = draw(out / f'{name}.png')
    say('drawing the figures', len(jobs), len(jobs))
    return written


def _finite(value: float) -> float | None:
    return value if math.isfinite(value) else None


def _json_extra(content: ReportContent, written: dict[str, Path],
                animation: AnimationResult | None) -> dict:
    walk = content.walk
    return {
        'bag': {'path': str(walk.bag.path), 'duration': walk.bag.duration,
                'message_count': walk.bag.message_count, 'clock': walk.bag.clock,
                'topics': {t: {'type': k, 'count': n} for t, (k, n) in walk.bag.topics.items()}},
        'params_file': str(content.params_file),
        'phases': [{'phase': i.name, 'start': i.start, 'end': i.end,
                    'step_index': i.step_index, 'from_node': i.from_node,
                    'to_node': i.to_node, 'reason': i.reason} for i in content.intervals],
        'step_spans': [{'number': s.number, 'step_index': s.step_index,
                        'from_node': s.from_node, 'to_node': s.to_node, 'start': s.start,
                        'end': s.end, 'insertion_start': s.insertion_start,
                        'safe_hold': s.safe_hold.reason if s.safe_hold else None,
                        'has_report': s.report is not None} for s in content.spans],
        'settle_time': content.settle_time,
        'vibration': [{'step': v.step, 'to_node': v.to_node, 'window': list(v.window),
                       'samples': v.window_samples, 'amplitude': _finite(v.amplitude),
                       'hole_offset': _finite(v.hole_offset), 'height': _finite(v.height)}
                      for v in content.vibrations.values()],
        'torque_limits': {'source': content.limits.source, **content.limits.torque},
        'joints': [{'joint': j.joint, 'torque_limit': j.torque_limit,
                    'peak_effort': j.peak_effort, 'peak_fraction': j.peak_fraction,
                    'saturated': j.saturated, 'stale': j.stale, 'samples': j.samples,
                    'max_error': j.max_error, 'final_error': _finite(j.final_error)}
                   for j in content.joints],
        'figures': {name: path.name for name, path in written.items()},
        'animation': None if animation is None else {
            'file': animation.path.name, 'still': animation.still.name,
            'frames': animation.frames, 'interval': animation.plan.interval,
            'delay': animation.plan.delay, 'speedup': animation.plan.speedup,
            'seconds': animation.seconds},
        'notes': content.notes,
        **({'screw_in_frames': [
            {**frame.numbers(), 'figure': _CAMERA_FIGURE.format(frame.step)}
            for frame in content.screw_ins]} if content.screw_ins else {}),
    }


def summary_text(content: ReportContent) -> str:
    """Return the report's summary as text: the step table, vibration, torques and notes."""
    walk = content.walk
    lines = [f'walk report of {walk.bag.path}: {walk.bag.duration:.2f} s '
             f'({walk.bag.clock.replace("_", " ") or "clock unknown"}), '
             f'{walk.bag.message_count} messages, {len(content.spans)} '
             f'step{"s" if len(content.spans) != 1 else ""} in the phases']
    lines.append(format_table(content.rows) if content.rows else 'no step report in the bag')
    if content.vibrations:
        lines.append(f'tip vibration near each target (over the {content.settle_time:.1f} s '
                     f'before insertion): ' + ', '.join(
                         f'step {v.step} -> {v.to_node} {v.amplitude * 1e3:.2f} mm'
                         for v in content.vibrations.values()))
    if content.joints:
        lines.append('peak torque / limit: ' + ', '.join(
            f'{j.joint.removesuffix("_joint")} {j.peak_effort:.1f}/{j.torque_limit:g} N m'
            + (f' ({j.saturated} clamped)' if j.saturated else '') for j in content.joints))
    if content.screw_ins:
        lines.append('the wrist camera before each screw-in: ' + '; '.join(
            f'step {f.step} -> {f.to_node} {camera_figure.caption(f)}'
            for f in content.screw_ins))
    lines += [f'note: {note}' for note in content.notes]
    return '\n'.join(lines)
