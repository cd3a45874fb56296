"""Headless images of the walker on its truss (pybullet's software renderer).

The scene lives in a physics client of its own, so it can draw the plant as it is or a
recorded state (joint angles and the pose of gripper a) without touching any simulation: the
walk animation renders frames from recorded states. It loads the plant's URDF, so the links
are drawn bent as the plant bends them when the bending angles are given.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pybullet

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_core.truss import Truss
from walker_core.urdf import flex_joints, plant_urdf
from walker_sim.core.bullet import index_body, load_urdf_text

__all__ = ['Camera', 'TrussScene', 'render_plant', 'save_png']

_NODE_HALF_SIZE = 0.03  # [m] half edge of a node block (cosmetic)
_MEMBER_RADIUS = 0.012  # [m] radius of a truss member (cosmetic)
_HOLE_RADIUS = 0.01  # [m] radius of the hole mark (cosmetic)
_NODE_COLOR = (0.35, 0.45, 0.6, 1.0)
_MEMBER_COLOR = (0.55, 0.6, 0.7, 1.0)
_HOLE_COLOR = (0.05, 0.05, 0.05, 1.0)
_BACKGROUND_PLANE = -0.25  # [m] height of the dark backdrop under the truss (cosmetic)


@dataclasses.dataclass(frozen=True)
class Camera:
    """A perspective camera looking at a point.

    Attributes
    ----------
    target : tuple of 3 float
        Point looked at [m], truss frame.
    distance : float
        Distance [m] from the target.
    yaw, pitch : float
        Viewing direction [deg] (pybullet's convention: pitch < 0 looks down).
    fov : float
        Vertical field of view [deg].
    """

    target: tuple[float, float, float]
    distance: float = 3.0
    yaw: float = 30.0
    pitch: float = -35.0
    fov: float = 45.0

    @classmethod
    def overview(cls, truss: Truss) -> 'Camera':
        """Return a camera that shows the whole truss face."""
        width = (truss.columns - 1) * truss.spacing
        depth = (truss.rows - 1) * truss.spacing
        centre = (truss.origin[0] + 0.5 * width, truss.origin[1] + 0.5 * depth, 0.0)
        return cls(target=centre, distance=max(2.0, 1.25 * math.hypot(width, depth)),
                   pitch=-45.0)


class TrussScene:
    """The robot and the truss, ready to be drawn.

    Parameters
    ----------
    params : WalkerParameters
        Robot and truss parameters.
    """

    def __init__(self, params) -> None:
        self.params = params
        self.truss = Truss.from_parameters(params)
        self.client = pybullet.connect(pybullet.DIRECT)
        try:
            self.body = load_urdf_text(self.client, plant_urdf(params), fixed_base=True)
            self.index = index_body(self.client, self.body)
            self._bends = [self.index.joints[b.name]
                           for b in flex_joints(params.robot.flexibility.segments_per_link)]
            self._add_truss()
        except Exception:
            self.close()
            raise

    def close(self) -> None:
        """Release the scene's client."""
        if pybullet.isConnected(self.client):
            pybullet.disconnect(physicsClientId=self.client)

    def __enter__(self) -> 'TrussScene':
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def _shape(self, shape_type: int, color, **size) -> int:
        return pybullet.createVisualShape(shape_type, rgbaColor=list(color),
                                          physicsClientId=self.client, **size)

    def _place(self, shape: int, position, orientation=(0.0, 0.0, 0.0, 1.0)) -> None:
        pybullet.createMultiBody(baseMass=0.0, baseVisualShapeIndex=shape,
                                 basePosition=list(position),
                                 baseOrientation=list(orientation), physicsClientId=self.client)

    def _add_truss(self) -> None:
        truss = self.truss
        node = self._shape(pybullet.GEOM_BOX, _NODE_COLOR, halfExtents=[_NODE_HALF_SIZE] * 3)
        hole = self._shape(pybullet.GEOM_CYLINDER, _HOLE_COLOR, radius=_HOLE_RADIUS,
                           length=0.002)
        along_x = pybullet.getQuaternionFromEuler([0.0, 0.5 * math.pi, 0.0])
        along_y = pybullet.getQuaternionFromEuler([0.5 * math.pi, 0.0, 0.0])
        member = self._shape(pybullet.GEOM_CYLINDER, _MEMBER_COLOR, radius=_MEMBER_RADIUS,
                             length=truss.spacing - 2 * _NODE_HALF_SIZE)
        for name in truss.node_names:
            position = truss.position(name)
            self._place(node, position - [0.0, 0.0, _NODE_HALF_SIZE])
            self._place(hole, position + [0.0, 0.0, 0.0005])
            column, row = truss.index(name)
            centre = position - [0.0, 0.0, _NODE_HALF_SIZE]
            if column + 1 < truss.columns:
                self._place(member, centre + [0.5 * truss.spacing, 0.0, 0.0], along_x)
            if row + 1 < truss.rows:
                self._place(member, centre + [0.0, 0.5 * truss.spacing, 0.0], along_y)
        width = (truss.columns + 1) * truss.spacing
        depth = (truss.rows + 1) * truss.spacing
        backdrop = self._shape(pybullet.GEOM_BOX, (0.12, 0.12, 0.15, 1.0),
                               halfExtents=[0.5 * width, 0.5 * depth, 0.005])
        self._place(backdrop, [truss.origin[0] + 0.5 * (width - 2 * truss.spacing),
                               truss.origin[1] + 0.5 * (depth - 2 * truss.spacing),
                               _BACKGROUND_PLANE])

    def pose_robot(self, positions, gripper_a_position, gripper_a_orientation,
                   bending=None) -> None:
        """Put the robot in a state.

        Parameters
        ----------
        positions : sequence of 5 float
            Joint angles [rad], physical order.
        gripper_a_position : sequence of 3 float
            Gripper a's contact point [m], truss frame.
        gripper_a_orientation : sequence of 4 float
            Gripper a's orientation, quaternion ``(x, y, z, w)``.
        bending : sequence of float, optional
            Bending joint angles [rad] (:func:`walker_core.urdf.flex_joints` order); straight
            links when omitted.
        """
        client = self.client
        pybullet.resetBasePositionAndOrientation(self.body, list(gripper_a_position),
                                                 list(gripper_a_orientation),
                                                 physicsClientId=client)
        for name, angle in zip(PHYSICAL_JOINT_NAMES, positions, strict=True):
            pybullet.resetJointState(self.body, self.index.joints[name], float(angle),
                                     physicsClientId=client)
        bending = np.zeros(len(self._bends)) if bending is None else bending
        for joint, angle in zip(self._bends, bending, strict=True):
            pybullet.resetJointState(self.body, joint, float(angle), physicsClientId=client)

    def render(self, camera: Camera | None = None, width: int = 960, height: int = 640,
               shadow: bool = True) -> np.ndarray:
        """Draw the scene with the software renderer (no display needed).

        ``shadow=False`` leaves out the cast shadows, which take more than half of the
        renderer's time (animations drawing hundreds of frames use it).

        Returns
        -------
        ndarray, shape (height, width, 3), uint8
            RGB image.
        """
        if width < 16 or height < 16:
            raise ValueError(f'image size must be at least 16x16 pixels, got {width}x{height}')
        camera = Camera.overview(self.truss) if camera is None else camera
        view = pybullet.computeViewMatrixFromYawPitchRoll(
            list(camera.target), camera.distance, camera.yaw, camera.pitch, 0.0, 2,
            physicsClientId=self.client)
        projection = pybullet.computeProjectionMatrixFOV(camera.fov, width / height, 0.02, 50.0,
                                                         physicsClientId=self.client)
        _, _, rgba, _, _ = pybullet.getCameraImage(
            width, height, view, projection, shadow=int(bool(shadow)),
            lightDirection=[1.0, 1.0, 2.0], renderer=pybullet.ER_TINY_RENDERER,
            physicsClientId=self.client)
        return np.reshape(np.asarray(rgba, dtype=np.uint8), (height, width, 4))[:, :, :3]


def render_plant(plant, camera: Camera | None = None, width: int = 960, height: int = 640,
                 scene: TrussScene | None = None) -> np.ndarray:
    """Draw a plant as it is now (an RGB array, see :meth:`TrussScene.render`)."""
    own = scene is None
    scene = TrussScene(plant.params) if own else scene
    try:
        state = plant.state()
        pose = state.poses['a']
        scene.pose_robot(state.position, pose.position, pose.orientation, plant.bending())
        return scene.render(camera, width, height)
    finally:
        if own:
            scene.close()


def save_png(image: np.ndarray, path) -> Path:
    """Write an RGB array as a PNG file and return its path."""
    import matplotlib.image

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    matplotlib.image.imsave(path, np.asarray(image, dtype=np.uint8))
    return path
