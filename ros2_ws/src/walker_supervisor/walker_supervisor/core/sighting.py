"""The hole a wrist camera's frame shows, placed in the base frame through the joints.

:class:`HoleSighter` turns one frame of the moving gripper's camera into a :class:`Sighting`:
the :class:`~walker_supervisor.core.hole_finder.HoleFinder` measures the hole's axis in the
gripper's frame, at the face's height below the gripper (the map's estimate of the node's
mouth against the gripper's height, both through the forward kinematics), and the gripper's
pose from the joints at the frame's instant (eq (1), :meth:`WalkerKinematics.
forward_transform`) carries it into the base frame. The camera sees the hole against the
gripper itself: the offset does not depend on the joints' calibration, only the hole's place
in the base frame does.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from walker_core.camera import CameraModel
from walker_core.kinematics import WalkerKinematics
from walker_supervisor.core.hole_finder import HoleFinder

__all__ = ['Sighting', 'HoleSighter', 'JointHistory', 'LookFrame', 'LookResult', 'look_result',
           'locate',
           'POSE_STD', 'frame_weights', 'combine']

#: [m] Standard deviation of the gripper's place at rest against the joints' forward kinematics
#: (what the links' bending and the joints' noise leave after the arm has settled), each
#: horizontal axis: two looks from nearly the same place that disagree by this much do not
#: make the height up.
POSE_STD = 3e-5


@dataclasses.dataclass(frozen=True)
class Sighting:
    """What one look saw.

    Attributes
    ----------
    hole : ndarray, shape (3,), or None
        [m] The hole's mouth in the base frame (its height the one assumed); None: not seen.
    slope : ndarray, shape (2,), or None
        How far the hole's x, y move per metre its height is higher than assumed (the line of
        sight's horizontal run per unit of rise, base frame): a height error moves the hole
        along the line of sight (:func:`locate`).
    offset : ndarray, shape (2,), or None
        [m] The hole's axis from the gripper's axis, in the gripper's frame (x, y).
    sigma : float
        [m] Standard deviation of each horizontal component at the assumed height, from the
        image alone (inf when not seen).
    reason : str
        Why the hole was not seen ('' when it was).
    detail : str
        What the image showed, for a log.
    """

    hole: np.ndarray | None
    slope: np.ndarray | None
    offset: np.ndarray | None
    sigma: float
    reason: str
    detail: str

    @property
    def found(self) -> bool:
        """True when the frame gave the hole."""
        return self.hole is not None

    @property
    def distance(self) -> float:
        """[m] How far the hole's axis is from the gripper's (nan when not seen)."""
        return math.nan if self.offset is None else float(np.hypot(*self.offset))


@dataclasses.dataclass(frozen=True)
class LookFrame:
    """One frame of a look, in the gripper's frame at its instant (the joints' kinematics).

    Attributes
    ----------
    exposure_time : float
        [s] The frame's instant (graph clock).
    weight : float
        Its weight in the look's mean (:func:`frame_weights`).
    measured : ndarray, shape (2,), or None
        [m] The hole's axis as this frame alone measured it, at the height the step assumed
        (x, y: its offset from the gripper's axis); None when not seen.
    located : ndarray, shape (2,), or None
        [m] The hole's axis as the look located it; None when not located.
    """

    exposure_time: float
    weight: float
    measured: np.ndarray | None
    located: np.ndarray | None


@dataclasses.dataclass(frozen=True)
class LookResult:
    """One look as the walk runner took it: what a report compares with the plant's truth.

    Attributes
    ----------
    gripper, node : str
        Whose camera, and the step's target node.
    found : bool
        The hole was seen.
    reason : str
        Why not ('' when seen).
    frames : tuple of LookFrame
        The look's frames, in order.
    spread : float
        [m] The located hole's worst horizontal standard deviation (inf: not located).
    final : bool
        The step looks no more before its descent (the hole it goes for).
    """

    gripper: str
    node: str
    found: bool
    reason: str
    frames: tuple[LookFrame, ...]
    spread: float
    final: bool


class HoleSighter:
    """Places the hole a wrist camera sees.

    Parameters
    ----------
    params : walker_core.robot_parameters.WalkerParameters
        ``gripper.camera.*`` (the nominal camera) and ``gripper.insertion_position_tolerance``
        (the mouth's radius).
    """

    def __init__(self, params) -> None:
        gripper = params.gripper
        self.enabled = bool(gripper.camera.enabled)
        self._finder = HoleFinder(CameraModel.from_parameters(gripper.camera),
                                  gripper.insertion_position_tolerance) if self.enabled else None

    def sight(self, image: np.ndarray, kinematics: WalkerKinematics, theta_roles: np.ndarray,
              mouth_height: float) -> Sighting:
        """Find the hole in ``image`` and place it in the base frame.

        Parameters
        ----------
        image : ndarray, shape (height, width, 3), uint8
            The moving gripper's frame.
        theta_roles : ndarray, shape (5,)
            [rad] The joints at the frame's instant, role order of the base.
        mouth_height : float
            [m] The node's mouth height in the base frame assumed (the map's estimate).

        Raises
        ------
        ValueError
            If the grippers carry no camera or the image is not the camera's size.
        """
        if self._finder is None:
            raise ValueError('the grippers carry no camera (gripper.camera.enabled is false)')
        pose = kinematics.forward_transform(theta_roles)
        height = float(pose[2, 3]) - float(mouth_height)
        if not height > 0.0:
            return Sighting(None, None, None, math.inf, 'out of view',
                            f'the face is not below the gripper ({height * 1e3:.1f} mm)')
        measured = self._finder.find(image, height)
        if not measured.found:
            return Sighting(None, None, None, math.inf, str(measured.reason), measured.detail)
        offset = np.asarray(measured.offset, dtype=float)
        # on the face's plane at the height the finder measured it at (the one assumed, or
        # the one the mouth's size says): a point on the line of sight either way
        hole = (pose @ np.array([offset[0], offset[1], -measured.height, 1.0]))[:3]
        sight = hole - (pose @ np.append(self._finder.model.mount[:3, 3], 1.0))[:3]
        return Sighting(hole, sight[:2] / sight[2], offset, float(measured.sigma), '',
                        measured.detail)


def frame_weights(count: int) -> np.ndarray:
    """Return the weights of a look's ``count`` frames: the binomial coefficients, summing to 1.

    Frames half a period of a mode apart, so weighted, are the zero-vibration shaper convolved
    ``count - 1`` times with itself (Singer and Seering): the mode's ringing cancels in their
    mean, and the more frames the wider the band of frequencies it cancels in (3 frames: to
    within 5 % of its amplitude at 15 % off the frequency).
    """
    if count < 1:
        raise ValueError(f'a look takes at least one frame, not {count}')
    weights = np.array([math.comb(count - 1, k) for k in range(count)], dtype=float)
    return weights / weights.sum()


def combine(frames: list[Sighting]) -> Sighting:
    """Return the weighted mean of a look's frames (:func:`frame_weights`, in their order).

    The frames that saw the hole count, their weights scaled to sum to 1; the look is not seen
    when none did (the first frame's reason).
    """
    weights = frame_weights(len(frames))
    seen = [(w, f) for w, f in zip(weights, frames, strict=True) if f.found]
    if not seen:
        return frames[0]
    total = sum(w for w, _ in seen)
    w = np.array([w / total for w, _ in seen])

    def mean(name: str) -> np.ndarray:
        return np.einsum('i,ij->j', w, np.array([getattr(f, name) for _, f in seen]))

    sigma = math.sqrt(float(np.sum((w * np.array([f.sigma for _, f in seen])) ** 2)))
    detail = f'{len(seen)} of {len(frames)} frames; ' + seen[0][1].detail
    return Sighting(mean('hole'), mean('slope'), mean('offset'), sigma, '', detail)


def locate(sightings: list[Sighting], height: float, height_std: float
           ) -> tuple[np.ndarray, np.ndarray]:
    """Return where the hole is, from the looks at it and the height known before them.

    Each look puts the hole on its line of sight: ``x_y = h_y + b (z - h_z)`` with ``h`` the
    hole at the height it assumed and ``b`` its :attr:`~Sighting.slope`, to the image's
    ``sigma`` and :data:`POSE_STD` on each axis. With the height ``height`` [m] (base frame)
    known to ``height_std`` [m] beforehand, the weighted least squares of the three unknowns
    ``x, y, z`` over every look is the estimate; looks along different lines of sight (from
    different heights over the node) measure its height, which one look cannot.

    Returns
    -------
    position : ndarray, shape (3,)
        [m] The hole's mouth in the base frame.
    covariance : ndarray, shape (3, 3)
        [m^2] Its covariance, the images' and the prior height's.
    """
    normal, right = np.zeros((3, 3)), np.zeros(3)
    for seen in sightings:
        rows = np.array([[1.0, 0.0, -seen.slope[0]], [0.0, 1.0, -seen.slope[1]]])
        values = seen.hole[:2] - seen.slope * seen.hole[2]
        weight = 1.0 / (seen.sigma ** 2 + POSE_STD ** 2)
        normal += weight * rows.T @ rows
        right += weight * rows.T @ values
    weight = 1.0 / max(height_std, 1e-9) ** 2
    normal[2, 2] += weight
    right[2] += weight * height
    covariance = np.linalg.inv(normal)
    return covariance @ right, (covariance + covariance.T) / 2.0


def look_result(gripper: str, node: str, look: Sighting,
                frames: list[tuple[float, np.ndarray, Sighting]], weights: list[float],
                located: tuple[np.ndarray, np.ndarray] | None, final: bool) -> LookResult:
    """Return a :class:`LookResult` of a look: ``look`` its frames' mean (:func:`combine`).

    ``frames`` are each frame's instant [s], the gripper's 4x4 pose in the base frame then (the
    joints' forward kinematics) and what it showed; ``located`` the hole's position [m] and
    covariance [m^2] in the base frame after the look (None: not located).
    """
    spread = math.inf if located is None else math.sqrt(
        max(float(np.linalg.eigvalsh(located[1][:2, :2]).max()), 0.0))
    taken = []
    for (time, pose, sighting), weight in zip(frames, weights, strict=True):
        in_gripper = None if located is None else np.linalg.solve(
            pose, np.append(located[0], 1.0))[:2]
        taken.append(LookFrame(time, float(weight), sighting.offset, in_gripper))
    return LookResult(gripper, node, look.found, look.reason, tuple(taken), spread, final)


class JointHistory:
    """The joints (physical order) [rad] of the last ticks, to find those of an instant."""

    SPAN = 2.0  # [s] kept

    def __init__(self) -> None:
        self._ticks: list[tuple[float, np.ndarray]] = []

    def add(self, now: float, positions: np.ndarray) -> None:
        """Keep the joints of the tick at ``now`` [s]."""
        ticks = self._ticks
        if ticks and now < ticks[-1][0]:
            ticks.clear()  # the clock went back: a new run
        ticks.append((now, np.array(positions, dtype=float)))
        while ticks and ticks[0][0] < now - self.SPAN:
            ticks.pop(0)

    def at(self, time: float) -> np.ndarray | None:
        """Return the joints of the tick nearest ``time`` [s] (None before any)."""
        if not self._ticks:
            return None
        return min(self._ticks, key=lambda tick: abs(tick[0] - time))[1].copy()
