"""What the wrist cameras really are and see, against the model: light, noise, delay, mount.

The model of each camera (``gripper.camera.*``, :mod:`walker_core.camera`) is what whoever
measures from an image uses. The plant renders each frame with the truth, which differs from it
in what makes vision hard in orbit:

* **light** (``sim.camera.sun_direction``, ``ambient``): one strong directional sun casting
  hard shadows, and little else (no air to scatter it; what is left is earthshine and the
  robot's own reflections, ``ambient``);
* **pixel noise** (``sim.camera.pixel_noise``): a white noise of that standard deviation on
  every pixel's every channel [grey levels of 255], drawn anew for each frame;
* **exposure latency** (``sim.camera.exposure_latency``): a frame shows the plant at the
  instant it was asked for and is ready a uniformly drawn time of at most this later;
* **the mount's calibration error** (``sim.imperfections.camera_mount_position`` and
  ``camera_mount_angle``): each camera sits off its nominal mount by an independent normal
  error of that standard deviation along each axis of the optical frame, and turned by a rotation
  vector of one about each axis, drawn once per plant from the imperfections' seed.

Draws come from ``SeedSequence([seed, stream])`` (:mod:`walker_sim.core.imperfections`): the
mount errors from :data:`MOUNT_STREAM`, each camera's noise and latency from
:data:`FRAME_STREAM` and its gripper's index, so the same seed gives the same frames, and with
every value zero the frames are the model's exactly.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.spatial.transform import Rotation

from walker_core.joint_roles import GRIPPERS
from walker_core.parameter_schema import ParameterError, parameter

__all__ = ['CameraRendering', 'MountErrors', 'FrameDraws', 'MOUNT_STREAM', 'FRAME_STREAM']

#: Sub-streams of ``SeedSequence([seed, stream, ...])`` beside the placement (0) and sensor
#: (1) streams of :mod:`walker_sim.core.imperfections`.
MOUNT_STREAM = 2
FRAME_STREAM = 3


@dataclasses.dataclass(frozen=True)
class CameraRendering:
    """How the plant renders the wrist cameras (``sim.camera.*``): light, noise, latency."""

    sun_direction: tuple[float, ...] = parameter(
        'direction from the truss toward the sun (x, y, z), truss frame; need not be unit', '',
        -1.0, 1.0, source='chosen: high and to the side, so that shadows fall across the node')
    ambient: float = parameter(
        'light that is not the sun (earthshine, reflections), as a fraction of full light', '',
        0.0, 1.0, source='chosen: dim, as in orbit')
    pixel_noise: float = parameter(
        "standard deviation of each pixel's noise (of 255 levels), every frame", 'grey levels',
        0.0, 50.0, source='chosen: a small sensor in daylight')
    exposure_latency: float = parameter(
        'the most a frame is ready after the instant it shows (drawn uniformly up to it)', 's',
        0.0, 1.0, source='chosen: a camera read out at 30 Hz')
    frame_rate: float = parameter(
        "rate of each camera's frames while its image is subscribed (plant time); 0: only "
        'triggered', 'Hz', 0.0, 100.0,
        source='chosen: none streamed, a frame costs a few hundred control periods of rendering')

    def __post_init__(self) -> None:
        if len(self.sun_direction) != 3:
            raise ParameterError('sim.camera.sun_direction needs 3 values (x, y, z), got '
                                 f'{len(self.sun_direction)}')
        if np.linalg.norm(self.sun_direction) < 1e-3:
            raise ParameterError('sim.camera.sun_direction must not be zero')

    @property
    def sun(self) -> np.ndarray:
        """Unit direction toward the sun, truss frame."""
        direction = np.asarray(self.sun_direction, dtype=float)
        return direction / np.linalg.norm(direction)


def _generator(seed: int, *stream: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence([int(seed), *stream]))


class MountErrors:
    """Each camera's true mount against its nominal one: a small rigid transform.

    Parameters
    ----------
    position, angle : float
        Standard deviations [m], [rad] of the error along and about each optical axis; 0, 0:
        every camera sits where the model says.
    seed : int
        Seed of the draws (stream :data:`MOUNT_STREAM`).
    """

    def __init__(self, position: float, angle: float, seed: int) -> None:
        self._errors = {gripper: np.eye(4) for gripper in GRIPPERS}
        if position > 0.0 or angle > 0.0:
            drawn = _generator(seed, MOUNT_STREAM).standard_normal((len(GRIPPERS), 6))
            for row, gripper in zip(drawn, GRIPPERS, strict=True):
                error = np.eye(4)
                error[:3, :3] = Rotation.from_rotvec(angle * row[3:]).as_matrix()
                error[:3, 3] = position * row[:3]
                self._errors[gripper] = error

    def error(self, gripper: str) -> np.ndarray:
        """Return the true optical frame in the nominal one (4x4)."""
        return self._errors[gripper].copy()

    def true_mount(self, gripper: str, nominal: np.ndarray) -> np.ndarray:
        """Return the true optical frame in the gripper's frame, of the nominal one (4x4)."""
        return np.asarray(nominal, dtype=float) @ self._errors[gripper]


class FrameDraws:
    """The random part of one camera's frames: pixel noise and exposure latency.

    Parameters
    ----------
    rendering : CameraRendering
    gripper : str
        Whose camera (its index picks the sub-stream).
    seed : int
        The imperfections' seed; :meth:`restart` starts the draws over from it.
    """

    def __init__(self, rendering: CameraRendering, gripper: str, seed: int) -> None:
        self._noise = rendering.pixel_noise
        self._latency = rendering.exposure_latency
        self._stream = (FRAME_STREAM, GRIPPERS.index(gripper))
        self._seed = int(seed)
        self.restart()

    def restart(self) -> None:
        """Start the draws over from the seed (a reset plant repeats its frames)."""
        self._generator = _generator(self._seed, *self._stream)

    def latency(self) -> float:
        """[s] Draw the delay of a frame, uniformly in ``[0, exposure_latency]``."""
        return float(self._latency * self._generator.random()) if self._latency > 0.0 else 0.0

    def noise(self, shape: tuple[int, ...]) -> np.ndarray | None:
        """Draw a frame's pixel noise, in standard deviations (None: ``pixel_noise`` is 0).

        Drawn with the frame's latency, when the frame is exposed, so that the draws keep their
        order however late the image is rendered; :meth:`add_noise` scales and adds it.
        """
        if self._noise <= 0.0:
            return None
        return self._generator.standard_normal(shape)

    def add_noise(self, image: np.ndarray, noise: np.ndarray | None) -> np.ndarray:
        """Return an RGB image (uint8) with a frame's drawn noise (:meth:`noise`) added."""
        if noise is None:
            return image
        return np.clip(np.rint(image + self._noise * noise), 0, 255).astype(np.uint8)

    def noisy(self, image: np.ndarray) -> np.ndarray:
        """Return an RGB image (uint8) with this frame's pixel noise drawn and added."""
        return self.add_noise(image, self.noise(image.shape))
