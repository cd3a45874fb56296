"""The wrist cameras' frames, rendered by pybullet's CPU renderer from the plant's true state.

A :class:`WristCameras` holds a physics client of its own (no simulation in it, nothing the
plant steps) with what a wrist camera sees: the truss nodes around it where they really are
(placement errors included), each face and hole the contact model's very shape (the hole a
dark insert, :mod:`walker_sim.core.node_mesh`), the nodes' blocks and the members between
them, and the camera's own gripper (its body and its screw, which cast shadows on the face).
The rest of the robot is not drawn: from a gripper over a node it is out of view, though a
link between the sun and the node would cast a shadow a real camera sees.

A frame is rendered only when asked for, with ``ER_TINY_RENDERER`` (software: no GPU, no
display): the client and its scene are built on the first frame, so a plant whose cameras are
never asked (or are off, ``gripper.camera.enabled: false``) spends nothing on them. Each frame
uses the camera's *true* mount, the sun's hard shadows, this frame's pixel noise and latency
(:mod:`walker_sim.core.camera_truth`), and carries the truth a test or a report compares a
measurement with: the nearest node's mouth in the gripper's frame.

A frame is taken in two parts: its *exposure* (:meth:`WristCameras.expose`: the gripper's pose,
the nearest node, the truth and the frame's draws; cheap, at the plant's instant) and its
*render* (:meth:`WristCameras.render`: two software renders, some hundred milliseconds), which
the plant has done by a process of its own (:mod:`walker_sim.core.frame_worker`,
:mod:`walker_sim.core.render_process`) while it steps on.
:meth:`WristCameras.frame` does both at once. A frame depends on its exposure alone, not on
when it is rendered.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pybullet

from walker_core.camera import CameraModel
from walker_core.joint_roles import GRIPPERS
from walker_core.rotations import quaternion_from_matrix
from walker_sim.core.camera_truth import CameraRendering, FrameDraws, MountErrors
from walker_sim.core.contact import NodeGeometry
from walker_sim.core.node_mesh import node_mesh

__all__ = ['CameraFrame', 'Exposure', 'WristCameras', 'projection_matrix', 'view_matrix']

_NODE_HALF_SIZE = 0.03  # [m] half edge of a node's block under its face (cosmetic)
_MEMBER_RADIUS = 0.012  # [m] radius of a truss member (cosmetic)
_GRIPPER_RADIUS = 0.035  # [m] the gripper's body, as the description draws it (cosmetic)
_GRIPPER_HEIGHT = 0.07
_SCREW_FRACTION = 0.8  # the screw's radius as a fraction of the bore's (its clearance)
# [m] How far the renderer puts the sun's shadow camera from the scene's origin: it maps the
# shadows of a region about this wide around the origin (the node under the camera, hence the
# scene's origin there), at the image's resolution: 0.3 m over 400 pixels is 0.75 mm a texel.
_SHADOW_DISTANCE = 0.3
# The fraction of the sun's light the renderer leaves in a shadow, and the sun's specular share.
_RENDERER_SHADOW = 0.8
_SPECULAR = 0.05
# [px] The software renderer's row offset against OpenGL's convention (see projection_matrix)
_RENDERER_ROW = 1.0
_FACE_COLOR = (0.78, 0.78, 0.75, 1.0)  # machined aluminium
_HOLE_COLOR = (0.12, 0.12, 0.13, 1.0)  # the hole's black-anodised insert
_NODE_COLOR = (0.35, 0.45, 0.6, 1.0)
_MEMBER_COLOR = (0.55, 0.6, 0.7, 1.0)
_GRIPPER_COLOR = (0.85, 0.55, 0.1, 1.0)
_SCREW_COLOR = (0.6, 0.6, 0.6, 1.0)


@dataclasses.dataclass(frozen=True)
class CameraFrame:
    """One frame of a wrist camera.

    Attributes
    ----------
    gripper : str
        Whose camera.
    image : ndarray, shape (height, width, 3), uint8
        RGB, row 0 at the top (the optical frame's -y side).
    exposure_time : float
        [s] Plant time of the instant the image shows.
    latency : float
        [s] How long after that it is ready (``ready_time = exposure_time + latency``).
    node : str
        The node nearest the gripper's axis (the one the truth is about).
    mouth_in_gripper : ndarray, shape (3,)
        The truth: where that node's hole mouth really is [m], in the gripper's frame (its x, y
        the hole's offset from the gripper's axis, -z the gripper's height over the face).
    """

    gripper: str
    image: np.ndarray
    exposure_time: float
    latency: float
    node: str
    mouth_in_gripper: np.ndarray

    @property
    def ready_time(self) -> float:
        """[s] Plant time the frame is ready."""
        return self.exposure_time + self.latency


@dataclasses.dataclass(frozen=True)
class Exposure:
    """What a frame takes of the plant at its instant, before it is rendered.

    Attributes
    ----------
    gripper : str
        Whose camera.
    pose : ndarray, shape (4, 4)
        The gripper's true contact-point frame in the truss frame, at the exposure.
    time : float
        [s] Plant time of the exposure.
    latency : float
        [s] The frame's drawn exposure latency.
    node : str
        The node nearest the gripper's axis.
    mouth_in_gripper : ndarray, shape (3,)
        That node's true mouth [m] in the gripper's frame.
    noise : ndarray, shape (height, width, 3), or None
        The frame's drawn standard normal pixel noise (None: no noise).
    """

    gripper: str
    pose: np.ndarray
    time: float
    latency: float
    node: str
    mouth_in_gripper: np.ndarray
    noise: np.ndarray | None

    @property
    def ready_time(self) -> float:
        """[s] Plant time the frame is ready."""
        return self.time + self.latency


def view_matrix(camera_in_world: np.ndarray) -> list[float]:
    """Return pybullet's view matrix (column-major 16) of an optical frame (4x4, world).

    OpenGL's camera looks along its -z with y up; the optical frame looks along +z with y
    down: the two differ by a half turn about x.
    """
    gl_camera = np.asarray(camera_in_world, dtype=float) @ np.diag([1.0, -1.0, -1.0, 1.0])
    return np.linalg.inv(gl_camera).T.reshape(-1).tolist()


def projection_matrix(model: CameraModel) -> list[float]:
    """Return pybullet's projection matrix (column-major 16) of the pinhole intrinsics.

    A point of the optical frame at ``(x, y, z)`` lands on pixel ``(fx x/z + cx, fy y/z + cy)``
    with pixel centres at whole numbers. The software renderer's rows are one off OpenGL's
    (flipped from the bottom row, it draws everything a row higher), hence the row added to
    ``cy``: measured, a rendered hole's fitted centre then falls on its projection to within
    0.05 pixel both ways (``test_wrist_camera``).
    """
    w, h, n, f = model.width, model.height, model.near, model.far
    cx, cy = model.cx, model.cy + _RENDERER_ROW
    projection = np.array([
        [2.0 * model.fx / w, 0.0, 1.0 - 2.0 * cx / w, 0.0],
        [0.0, 2.0 * model.fy / h, 2.0 * cy / h - 1.0, 0.0],
        [0.0, 0.0, -(f + n) / (f - n), -2.0 * f * n / (f - n)],
        [0.0, 0.0, -1.0, 0.0]])
    return projection.T.reshape(-1).tolist()


class WristCameras:
    """The two grippers' cameras of a plant.

    Parameters
    ----------
    model : CameraModel
        The nominal camera (intrinsics and mount).
    rendering : CameraRendering
        Light, noise and latency (``sim.camera.*``).
    mounts : MountErrors
        Each camera's true mount against the nominal one.
    truss : walker_core.truss.Truss
    mouths : dict
        Node name -> where its mouth really is [m], truss frame.
    geometry : NodeGeometry
        The nodes' face and hole.
    seed : int
        The imperfections' seed (the frames' noise and latency).
    """

    def __init__(self, model: CameraModel, rendering: CameraRendering, mounts: MountErrors,
                 truss, mouths: dict, geometry: NodeGeometry, seed: int) -> None:
        self.model = model
        self.rendering = rendering
        self.truss = truss
        self.geometry = geometry
        self._mouths = {name: np.asarray(p, dtype=float) for name, p in mouths.items()}
        self._mounts = {g: mounts.true_mount(g, model.mount) for g in GRIPPERS}
        self._draws = {g: FrameDraws(rendering, g, seed) for g in GRIPPERS}
        self._projection = projection_matrix(model)
        self._client: int | None = None
        self._own: tuple[int, int] | None = None  # the gripper being looked from

    def prepare(self) -> None:
        """Build the renderer's client and scene now rather than at the first frame."""
        if self._client is None:
            self._build()

    def restart(self) -> None:
        """Start the noise and latency draws over (the plant was reset)."""
        for draws in self._draws.values():
            draws.restart()

    def close(self) -> None:
        """Release the scene's client, if a frame was ever rendered."""
        if self._client is not None and pybullet.isConnected(self._client):
            pybullet.disconnect(physicsClientId=self._client)
        self._client = None
        self._own = None

    def true_mount(self, gripper: str) -> np.ndarray:
        """Return the true optical frame of a gripper's camera in the gripper's frame (4x4)."""
        return self._mounts[gripper].copy()

    # ------------------------------------------------------------------ the scene
    def _shape(self, shape_type: int, color, **options) -> int:
        return pybullet.createVisualShape(shape_type, rgbaColor=list(color),
                                          physicsClientId=self._client, **options)

    def _place(self, shape: int, position, orientation=(0.0, 0.0, 0.0, 1.0)) -> int:
        return pybullet.createMultiBody(baseMass=0.0, baseVisualShapeIndex=shape,
                                        basePosition=list(position),
                                        baseOrientation=list(orientation),
                                        physicsClientId=self._client)

    def _build(self) -> None:
        self._client = pybullet.connect(pybullet.DIRECT)
        self._neighbourhood: str | None = None
        try:
            self._shapes()
        except Exception:
            self.close()
            raise

    def _shapes(self) -> None:
        face, bore = node_mesh(self.geometry)
        self._face, self._bore = (
            self._shape(pybullet.GEOM_MESH, color, vertices=mesh.vertices.tolist(),
                        indices=mesh.indices.reshape(-1).tolist(), normals=mesh.normals.tolist())
            for mesh, color in ((face, _FACE_COLOR), (bore, _HOLE_COLOR)))
        self._block = self._shape(pybullet.GEOM_BOX, _NODE_COLOR,
                                  halfExtents=[_NODE_HALF_SIZE] * 3)
        self._member = self._shape(pybullet.GEOM_CYLINDER, _MEMBER_COLOR, radius=_MEMBER_RADIUS,
                                   length=self.truss.spacing - 2 * _NODE_HALF_SIZE)
        self._gripper_body = self._shape(
            pybullet.GEOM_CYLINDER, _GRIPPER_COLOR, radius=_GRIPPER_RADIUS,
            length=_GRIPPER_HEIGHT, visualFramePosition=[0.0, 0.0, 0.5 * _GRIPPER_HEIGHT])
        length = max(self.geometry.screw_length, 1e-4)
        self._screw = self._shape(pybullet.GEOM_CYLINDER, _SCREW_COLOR,
                                  radius=_SCREW_FRACTION * self.geometry.bore_radius,
                                  length=length, visualFramePosition=[0.0, 0.0, -0.5 * length])
        self._bodies: list[int] = []

    def _show_neighbourhood(self, centre: str) -> None:
        """Place the node under the camera, its neighbours and the members between them.

        Only they are drawn: the renderer's time grows with every body in the scene, and from
        a gripper over a node the rest of the truss is out of view or a speck.

        The scene's origin is the centre node's nominal place: the renderer maps shadows only
        around the origin.
        """
        if centre == self._neighbourhood:
            return
        for body in self._bodies:
            pybullet.removeBody(body, physicsClientId=self._client)
        truss, depth = self.truss, self.geometry.hole_depth
        below = np.array([0.0, 0.0, depth + _NODE_HALF_SIZE])
        along_x = pybullet.getQuaternionFromEuler([0.0, 0.5 * math.pi, 0.0])
        along_y = pybullet.getQuaternionFromEuler([0.5 * math.pi, 0.0, 0.0])
        column, row = truss.index(centre)
        self._origin = truss.position(centre)
        bodies = []
        for name in truss.node_names:
            c, r = truss.index(name)
            if abs(c - column) > 1 or abs(r - row) > 1:
                continue
            mouth = self._mouths[name] - self._origin
            bodies += [self._place(self._face, mouth), self._place(self._bore, mouth),
                       self._place(self._block, mouth - below)]
            nominal = truss.position(name) - self._origin - below
            if c + 1 < truss.columns and c + 1 - column <= 1:
                bodies.append(self._place(self._member,
                                          nominal + [0.5 * truss.spacing, 0.0, 0.0], along_x))
            if r + 1 < truss.rows and r + 1 - row <= 1:
                bodies.append(self._place(self._member,
                                          nominal + [0.0, 0.5 * truss.spacing, 0.0], along_y))
        self._bodies = bodies
        self._neighbourhood = centre

    # ------------------------------------------------------------------ frames
    def _render(self, camera: np.ndarray, shadow: bool) -> tuple[np.ndarray, np.ndarray]:
        model, light = self.model, self.rendering
        _, _, rgba, _, segmentation = pybullet.getCameraImage(
            model.width, model.height, view_matrix(camera), self._projection,
            shadow=int(shadow), lightDirection=light.sun.tolist(), lightColor=[1.0, 1.0, 1.0],
            lightAmbientCoeff=light.ambient, lightDiffuseCoeff=1.0 - light.ambient,
            lightSpecularCoeff=_SPECULAR, lightDistance=_SHADOW_DISTANCE,
            renderer=pybullet.ER_TINY_RENDERER, physicsClientId=self._client)
        image = np.reshape(np.asarray(rgba, dtype=np.uint8),
                           (model.height, model.width, 4))[:, :, :3].astype(float)
        return image, np.reshape(np.asarray(segmentation), (model.height, model.width))

    def _hard_shadows(self, camera: np.ndarray) -> np.ndarray:
        """Render with hard shadows: the sun's light gone wherever something stands before it.

        The renderer only dims the sun's light in a shadow to :data:`_RENDERER_SHADOW` of it;
        the image with that shadow and the one without give the sun's part there, which the
        frame takes out altogether: in a shadow only the ambient light is left, as in orbit.
        """
        lit, space = self._render(camera, shadow=False)
        dimmed, _ = self._render(camera, shadow=True)
        image = lit - (lit - dimmed) / (1.0 - _RENDERER_SHADOW)
        image[space < 0] = 0.0  # nothing there: black space (the renderer would leave it white)
        return np.clip(np.rint(image), 0, 255).astype(np.uint8)

    def nearest_node(self, position) -> str:
        """Return the node whose mouth is nearest a point's x, y [m] (truss frame)."""
        return min(self._mouths, key=lambda name: float(np.hypot(
            *(self._mouths[name][:2] - np.asarray(position, dtype=float)[:2]))))

    def expose(self, gripper: str, pose: np.ndarray, time: float) -> Exposure:
        """Take what a frame of a gripper's camera needs of this instant, without rendering it.

        Cheap, and in the plant's order: the gripper's pose, the node nearest it, the truth
        (that node's mouth in the gripper's frame), then the frame's draws (latency, then
        noise), so that frames stay seeded as they are drawn, whenever they are rendered.

        Parameters
        ----------
        gripper : str
            ``'a'`` or ``'b'``.
        pose : ndarray, shape (4, 4)
            The gripper's true contact-point frame in the truss frame.
        time : float
            [s] The plant's time now (the frame's exposure).

        Returns
        -------
        Exposure
            What :meth:`render` turns into the frame.
        """
        if gripper not in GRIPPERS:
            raise ValueError(f"gripper must be 'a' or 'b', got {gripper!r}")
        pose = np.array(pose, dtype=float)
        node = self.nearest_node(pose[:3, 3])
        mouth = pose[:3, :3].T @ (self._mouths[node] - pose[:3, 3])
        draws = self._draws[gripper]
        latency = draws.latency()
        noise = draws.noise((self.model.height, self.model.width, 3))
        return Exposure(gripper, pose, float(time), latency, node, mouth, noise)

    def render(self, exposure: Exposure) -> CameraFrame:
        """Render an exposure: the expensive part of a frame (two software renders).

        The scene (its client built on the first frame, or by :meth:`prepare`) is this
        object's alone: render from one thread at a time.
        """
        self.prepare()
        pose = exposure.pose
        self._show_neighbourhood(exposure.node)
        local = pose.copy()  # in the scene, whose origin is the node's nominal place
        local[:3, 3] -= self._origin
        orientation = _quaternion(pose[:3, :3])
        if self._own is None:
            self._own = (self._place(self._gripper_body, local[:3, 3], orientation),
                         self._place(self._screw, local[:3, 3], orientation))
        for body in self._own:
            pybullet.resetBasePositionAndOrientation(body, local[:3, 3].tolist(), orientation,
                                                     physicsClientId=self._client)
        camera = local @ self._mounts[exposure.gripper]
        image = self._draws[exposure.gripper].add_noise(self._hard_shadows(camera),
                                                       exposure.noise)
        return CameraFrame(exposure.gripper, image, exposure.time, exposure.latency,
                           exposure.node, exposure.mouth_in_gripper)

    def frame(self, gripper: str, pose: np.ndarray, time: float) -> CameraFrame:
        """Expose and render a gripper's camera at a gripper pose (:meth:`expose`, :meth:`render`).

        Parameters
        ----------
        gripper : str
            ``'a'`` or ``'b'``.
        pose : ndarray, shape (4, 4)
            The gripper's true contact-point frame in the truss frame.
        time : float
            [s] The plant's time now (the frame's exposure).
        """
        return self.render(self.expose(gripper, pose, time))

def _quaternion(rotation: np.ndarray) -> list[float]:
    return [float(v) for v in quaternion_from_matrix(rotation)]
