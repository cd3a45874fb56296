"""A screw-in's camera frame with the detection drawn, and its caption (matplotlib's Agg canvas).

The frame is drawn as the camera took it (row 0 at the top, pixel centres at whole numbers, as
:class:`~walker_core.camera.CameraModel` projects). Over it, through the nominal camera model
(the one the supervisor measures with):

* the hole as the supervisor measured it in this frame: the outline of the mouth's disc
  (radius ``mouth_radius``) at the measured point of the face, and its centre;
* the true hole (the simulation's truth), dashed over it;
* the gripper's axis from its contact point down to the face, and where it meets the face (the
  point the hole's offset is measured from).

The caption gives the measured and the true offset of the hole's axis from the gripper's axis
(x, y in the gripper's frame) [mm] and their distance.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from walker_core.camera import CameraModel
from walker_report.core.figures import DPI
from walker_report.core.screw_in_frames import ScrewInFrame

__all__ = ['screw_in_figure', 'caption', 'title']

_MEASURED_COLOR = '#39ff14'
_TRUE_COLOR = '#ff2bd6'
_AXIS_COLOR = '#ffd92f'
_OUTLINE_POINTS = 72
_AXIS_BEYOND = 0.005  # [m] the axis drawn this far below the face
_ZOOM = 30.0  # [px] the enlarged view's half width around the hole


def _mm(point: np.ndarray) -> str:
    return f'({point[0] * 1e3:+.2f}, {point[1] * 1e3:+.2f}) mm'


def caption(frame: ScrewInFrame) -> str:
    """Return the caption: the measured and true offsets of the hole from the gripper's axis."""
    true = 'true offset not recorded' if frame.true is None else f'true {_mm(frame.true)}'
    if frame.measured is None:
        return f'hole not seen in this frame; {true}'
    text = f'measured offset (x, y) {_mm(frame.measured)} at the height assumed'
    if frame.seen is not None:
        text += f', {_mm(frame.seen)} at the true face'
    text = f'{text}; {true}'
    return text if frame.true is None else f'{text}: {frame.error * 1e3:.2f} mm apart'


def title(frame: ScrewInFrame) -> str:
    """Return the figure's title: the step, its node, the camera and the frame's instant."""
    return (f'step {frame.step} -> {frame.to_node}: camera {frame.gripper}, the last frame '
            f'before the screw-in ({frame.time:.2f} s)')


def _outline(model: CameraModel, centre: np.ndarray, radius: float) -> np.ndarray:
    angle = np.linspace(0.0, 2.0 * math.pi, _OUTLINE_POINTS)
    circle = np.column_stack([np.cos(angle), np.sin(angle), np.zeros_like(angle)])
    return model.project(centre + radius * circle)


def screw_in_figure(path: Path, frame: ScrewInFrame, model: CameraModel,
                    mouth_radius: float) -> Path:
    """Draw a screw-in's frame with the detection, the truth and the gripper's axis; save PNG.

    Left the whole frame, right the hole enlarged (:data:`_ZOOM` pixels each way).

    Parameters
    ----------
    path : Path
        The PNG to write.
    frame : ScrewInFrame
    model : CameraModel
        The nominal camera (``gripper.camera.*``).
    mouth_radius : float
        [m] The hole's mouth radius (``gripper.insertion_position_tolerance``).
    """
    rows, columns, _ = frame.image.shape
    figure = Figure(figsize=(12.0, 6.0 * rows / columns + 1.2))
    whole, near = figure.subplots(1, 2)
    drawn = (rows, columns) == (model.height, model.width)
    for ax in (whole, near):
        ax.imshow(frame.image, interpolation='nearest')
        if drawn:
            _overlay(ax, frame, model, mouth_radius)
        ax.set_xlim(-0.5, columns - 0.5)
        ax.set_ylim(rows - 0.5, -0.5)
        ax.set_xlabel('u [px]')
        ax.set_ylabel('v [px]')
    whole.legend(loc='upper right', fontsize=8, framealpha=0.8)
    whole.set_title('the frame', fontsize=10)
    hole = frame.measured if frame.measured is not None else frame.true
    centre = model.project(hole)[0] if drawn and hole is not None else None
    if centre is not None and np.all(np.isfinite(centre)):
        near.set_xlim(centre[0] - _ZOOM, centre[0] + _ZOOM)
        near.set_ylim(centre[1] + _ZOOM, centre[1] - _ZOOM)
        near.set_title('the hole, enlarged', fontsize=10)
    else:
        near.set_visible(False)
    figure.suptitle(title(frame), fontsize=11)
    note = caption(frame) if drawn else \
        f"{caption(frame)} (the image is not the camera model's size: nothing drawn over it)"
    figure.text(0.5, 0.015, note, ha='center', va='bottom', fontsize=10)
    figure.tight_layout(rect=(0, 0.05, 1, 1))
    path = Path(path)
    figure.savefig(path, dpi=DPI, facecolor='white')
    return path


def _overlay(ax, frame: ScrewInFrame, model: CameraModel, mouth_radius: float) -> None:
    face = frame.measured if frame.measured is not None else frame.true
    if face is not None:
        depth = -float(face[2])
        axis = model.project(np.column_stack([
            np.zeros(2), np.zeros(2), [0.0, -(depth + _AXIS_BEYOND)]]))
        ax.plot(axis[:, 0], axis[:, 1], color=_AXIS_COLOR, lw=1.0, ls=':')
        foot = model.project([0.0, 0.0, -depth])[0]
        ax.plot(*foot, marker='+', ms=16, mew=1.5, color=_AXIS_COLOR, ls='none',
                label="gripper's axis at the face")
    if frame.measured is not None:
        outline = _outline(model, frame.measured, mouth_radius)
        ax.plot(outline[:, 0], outline[:, 1], color=_MEASURED_COLOR, lw=1.0,
                label='hole measured')
        centre = model.project(frame.measured)[0]
        ax.plot(*centre, marker='x', ms=8, mew=1.5, color=_MEASURED_COLOR, ls='none')
    if frame.true is not None:
        outline = _outline(model, frame.true, mouth_radius)
        ax.plot(outline[:, 0], outline[:, 1], color=_TRUE_COLOR, lw=1.0, ls=(0, (3, 3)),
                label='true hole')
