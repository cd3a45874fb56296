"""The walk animation: frames rendered headless from the recorded joint states, as a GIF.

Each frame poses the robot as recorded (the five joint angles of ``joint_states`` and the pose
of gripper ``a`` from ``gripper_a_pose``, the latest samples at or before the frame's time) in a
:class:`walker_sim.core.render.TrussScene` and draws it with pybullet's software renderer, so no
display is needed. The links are drawn straight: the bending of the flexible links is not
recorded. A caption gives the time, the step, the phase and the grippers' states.

Frames are taken every ``1 / fps`` s of the walk's time and played back in real time; a walk
longer than ``max_frames / fps`` is sampled more sparsely and played faster (the plan says by
how much). The GIF is written with Pillow with one palette for every frame (no dithering), so
the still truss compresses to almost nothing between frames. MP4 would need an encoder (ffmpeg)
that is not available here; GIF needs none.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import os
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from walker_core.gripper_state import GripperState
from walker_report.core.analysis import PhaseInterval, phase_name
from walker_report.core.walk_data import GripperEvent, WalkData

__all__ = ['AnimationOptions', 'FramePlan', 'AnimationResult', 'plan_frames', 'sample_states',
           'frame_captions', 'walk_camera', 'walk_nodes', 'project', 'render_animation']

#: Each ``walker_msgs/GripperState`` code's caption
_GRIPPER_STATES = {state.code: 'screwing in' if state == GripperState.SCREWING else str(state)
                   for state in GripperState}
#: Shortest frame delay GIF viewers honour [s]; GIF delays count hundredths of a second.
_MIN_DELAY = 0.02


@dataclasses.dataclass(frozen=True)
class AnimationOptions:
    """How the animation is made.

    Attributes
    ----------
    fps : float
        Frames per second of the walk's time [1/s] (and of playback when not sped up).
    max_frames : int
        Most frames; a longer walk is sampled more sparsely and played faster.
    width, height : int
        Frame size [px].
    """

    fps: float = 10.0
    max_frames: int = 600
    width: int = 640
    height: int = 400

    def __post_init__(self) -> None:
        if isinstance(self.fps, bool) or not isinstance(self.fps, (int, float)) \
                or not math.isfinite(self.fps) or not 0.1 <= self.fps <= 50.0:
            raise ValueError(f'the animation rate must be 0.1 to 50 frames per second of the '
                             f'walk, got {self.fps!r}')
        if isinstance(self.max_frames, bool) or not isinstance(self.max_frames, int) \
                or self.max_frames < 2:
            raise ValueError(f'max_frames must be an integer of at least 2, '
                             f'got {self.max_frames!r}')
        for name in ('width', 'height'):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or not 64 <= value <= 4096:
                raise ValueError(f'the frame {name} must be 64 to 4096 pixels, got {value!r}')


@dataclasses.dataclass(frozen=True)
class FramePlan:
    """When frames are taken and how they play.

    Attributes
    ----------
    times : ndarray (F,)
        Frame times [s].
    interval : float
        Walk time between frames [s].
    delay : float
        Playback time per frame [s] (a multiple of 0.01 s, as GIF stores it).
    """

    times: np.ndarray
    interval: float
    delay: float

    @property
    def speedup(self) -> float:
        """Walk time shown per second of playback."""
        return self.interval / self.delay


@dataclasses.dataclass(frozen=True)
class AnimationResult:
    """What :func:`render_animation` wrote.

    Attributes
    ----------
    path : Path
        The GIF.
    still : Path
        A PNG of the last frame at twice the frame size.
    plan : FramePlan
        The frames' times and playback.
    seconds : float
        Wall time it took [s].
    """

    path: Path
    still: Path
    plan: FramePlan
    seconds: float

    @property
    def frames(self) -> int:
        """Number of frames."""
        return len(self.plan.times)


def plan_frames(start: float, end: float, fps: float, max_frames: int) -> FramePlan:
    """Plan frames every ``1 / fps`` s from ``start`` to ``end`` [s], at most ``max_frames``.

    The last frame is at ``end`` or less than one interval before it. When more than
    ``max_frames`` frames would be needed, the interval grows to fit them and playback runs
    faster than real time (at ``fps`` frames per second).
    """
    if not (math.isfinite(start) and math.isfinite(end)) or end < start:
        raise ValueError(f'need a finite time span, got {start} to {end} s')
    interval = 1.0 / fps
    count = int(math.floor((end - start) * fps + 1e-9)) + 1
    if count > max_frames:
        interval = (end - start) / (max_frames - 1)
        count = max_frames
    delay = max(_MIN_DELAY, round(min(interval, 1.0 / fps), 2))
    return FramePlan(start + interval * np.arange(count), interval, delay)


def _latest(times: np.ndarray, at: np.ndarray) -> np.ndarray:
    """Index of the latest sample at or before each time (the first sample before them all)."""
    return np.clip(np.searchsorted(times, at, side='right') - 1, 0, len(times) - 1)


def sample_states(walk: WalkData, times: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return the recorded state at each frame time: the latest samples at or before it.

    Returns
    -------
    joints : ndarray (F, 5)
        Joint angles [rad], physical order.
    position : ndarray (F, 3)
        Gripper a's position [m].
    orientation : ndarray (F, 4)
        Gripper a's orientation (quaternion x, y, z, w).

    Raises
    ------
    ValueError
        If the walk has no joint states or no pose of gripper a.
    """
    pose = walk.gripper_poses['a']
    if not len(walk.joints.time):
        raise ValueError('the bag has no joint_states: nothing to animate')
    if not len(pose):
        raise ValueError('the bag has no gripper_a_pose: the robot cannot be placed on the '
                         'truss')
    joints = walk.joints.position[_latest(walk.joints.time, times)]
    at = _latest(pose.time, times)
    return joints, pose.position[at], pose.orientation[at]


def _gripper_text(event: GripperEvent | None) -> str:
    if event is None:
        return ''
    parts = []
    for name in sorted(event.states):
        state, node = event.states[name]
        where = f' {node}' if node else ''
        parts.append(f'{name}: {_GRIPPER_STATES.get(state, "?")}{where}')
    return 'grippers ' + ', '.join(parts)


def frame_captions(walk: WalkData, intervals: list[PhaseInterval], times: np.ndarray
                   ) -> list[tuple[str, str]]:
    """Two caption lines per frame: time, step and phase; the grippers' states."""
    captions = []
    starts = np.array([i.start for i in intervals])
    events = walk.gripper_events
    event_times = np.array([e.time for e in events])
    for t in times:
        line = f't = {t:6.2f} s'
        k = int(np.searchsorted(starts, t, side='right')) - 1 if len(starts) else -1
        if k >= 0:
            interval = intervals[k]
            if interval.from_node or interval.to_node:
                line += (f'   step {interval.step_index + 1}/{interval.step_count}  '
                         f'{interval.from_node} -> {interval.to_node}')
            line += f'   {phase_name(interval.phase)}'
            if interval.reason and interval.phase == 5:
                line += f': {interval.reason}'
        e = int(np.searchsorted(event_times, t, side='right')) - 1 if len(events) else -1
        captions.append((line, _gripper_text(events[e] if e >= 0 else None)))
    return captions


def walk_camera(walk: WalkData, truss):
    """Return a camera framing every place either gripper went, seen obliquely from above."""
    from walker_sim.core.render import Camera

    points = [p.position[:, :2] for p in walk.gripper_poses.values() if len(p)]
    if not points:
        return Camera.overview(truss)
    points = np.concatenate(points)
    low, high = points.min(axis=0), points.max(axis=0)
    centre = 0.5 * (low + high)
    size = float(np.hypot(*(high - low)))
    return Camera(target=(float(centre[0]), float(centre[1]), 0.15),
                  distance=max(1.8, 0.9 * size + 1.0), yaw=20.0, pitch=-35.0)


def project(camera, points: np.ndarray, width: int, height: int) -> np.ndarray:
    """Pixel coordinates (N, 2) of points (N, 3) [m] in a frame drawn with ``camera``.

    Uses the view and projection of :meth:`walker_sim.core.render.TrussScene.render`.
    """
    import pybullet

    view = np.reshape(pybullet.computeViewMatrixFromYawPitchRoll(
        list(camera.target), camera.distance, camera.yaw, camera.pitch, 0.0, 2), (4, 4)).T
    projection = np.reshape(pybullet.computeProjectionMatrixFOV(
        camera.fov, width / height, 0.02, 50.0), (4, 4)).T
    points = np.atleast_2d(np.asarray(points, dtype=float))
    clip = (projection @ view @ np.c_[points, np.ones(len(points))].T).T
    ndc = clip[:, :2] / clip[:, 3:4]
    return np.c_[(ndc[:, 0] + 1.0) * 0.5 * width, (1.0 - ndc[:, 1]) * 0.5 * height]


def walk_nodes(walk: WalkData, intervals: list[PhaseInterval]) -> list[str]:
    """Return the truss nodes the walk involves: where the grippers stood and every target."""
    nodes = []
    for event in walk.gripper_events[:1]:
        nodes += [node for _, node in event.states.values() if node]
    for interval in intervals:
        nodes += [n for n in (interval.from_node, interval.to_node) if n]
    return list(dict.fromkeys(nodes))


def _label_nodes(image: Image.Image, labels: list[tuple[str, np.ndarray]], font) -> None:
    draw = ImageDraw.Draw(image)
    for name, (x, y) in labels:
        if 0 <= x < image.width and 0 <= y < image.height:
            draw.text((x + 9, y + 4), name, font=font, fill=(150, 200, 255))


@contextlib.contextmanager
def _stderr_silenced() -> Iterator[None]:
    """Silence the C-level banner pybullet prints on stderr when it is first imported."""
    saved = os.dup(2)
    try:
        with open(os.devnull, 'wb') as null:
            os.dup2(null.fileno(), 2)
            yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def _caption(image: Image.Image, lines: tuple[str, str], font) -> None:
    draw = ImageDraw.Draw(image)
    text = '\n'.join(line for line in lines if line)
    box = draw.multiline_textbbox((8, 6), text, font=font, spacing=3)
    draw.rectangle((box[0] - 5, box[1] - 4, box[2] + 5, box[3] + 4), fill=(20, 20, 28))
    draw.multiline_text((8, 6), text, font=font, fill=(240, 240, 240), spacing=3)


def render_animation(path: Path, walk: WalkData, params, intervals: list[PhaseInterval],
                     options: AnimationOptions = AnimationOptions(),
                     progress: Callable[[int, int], None] | None = None) -> AnimationResult:
    """Render the walk as a GIF (and its last frame as a PNG beside it).

    Parameters
    ----------
    path : Path
        The GIF to write; the still is ``<stem>_final.png`` beside it.
    walk : WalkData
        The recorded walk (joint states and gripper a's pose are needed).
    params : WalkerParameters
        The robot and truss drawn.
    intervals : list of PhaseInterval
        The phases, for the captions.
    options : AnimationOptions
        Rate, frame limit and size.
    progress : callable, optional
        Called as ``progress(frames_done, frames)``.

    Raises
    ------
    ValueError
        If the walk lacks what the animation needs.
    """
    started = time.monotonic()
    with _stderr_silenced():
        from walker_sim.core.render import TrussScene
    plan = plan_frames(float(walk.joints.time[0]) if len(walk.joints.time) else 0.0,
                       float(walk.joints.time[-1]) if len(walk.joints.time) else 0.0,
                       options.fps, options.max_frames)
    joints, positions, orientations = sample_states(walk, plan.times)
    captions = frame_captions(walk, intervals, plan.times)
    font = ImageFont.load_default(size=max(10, options.height // 28))
    frames: list[Image.Image] = []
    palette = None
    path = Path(path)
    still = path.with_name(f'{path.stem}_final.png')
    with TrussScene(params) as scene:
        camera = walk_camera(walk, scene.truss)
        nodes = [n for n in walk_nodes(walk, intervals) if n in scene.truss.node_names]
        points = np.array([scene.truss.position(n) for n in nodes]).reshape(-1, 3)
        labels = list(zip(nodes, project(camera, points, options.width, options.height),
                          strict=True))
        big_labels = list(zip(nodes, project(camera, points, 2 * options.width,
                                             2 * options.height), strict=True))
        for k in range(len(plan.times)):
            scene.pose_robot(joints[k], positions[k], orientations[k])
            image = Image.fromarray(scene.render(camera, options.width, options.height,
                                                 shadow=False))
            _label_nodes(image, labels, font)
            _caption(image, captions[k], font)
            if palette is None:
                palette = image.quantize(colors=255, method=Image.Quantize.MEDIANCUT)
            frames.append(image.quantize(palette=palette, dither=Image.Dither.NONE))
            if progress is not None:
                progress(k + 1, len(plan.times))
        final = Image.fromarray(scene.render(camera, 2 * options.width, 2 * options.height))
        big_font = ImageFont.load_default(size=2 * font.size)
        _label_nodes(final, big_labels, big_font)
        _caption(final, captions[-1], big_font)
        final.save(still)
    frames[0].save(path, save_all=True, append_images=frames[1:],
                   duration=int(round(plan.delay * 1000)), loop=0, optimize=False,
                   disposal=1)
    return AnimationResult(path, still, plan, time.monotonic() - started)
