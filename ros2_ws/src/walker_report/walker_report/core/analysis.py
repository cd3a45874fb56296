"""What the report computes from a walk: phase timeline, steps, vibration near targets, joints.

Every function takes the arrays of :mod:`walker_report.core.walk_data` and returns plain
dataclasses; nothing here draws or writes. Times are in s from the bag's start, lengths in m,
angles in rad, torques in N*m.
"""

from __future__ import annotations

import dataclasses
import math
import xml.etree.ElementTree as ElementTree

import numpy as np

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_core.truss import Truss, UnknownNodeError
from walker_report.core.walk_data import (
    ControllerSeries, PhaseEvent, PoseSeries, StepReportRecord)

__all__ = [
    'IDLE', 'EXTRACTION', 'COARSE', 'FINE', 'INSERTION', 'SAFE_HOLD', 'PHASE_NAMES',
    'phase_name', 'PhaseInterval', 'StepSpan', 'TargetVibration', 'JointLimits', 'JointStats',
    'phase_intervals', 'step_spans', 'target_vibration', 'joint_limits', 'joint_stats',
]

# The walker_msgs/StepPhase constants.
IDLE, EXTRACTION, COARSE, FINE, INSERTION, SAFE_HOLD = range(6)
#: Name of each phase constant.
PHASE_NAMES = ('idle', 'extraction', 'coarse', 'fine', 'insertion', 'safe hold')


def phase_name(phase: int) -> str:
    """Return the name of a ``walker_msgs/StepPhase`` constant (``phase <n>`` if unknown)."""
    return PHASE_NAMES[phase] if 0 <= phase < len(PHASE_NAMES) else f'phase {phase}'


@dataclasses.dataclass(frozen=True)
class PhaseInterval:
    """A phase from the message that entered it to the next phase message (or the bag's end).

    Attributes
    ----------
    phase : int
        ``walker_msgs/StepPhase`` constant.
    start, end : float
        [s].
    step_index, step_count : int
        As published: the step within its walk and the walk's length.
    from_node, to_node : str
        The step's nodes (``''`` outside a step).
    reason : str
        Why the phase was entered (the fault behind a SAFE_HOLD).
    """

    phase: int
    start: float
    end: float
    step_index: int
    step_count: int
    from_node: str
    to_node: str
    reason: str

    @property
    def name(self) -> str:
        """The phase's name."""
        return phase_name(self.phase)

    @property
    def duration(self) -> float:
        """Length of the interval [s]."""
        return self.end - self.start


@dataclasses.dataclass(frozen=True)
class StepSpan:
    """One step as the phase timeline shows it, with its step report when one was recorded.

    Attributes
    ----------
    number : int
        1-based order of the step in the bag.
    step_index : int
        0-based index of the step within its walk (as published).
    base_gripper, from_node, to_node : str
        The pivot gripper and the moving gripper's nodes.
    intervals : tuple of PhaseInterval
        The step's phases, extraction to insertion, and the SAFE_HOLD that ended it, if any.
    report : StepReportRecord or None
        The step's report (``None`` when the bag holds none for it).
    """

    number: int
    step_index: int
    base_gripper: str
    from_node: str
    to_node: str
    intervals: tuple[PhaseInterval, ...]
    report: StepReportRecord | None = None

    @property
    def start(self) -> float:
        """When the step's first phase began [s]."""
        return self.intervals[0].start

    @property
    def end(self) -> float:
        """When the step's last phase ended [s]."""
        return self.intervals[-1].end

    @property
    def insertion_start(self) -> float | None:
        """When the step's first insertion began [s] (``None`` if it never did)."""
        return next((i.start for i in self.intervals if i.phase == INSERTION), None)

    @property
    def safe_hold(self) -> PhaseInterval | None:
        """The SAFE_HOLD that ended the step, if any."""
        return next((i for i in self.intervals if i.phase == SAFE_HOLD), None)

    @property
    def label(self) -> str:
        """Short label, e.g. ``step 1: n2_1 -> n1_2``."""
        return f'step {self.number}: {self.from_node or "?"} -> {self.to_node or "?"}'


def phase_intervals(phases: tuple[PhaseEvent, ...] | list[PhaseEvent],
                    end_time: float) -> list[PhaseInterval]:
    """Turn the phase messages into intervals; repeated messages of one phase are merged.

    Messages repeating a step's phase merge into one interval; so do consecutive IDLE
    messages, and SAFE_HOLD messages with the same reason, whatever their step fields say (the
    supervisor re-publishes them as the walk's bookkeeping ends: a rest or a hold is one
    interval). The first message's fields are kept.

    Parameters
    ----------
    phases : sequence of PhaseEvent
        The phase messages, in time order.
    end_time : float
        End of the last interval [s] (the bag's end).
    """
    intervals: list[PhaseInterval] = []
    key = None
    for event in phases:
        if event.phase == IDLE:
            this = (IDLE,)
        elif event.phase == SAFE_HOLD:
            this = (SAFE_HOLD, event.reason)
        else:
            this = (event.phase, event.step_index, event.step_count, event.from_node,
                    event.to_node, event.reason)
        if this == key:
            continue
        key = this
        if intervals:
            intervals[-1] = dataclasses.replace(intervals[-1], end=event.time)
        intervals.append(PhaseInterval(event.phase, event.time, max(event.time, end_time),
                                       event.step_index, event.step_count, event.from_node,
                                       event.to_node, event.reason))
    return intervals


def step_spans(intervals: list[PhaseInterval],
               reports: tuple[StepReportRecord, ...] | list[StepReportRecord] = ()
               ) -> list[StepSpan]:
    """Group the phase intervals into steps and attach each step's report.

    A step is a run of extraction, coarse, fine and insertion intervals of one
    ``(step_index, from_node, to_node)``; it ends at the next IDLE, at a SAFE_HOLD (which it
    includes) or where a different step's phases begin. Reports are matched to steps in order, by
    step index and target node.
    """
    groups: list[list[PhaseInterval]] = []
    open_key = None
    for interval in intervals:
        if interval.phase == IDLE:
            open_key = None
            continue
        if interval.phase == SAFE_HOLD:
            if open_key is not None:
                groups[-1].append(interval)
            open_key = None
            continue
        key = (interval.step_index, interval.from_node, interval.to_node)
        if key != open_key:
            groups.append([])
            open_key = key
        groups[-1].append(interval)
    spans = []
    unmatched = list(reports)
    for number, group in enumerate(groups, start=1):
        first = group[0]
        report = next((r for r in unmatched if int(r.message.step_index) == first.step_index
                       and r.message.to_node == first.to_node and r.time >= first.start), None)
        if report is not None:
            unmatched.remove(report)
        spans.append(StepSpan(number, first.step_index,
                              report.message.base_gripper if report is not None else '',
                              first.from_node, first.to_node, tuple(group), report))
    return spans


@dataclasses.dataclass(frozen=True)
class TargetVibration:
    """The tip near a step's target: its deviation from the mean over the settling window.

    The settling window is the ``settle_time`` before insertion starts: the joints have
    stopped above the hole and the links may still ring (the walker cannot see it; the plant's
    ``tip_pose`` can).

    Attributes
    ----------
    step : int
        The step's number (:attr:`StepSpan.number`).
    to_node : str
        The target node.
    insertion_start : float
        When insertion began [s].
    window : tuple of 2 float
        The settling window [s].
    time : ndarray (N,)
        Sample times relative to the insertion start [s], from up to ``lead`` before it.
    deviation : ndarray (N, 3)
        Tip position minus its mean over the settling window [m].
    amplitude : float
        Largest distance of a sample in the window from the mean [m] (NaN without samples).
    mean_position : ndarray (3,)
        The window's mean tip position [m].
    hole_offset : float
        Horizontal distance of that mean from the target hole's axis [m] (NaN if unknown).
    height : float
        Height of that mean above the hole mouth [m] (NaN if unknown).
    window_samples : int
        Samples in the window.
    """

    step: int
    to_node: str
    insertion_start: float
    window: tuple[float, float]
    time: np.ndarray
    deviation: np.ndarray
    amplitude: float
    mean_position: np.ndarray
    hole_offset: float
    height: float
    window_samples: int


def target_vibration(span: StepSpan, tip: PoseSeries, settle_time: float,
                     truss: Truss | None = None, lead: float | None = None
                     ) -> TargetVibration | None:
    """Measure the tip's vibration near a step's target (``None`` if insertion never began).

    Parameters
    ----------
    span : StepSpan
        The step.
    tip : PoseSeries
        The recorded ``tip_pose``.
    settle_time : float
        Length of the settling window [s] (``supervisor.settle_time``).
    truss : Truss, optional
        The truss, for the mean's offset from the hole.
    lead : float, optional
        How long before the insertion start to keep samples for the figure [s]
        (default three settling windows, at least 2 s); never before the step began.
    """
    if not settle_time > 0 or not math.isfinite(settle_time):
        raise ValueError(f'the settling window must be a positive time [s], got {settle_time}')
    start = span.insertion_start
    if start is None:
        return None
    lead = max(3.0 * settle_time, 2.0) if lead is None else lead
    window = (start - settle_time, start)
    in_window = (tip.time >= window[0]) & (tip.time <= window[1])
    shown = (tip.time >= max(span.start, start - lead)) & (tip.time <= start)
    if np.any(in_window):
        mean = tip.position[in_window].mean(axis=0)
        amplitude = float(np.max(np.linalg.norm(tip.position[in_window] - mean, axis=1)))
    else:
        mean, amplitude = np.full(3, math.nan), math.nan
    hole_offset = height = math.nan
    if truss is not None and np.all(np.isfinite(mean)):
        try:
            hole = truss.position(span.to_node)
        except UnknownNodeError:
            pass
        else:
            hole_offset = float(np.linalg.norm(mean[:2] - hole[:2]))
            height = float(mean[2] - hole[2])
    return TargetVibration(span.number, span.to_node, start, window, tip.time[shown] - start,
                           tip.position[shown] - mean, amplitude, mean, hole_offset, height,
                           int(np.count_nonzero(in_window)))


@dataclasses.dataclass(frozen=True)
class JointLimits:
    """Torque limits [N*m] of the physical joints and where they come from."""

    torque: dict[str, float]
    source: str


def joint_limits(robot_description: str, params) -> JointLimits:
    """Return the torque limits: the recorded URDF's ``<limit effort>``, else the parameters'.

    Parameters
    ----------
    robot_description : str
        The URDF recorded on ``robot_description`` (``''`` when none was).
    params : WalkerParameters
        The parameter file's robot section, for joints the URDF does not give.
    """
    from_params = {name: float(params.robot.drive.role_array('torque_limit')[i])
                   for i, name in enumerate(PHYSICAL_JOINT_NAMES)}
    if not robot_description:
        return JointLimits(from_params, 'the parameter file')
    try:
        root = ElementTree.fromstring(robot_description)
    except ElementTree.ParseError:
        return JointLimits(from_params, 'the parameter file (the recorded URDF is malformed)')
    limits = {}
    for joint in root.iter('joint'):
        limit = joint.find('limit')
        name = joint.get('name')
        if name in from_params and limit is not None and limit.get('effort') is not None:
            try:
                value = float(limit.get('effort'))
            except ValueError:
                continue
            if math.isfinite(value) and value > 0:
                limits[name] = value
    if set(limits) != set(from_params):
        return JointLimits({**from_params, **limits},
                           'the recorded robot_description and the parameter file')
    return JointLimits(limits, 'the recorded robot_description')


@dataclasses.dataclass(frozen=True)
class JointStats:
    """How one joint's controller did over the walk.

    Attributes
    ----------
    joint : str
        Physical joint name.
    torque_limit : float
        [N*m].
    peak_effort : float
        Largest commanded torque magnitude [N*m].
    saturated : int
        Samples clamped at the torque limit.
    stale : int
        Samples holding on a timed-out input.
    samples : int
        Controller states recorded.
    max_error : dict of str to float
        Largest position error magnitude [rad] in each phase (by phase name) the joint was
        recorded in.
    final_error : float
        Position error of the last sample [rad].
    """

    joint: str
    torque_limit: float
    peak_effort: float
    saturated: int
    stale: int
    samples: int
    max_error: dict[str, float]
    final_error: float

    @property
    def peak_fraction(self) -> float:
        """Peak torque as a fraction of the limit."""
        return self.peak_effort / self.torque_limit


def joint_stats(series: ControllerSeries, limit: float,
                intervals: list[PhaseInterval]) -> JointStats:
    """Summarise one controller's states against its torque limit [N*m], phase by phase."""
    max_error: dict[str, float] = {}
    magnitude = np.abs(series.position_error)
    for interval in intervals:
        inside = (series.time >= interval.start) & (series.time < interval.end)
        if np.any(inside):
            value = float(np.max(magnitude[inside]))
            max_error[interval.name] = max(max_error.get(interval.name, 0.0), value)
    return JointStats(
        series.joint, limit, float(np.max(np.abs(series.effort))) if len(series.effort) else 0.0,
        int(np.count_nonzero(series.saturated)), int(np.count_nonzero(series.stale)),
        len(series.time), max_error,
        float(series.position_error[-1]) if len(series.time) else math.nan)

