"""The wrist camera's last frame before each screw-in, read from a walk's bag.

With cameras on, a walk's bag holds each frame of the supervisor's looks
(``camera_<g>/image_raw``), the plant's truth of each (``camera_<g>/true_hole``) and the hole
the supervisor measured in it (``camera_<g>/hole``, only for a frame that showed it), the two
``geometry_msgs/PointStamped`` in the gripper's frame with the image's stamp. A step looks
before it descends; the frame the report shows for a step is the last of the moving gripper's
frames exposed between the step's start and its last insertion (the descent that screwed in, or
the last one tried): the last frame of the look the descent went for. A bag without camera
frames gives none, and the report then says nothing of cameras.

Times are in s from the bag's start, lengths in m, points in the gripper's frame (z along its
axis away from the truss: a face below the gripper is at negative z).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np

from walker_bag.core.bag_reader import BagReader
from walker_bag.core.errors import BagError
from walker_core.camera import HOLE, IMAGE, TRUE_HOLE, camera_topic
from walker_core.joint_roles import GRIPPERS, other_gripper
from walker_report.core.analysis import INSERTION, StepSpan
from walker_report.core.errors import ReportError
from walker_report.core.walk_data import WalkData

__all__ = ['ScrewInFrame', 'screw_in_frames', 'image_array', 'STAMP_TOLERANCE']

#: [ns] A point belongs to an image whose stamp is this close (both are the frame's exposure).
STAMP_TOLERANCE = 1000
_RGB8 = 'rgb8'


@dataclasses.dataclass(frozen=True)
class ScrewInFrame:
    """The last camera frame before a step's screw-in, with its measurement and its truth.

    Attributes
    ----------
    step : int
        The step's number in the report (:class:`~walker_report.core.analysis.StepSpan`).
    to_node : str
        The node the step screwed into (or tried to).
    gripper : str
        Whose camera.
    time : float
        [s] The frame's exposure, from the bag's start.
    stamp_ns : int
        [ns] Its image's header stamp (the walk's clock).
    image : ndarray, shape (height, width, 3), uint8
        RGB, row 0 at the top.
    measured : ndarray, shape (3,), or None
        [m] The hole the supervisor measured in this frame, in the gripper's frame; None when
        the frame did not show it.
    true : ndarray, shape (3,), or None
        [m] Where the hole really was (the simulation's truth); None when not recorded.
    camera_centre : ndarray, shape (3,), or None
        [m] The camera's centre in the gripper's frame (the nominal mount), through which
        :attr:`seen` carries the measurement to the true face.
    """

    step: int
    to_node: str
    gripper: str
    time: float
    stamp_ns: int
    image: np.ndarray
    measured: np.ndarray | None
    true: np.ndarray | None
    camera_centre: np.ndarray | None = None

    @property
    def seen(self) -> np.ndarray | None:
        """[m] The measured hole on its line of sight at the true face's height.

        A frame measures a line of sight; the supervisor places it at the face's height the
        step assumed (:attr:`measured`), which the truss as built may not have: carried along
        the line to the true height it is what the image said, comparable with :attr:`true`.
        None without the measurement, the truth or the camera's centre.
        """
        if self.measured is None or self.true is None or self.camera_centre is None:
            return None
        sight = self.measured - self.camera_centre
        if abs(sight[2]) < 1e-9:
            return None
        return self.camera_centre + sight * (self.true[2] - self.camera_centre[2]) / sight[2]

    @property
    def error(self) -> float:
        """[m] Horizontal distance of what the frame saw from the true hole (nan: lacking).

        Taken at the true face's height (:attr:`seen`) when the camera's centre is known, else
        at the heights as they are.
        """
        if self.measured is None or self.true is None:
            return math.nan
        seen = self.seen if self.seen is not None else self.measured
        return float(math.hypot(*(seen[:2] - self.true[:2])))

    def numbers(self) -> dict:
        """Return the frame's numbers for ``report.json`` (points [m], None when lacking)."""
        def point(value):
            return None if value is None else [float(v) for v in value]

        return {'step': self.step, 'to_node': self.to_node, 'gripper': self.gripper,
                'time': self.time, 'stamp': self.stamp_ns * 1e-9,
                'measured': point(self.measured), 'seen': point(self.seen),
                'true': point(self.true),
                'error': None if math.isnan(self.error) else self.error}


def image_array(message) -> np.ndarray:
    """Return an ``rgb8`` ``sensor_msgs/Image`` (a decoded one) as (height, width, 3) uint8.

    Raises
    ------
    ValueError
        If the encoding is not ``rgb8`` or the data does not fill the image's rows.
    """
    if message.encoding != _RGB8:
        raise ValueError(f'image encoding {message.encoding!r} is not {_RGB8!r}')
    height, width, step = int(message.height), int(message.width), int(message.step)
    data = np.asarray(message.data, dtype=np.uint8).reshape(-1)
    if step < 3 * width or data.size < height * step:
        raise ValueError(f'image of {data.size} bytes is not {height} rows of {step} bytes '
                         f'for {width} rgb8 pixels')
    return data[:height * step].reshape(height, step)[:, :3 * width].reshape(height, width, 3)


def _descent(span: StepSpan) -> float | None:
    """[s] When the step's last insertion began (None: it never descended)."""
    return max((i.start for i in span.intervals if i.phase == INSERTION), default=None)


def _stamp_ns(message) -> int:
    return int(message.header.stamp.sec) * 1_000_000_000 + int(message.header.stamp.nanosec)


def _point_at(points: dict[int, np.ndarray], stamp: int) -> np.ndarray | None:
    near = min(points, key=lambda s: abs(s - stamp), default=None)
    return None if near is None or abs(near - stamp) > STAMP_TOLERANCE else points[near]


def screw_in_frames(walk: WalkData, spans: list[StepSpan],
                    progress: Callable[[int, int], None] | None = None,
                    camera_centre: np.ndarray | None = None) -> list[ScrewInFrame]:
    """Read the last camera frame before each step's screw-in from the walk's bag.

    Parameters
    ----------
    walk : WalkData
        The walk (its bag, namespace and start).
    spans : list of StepSpan
        The steps; one frame for each that descended after its gripper's camera took one.
    progress : callable, optional
        ``progress(messages_read, messages_to_read)``.
    camera_centre : ndarray, shape (3,), optional
        [m] The camera's centre in the gripper's frame (:attr:`ScrewInFrame.camera_centre`).

    Returns
    -------
    list of ScrewInFrame
        In step order; empty when the bag holds no camera frame.

    Raises
    ------
    ReportError
        If the bag cannot be read again, or a frame is not an ``rgb8`` image.
    """
    names = {(g, kind): f'{walk.namespace.rstrip("/")}/{camera_topic(g, kind)}'
             for g in GRIPPERS for kind in (IMAGE, TRUE_HOLE, HOLE)}
    present = {key: name for key, name in names.items() if walk.bag.topics.get(name, ('', 0))[1]}
    if not any(kind == IMAGE for _, kind in present):
        return []
    windows = []  # (span, grippers, start [ns], descent [ns])
    for span in spans:
        descent = _descent(span)
        if descent is None:
            continue
        grippers = (other_gripper(span.base_gripper),) if span.base_gripper else GRIPPERS
        windows.append((span, grippers, walk.bag.start_ns + round(span.start * 1e9),
                        walk.bag.start_ns + round(descent * 1e9)))
    chosen: dict[int, tuple[int, str, object]] = {}  # span number -> (stamp, gripper, message)
    points = {key: {} for key in present if key[1] != IMAGE}
    by_name = {name: key for key, name in present.items()}
    total = sum(walk.bag.topics[name][1] for name in present.values())
    try:
        with BagReader(walk.bag.path) as reader:
            for done, record in enumerate(reader.messages(list(present.values())), start=1):
                if progress is not None:
                    progress(done, total)
                gripper, kind = by_name[record.topic]
                stamp = _stamp_ns(record.message)
                if kind != IMAGE:
                    p = record.message.point
                    points[gripper, kind][stamp] = np.array([p.x, p.y, p.z], dtype=float)
                    continue
                for span, grippers, start, descent in windows:
                    best = chosen.get(span.number)
                    if gripper in grippers and start <= stamp < descent \
                            and (best is None or stamp >= best[0]):
                        chosen[span.number] = (stamp, gripper, record.message)
    except BagError as error:
        raise ReportError(f'the camera frames of {walk.bag.path}: {error}') from None
    frames = []
    for span, _, _, _ in windows:
        if span.number not in chosen:
            continue
        stamp, gripper, message = chosen[span.number]
        try:
            image = image_array(message)
        except ValueError as error:
            raise ReportError(f'the frame of camera {gripper} for {span.label}: {error}') \
                from None
        frames.append(ScrewInFrame(
            span.number, span.to_node, gripper, (stamp - walk.bag.start_ns) / 1e9, stamp,
            image, _point_at(points.get((gripper, HOLE), {}), stamp),
            _point_at(points.get((gripper, TRUE_HOLE), {}), stamp),
            None if camera_centre is None else np.asarray(camera_centre, dtype=float)))
    return frames
