"""A recorded walk read into arrays: joint states, poses, controller states, phases, reports.

The bag is read once, through :mod:`walker_bag.core.bag_reader` (rosbags, decoding every
message from the definitions stored in the bag, the custom ``walker_msgs`` types included).

Times are in seconds from the bag's start (the log time of its first message). A message's time
is its header stamp when it has a non-zero one (the publisher's time of the sample: the plant's
physics time for states and poses, the supervisor's clock for phases), else its log time, which
in a sim-time bag is quantised to the ``/clock`` period. Positions are in m, angles in rad,
torques in N*m, quaternions ``(x, y, z, w)``; per-joint arrays are in the physical joint order
of :data:`walker_core.joint_roles.PHYSICAL_JOINT_NAMES`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np

from walker_bag.core.bag_metadata import read_metadata
from walker_bag.core.losses import recorded_losses
from walker_bag.core.bag_reader import BagReader
from walker_bag.core.errors import BagError, MetadataError
from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_report.core.errors import BagCutShortError, ReportError

__all__ = [
    'BagSummary', 'JointSeries', 'PoseSeries', 'ControllerSeries', 'PhaseEvent',
    'GripperEvent', 'ModeEvent', 'StepReportRecord', 'WalkData', 'TOPICS', 'load_walk',
    'resolve_bag_dir',
]

#: The topics the report reads, relative to the robot's namespace, and what is lost without
#: each. ``controllers/*/state`` stands for the five controllers' states.
TOPICS = {
    'joint_states': 'no animation',
    'tip_pose': 'no tip path and no vibration near the targets',
    'gripper_a_pose': 'no animation (the robot cannot be placed on the truss)',
    'gripper_b_pose': 'gripper b is not marked at the start',
    'gripper_states': "no grippers' states in the timeline and the animation",
    'phase': 'no phase timeline, no steps, no vibration near the targets',
    'step_reports': 'no per-step table',
    'control_mode': "no controllers' modes in the timeline",
    'controllers/*/state': 'no joint errors and torques',
    'robot_description': 'torque limits from the parameter file',
}

_MCAP_MAGIC = b'\x89MCAP0\r\n'
_NS_PER_S = 1e9


@dataclasses.dataclass(frozen=True)
class BagSummary:
    """What the bag holds.

    Attributes
    ----------
    path : Path
        The bag directory.
    start_ns : int
        Log time of the first message [ns]; report times count from it.
    duration : float
        From the first to the last message [s].
    message_count : int
        Messages in the bag.
    topics : dict of str to (str, int)
        Type and message count of every topic.
    clock : str
        ``custom_data.clock`` of the metadata (``sim_time`` or ``wall``; ``''`` if unknown).
    size_bytes : int
        Size of the bag's files [bytes].
    losses : dict
        What the bag says it lacks (:func:`walker_bag.core.losses.recorded_losses`): messages
        lost on the way to the recorder, spans a recorder started again did not record.
    """

    path: Path
    start_ns: int
    duration: float
    message_count: int
    topics: dict[str, tuple[str, int]]
    clock: str
    size_bytes: int
    losses: dict = dataclasses.field(default_factory=lambda: recorded_losses({}))


@dataclasses.dataclass(frozen=True)
class JointSeries:
    """``sensor_msgs/JointState`` samples, in the physical joint order.

    Attributes
    ----------
    time : ndarray (N,)
        [s].
    position, velocity, effort : ndarray (N, 5)
        [rad], [rad/s], [N*m] (the applied torque; NaN when not published).
    """

    time: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    effort: np.ndarray

    @classmethod
    def empty(cls) -> 'JointSeries':
        """Return a series without samples."""
        return cls(np.zeros(0), np.zeros((0, 5)), np.zeros((0, 5)), np.zeros((0, 5)))


@dataclasses.dataclass(frozen=True)
class PoseSeries:
    """``geometry_msgs/PoseStamped`` samples in the truss frame.

    Attributes
    ----------
    time : ndarray (N,)
        [s].
    position : ndarray (N, 3)
        [m].
    orientation : ndarray (N, 4)
        Quaternions ``(x, y, z, w)``.
    """

    time: np.ndarray
    position: np.ndarray
    orientation: np.ndarray

    @classmethod
    def empty(cls) -> 'PoseSeries':
        """Return a series without samples."""
        return cls(np.zeros(0), np.zeros((0, 3)), np.zeros((0, 4)))

    def __len__(self) -> int:
        return len(self.time)


@dataclasses.dataclass(frozen=True)
class ControllerSeries:
    """``walker_msgs/ControllerState`` samples of one joint's controller.

    Attributes
    ----------
    joint : str
        Physical joint name.
    time : ndarray (N,)
        [s].
    mode, role : ndarray (N,) of int
        ControllerState mode constant; joint role 1..5.
    position_setpoint, position, position_error : ndarray (N,)
        [rad]; the error is setpoint minus measured.
    effort : ndarray (N,)
        The command sent to the joint [N*m].
    saturated, stale : ndarray (N,) of bool
        Clamped at the torque limit; holding on a timed-out input.
    """

    joint: str
    time: np.ndarray
    mode: np.ndarray
    role: np.ndarray
    position_setpoint: np.ndarray
    position: np.ndarray
    position_error: np.ndarray
    effort: np.ndarray
    saturated: np.ndarray
    stale: np.ndarray


@dataclasses.dataclass(frozen=True)
class PhaseEvent:
    """A ``walker_msgs/StepPhase`` message: the phase entered at ``time`` [s]."""

    time: float
    phase: int
    base_gripper: str
    step_index: int
    step_count: int
    from_node: str
    to_node: str
    reason: str


@dataclasses.dataclass(frozen=True)
class GripperEvent:
    """A change of the grippers' states at ``time`` [s].

    ``states`` maps each gripper name to its ``walker_msgs/GripperState`` constant and node.
    """

    time: float
    states: dict[str, tuple[int, str]]


@dataclasses.dataclass(frozen=True)
class ModeEvent:
    """A ``walker_msgs/ControlMode`` message: the controllers' mode from ``time`` [s]."""

    time: float
    mode: int
    base_gripper: str


@dataclasses.dataclass(frozen=True)
class StepReportRecord:
    """A ``walker_msgs/StepReport`` published at ``time`` [s] (``message``: the decoded one)."""

    time: float
    message: object


@dataclasses.dataclass(frozen=True)
class WalkData:
    """Everything the report uses from one bag.

    Attributes
    ----------
    bag : BagSummary
        The bag's topics, counts and span.
    namespace : str
        The robot's namespace the topics were read under, e.g. ``/walker``.
    joints : JointSeries
        The joint states.
    tip : PoseSeries
        The moving gripper's (tip's) pose.
    gripper_poses : dict of str to PoseSeries
        The pose of gripper ``a`` and of gripper ``b``.
    controllers : dict of str to ControllerSeries
        The controller states, by physical joint name (joints without states left out).
    phases, gripper_events, modes : tuple
        The phase messages, the changes of the gripper states, the control modes, in time
        order.
    step_reports : tuple of StepReportRecord
        The step reports, in time order.
    robot_description : str
        The URDF published on ``robot_description`` (``''`` if not recorded).
    missing : tuple of str
        The topics the report uses that the bag does not hold (relative names as in
        :data:`TOPICS`).
    """

    bag: BagSummary
    namespace: str
    joints: JointSeries
    tip: PoseSeries
    gripper_poses: dict[str, PoseSeries]
    controllers: dict[str, ControllerSeries]
    phases: tuple[PhaseEvent, ...]
    gripper_events: tuple[GripperEvent, ...]
    modes: tuple[ModeEvent, ...]
    step_reports: tuple[StepReportRecord, ...]
    robot_description: str
    missing: tuple[str, ...]

    @property
    def end_time(self) -> float:
        """Time of the bag's last message [s]."""
        return self.bag.duration


def resolve_bag_dir(path: str | Path) -> Path:
    """Return the bag directory of ``path`` (a bag directory, or the MCAP file inside one).

    Raises
    ------
    ReportError
        If it is neither.
    BagCutShortError
        If a storage file of the bag has no MCAP footer (the recording was cut short): the
        message says how to recover it.
    """
    path = Path(path)
    if path.is_file() and path.suffix == '.mcap':
        path = path.parent
    if not path.is_dir():
        raise ReportError(f'{path} is not a bag directory (a rosbag2 bag: a directory holding '
                          f'metadata.yaml and an .mcap file)')
    try:
        files = [path / f for f in read_metadata(path).relative_file_paths]
    except MetadataError:
        files = sorted(path.glob('*.mcap'))
    for file in files:
        if file.is_file() and not _has_footer(file):
            raise BagCutShortError(
                f'the bag {path} was cut short: {file.name} ends without its MCAP footer (its '
                f'recorder was killed before closing it). Recover a complete copy with '
                f'`bag_info {path} --recover` and make the report from {path}_recovered')
    return path


def _has_footer(file: Path) -> bool:
    size = file.stat().st_size
    if size < 2 * len(_MCAP_MAGIC):
        return False
    with open(file, 'rb') as stream:
        stream.seek(size - len(_MCAP_MAGIC))
        return stream.read() == _MCAP_MAGIC


def _detect_namespace(topics: dict[str, str]) -> str:
    for name in ('joint_states', 'phase', 'tip_pose', 'step_reports'):
        candidates = sorted(t[:-len(name) - 1] for t in topics if t.endswith('/' + name))
        if candidates:
            return candidates[0] or '/'
    return '/walker'


def _absolute(namespace: str, name: str) -> str:
    return name if name.startswith('/') else f'{namespace.rstrip("/")}/{name}'


class _Clock:
    """Message times [s] from the bag's start: the header stamp if non-zero, else log time."""

    def __init__(self, origin_ns: int) -> None:
        self.origin_ns = origin_ns

    def __call__(self, message, log_time_ns: int) -> float:
        header = getattr(message, 'header', None)
        stamp_ns = 0
        if header is not None:
            stamp_ns = int(header.stamp.sec) * 1_000_000_000 + int(header.stamp.nanosec)
        return ((stamp_ns or log_time_ns) - self.origin_ns) / _NS_PER_S


def _pose_series(samples: list) -> PoseSeries:
    if not samples:
        return PoseSeries.empty()
    samples.sort(key=lambda s: s[0])
    return PoseSeries(np.array([s[0] for s in samples]), np.array([s[1] for s in samples]),
                      np.array([s[2] for s in samples]))


def _ordered(names, values, order: list[int] | None) -> np.ndarray:
    values = np.asarray(values, dtype=float)
    if order is None or len(values) != len(names):
        return np.full(5, math.nan)
    return values[order]


def load_walk(bag_dir: str | Path, namespace: str | None = None,
              progress: Callable[[int, int], None] | None = None) -> WalkData:
    """Read what the report uses from a bag.

    Parameters
    ----------
    bag_dir : str or Path
        The bag directory (or its MCAP file).
    namespace : str, optional
        The robot's namespace; found from the topics when omitted (``/walker`` by default).
    progress : callable, optional
        Called as ``progress(messages_read, messages_to_read)`` while reading.

    Raises
    ------
    ReportError
        If the path is not a readable bag (:class:`BagCutShortError` when it was cut short).
    """
    path = resolve_bag_dir(bag_dir)
    try:
        reader = BagReader(path)
    except BagError as error:
        raise ReportError(str(error)) from None
    with reader:
        topic_types = reader.topics
        counts = reader.message_counts
        namespace = _detect_namespace(topic_types) if namespace is None else namespace
        if not namespace.startswith('/'):
            raise ReportError(f'the namespace must be absolute (start with /), got {namespace!r}')
        try:
            custom_data = dict(read_metadata(path).custom_data)
        except MetadataError:
            custom_data = {}
        clock_kind = custom_data.get('clock', '')
        start_ns = reader.start_time_ns if reader.message_count else 0
        end_ns = reader.end_time_ns - 1 if reader.message_count else 0
        summary = BagSummary(
            path=path, start_ns=start_ns, duration=max(0.0, (end_ns - start_ns) / _NS_PER_S),
            message_count=reader.message_count,
            topics={t: (topic_types[t], counts.get(t, 0)) for t in sorted(topic_types)},
            clock=clock_kind, size_bytes=sum(f.stat().st_size for f in path.iterdir()
                                             if f.is_file()),
            losses=recorded_losses(custom_data))
        names = {rel: _absolute(namespace, rel) for rel in TOPICS if '*' not in rel}
        controller_topics = {
            _absolute(namespace, f'controllers/{joint}/state'): joint
            for joint in PHYSICAL_JOINT_NAMES}
        wanted = [t for t in (*names.values(), *controller_topics) if t in topic_types]
        missing = [rel for rel, name in names.items() if name not in topic_types]
        if not any(t in topic_types for t in controller_topics):
            missing.append('controllers/*/state')
        total = sum(counts.get(t, 0) for t in wanted)
        by_topic = {name: rel for rel, name in names.items()}
        return _read(reader, wanted, by_topic, controller_topics, summary, namespace,
                     tuple(sorted(missing, key=list(TOPICS).index)), total, progress)


def _read(reader: BagReader, wanted, by_topic, controller_topics, summary, namespace,
          missing, total, progress) -> WalkData:
    clock = _Clock(summary.start_ns)
    joints: list = []
    poses: dict[str, list] = {'tip_pose': [], 'gripper_a_pose': [], 'gripper_b_pose': []}
    controllers: dict[str, list] = {}
    phases, gripper_events, modes, reports = [], [], [], []
    description = ''
    order_cache: dict[tuple, list[int] | None] = {}
    done = 0
    step = max(1, total // 100)
    for record in (reader.messages(wanted) if wanted else ()):
        done += 1
        if progress is not None and (done % step == 0 or done == total):
            progress(done, total)
        msg = record.message
        t = clock(msg, record.log_time_ns)
        joint = controller_topics.get(record.topic)
        if joint is not None:
            controllers.setdefault(joint, []).append((
                t, msg.mode, msg.role, msg.position_setpoint, msg.position, msg.position_error,
                msg.effort, msg.saturated, msg.stale))
            continue
        kind = by_topic.get(record.topic)
        if kind == 'joint_states':
            key = tuple(msg.name)
            if key not in order_cache:
                order_cache[key] = ([key.index(j) for j in PHYSICAL_JOINT_NAMES]
                                    if set(PHYSICAL_JOINT_NAMES) <= set(key) else None)
            order = order_cache[key]
            if order is None:
                continue
            joints.append((t, _ordered(key, msg.position, order),
                           _ordered(key, msg.velocity, order), _ordered(key, msg.effort, order)))
        elif kind in poses:
            p, q = msg.pose.position, msg.pose.orientation
            poses[kind].append((t, (p.x, p.y, p.z), (q.x, q.y, q.z, q.w)))
        elif kind == 'phase':
            phases.append(PhaseEvent(t, int(msg.phase), msg.base_gripper, int(msg.step_index),
                                     int(msg.step_count), msg.from_node, msg.to_node,
                                     msg.reason))
        elif kind == 'gripper_states':
            states = {g.name: (int(g.state), g.node) for g in msg.grippers}
            last = gripper_events[-1] if gripper_events else None
            if last is None or last.states != states:
                gripper_events.append(GripperEvent(t, states))
        elif kind == 'control_mode':
            modes.append(ModeEvent(t, int(msg.mode), msg.base_gripper))
        elif kind == 'step_reports':
            reports.append(StepReportRecord(t, msg))
        elif kind == 'robot_description':
            description = msg.data
    joint_series = JointSeries.empty()
    if joints:
        joints.sort(key=lambda s: s[0])
        joint_series = JointSeries(*(np.array([s[i] for s in joints]) for i in range(4)))
    controller_series = {}
    for joint in PHYSICAL_JOINT_NAMES:
        samples = sorted(controllers.get(joint, ()), key=lambda s: s[0])
        if samples:
            columns = list(zip(*samples, strict=True))
            controller_series[joint] = ControllerSeries(
                joint, np.array(columns[0]), np.array(columns[1], dtype=int),
                np.array(columns[2], dtype=int), *(np.array(c, dtype=float) for c in columns[3:7]),
                np.array(columns[7], dtype=bool), np.array(columns[8], dtype=bool))
    return WalkData(
        bag=summary, namespace=namespace, joints=joint_series,
        tip=_pose_series(poses['tip_pose']),
        gripper_poses={'a': _pose_series(poses['gripper_a_pose']),
                       'b': _pose_series(poses['gripper_b_pose'])},
        controllers=controller_series,
        phases=tuple(sorted(phases, key=lambda e: e.time)),
        gripper_events=tuple(gripper_events), modes=tuple(sorted(modes, key=lambda e: e.time)),
        step_reports=tuple(sorted(reports, key=lambda r: r.time)),
        robot_description=description, missing=missing)
