"""The wrist camera on each gripper: its parameters (``gripper.camera.*``) and its geometry.

Each gripper carries a camera beside its body, off the gripper's axis, looking down along that
axis at the node below and tilted toward it so that the point of the axis ``aim_distance``
below the contact point is at the image's centre. The model here is the one every package
shares: the nominal mount and the plumb-bob (pinhole) intrinsics. The plant renders with the
*true* mount (the nominal one and a calibration error, ``sim.imperfections.camera_mount_*``);
whoever measures from an image uses this nominal one.

Frames (REP 103 / REP 104):

* the gripper frame: origin at the gripper's contact point, z along the gripper's axis away
  from the truss (:mod:`walker_core.kinematics`);
* the camera's optical frame ``camera_<gripper>_optical``: origin at the optical centre, z
  forward along the line of sight, x right and y down in the image.

A pixel ``(u, v)`` (u along a row, v down the rows, the centre of the top-left pixel at
``(0, 0)``, OpenCV's convention) sees the ray ``((u - cx) / fx, (v - cy) / fy, 1)`` of the
optical frame. The renderer is a pinhole: the distortion of the plumb-bob model is zero.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from walker_core.parameter_schema import ParameterError, parameter

__all__ = ['CameraParameters', 'CameraModel', 'PlumbBob', 'mount_transform', 'mount_rpy',
           'optical_frame_name', 'camera_topic', 'PLUMB_BOB', 'IMAGE', 'CAMERA_INFO',
           'TRUE_HOLE', 'HOLE', 'RECORDED_CAMERA_TOPICS']

#: ``sensor_msgs/CameraInfo.distortion_model`` of the camera (its five coefficients are zero).
PLUMB_BOB = 'plumb_bob'

# The topics of a gripper's camera, ``camera_<g>/<name>`` (:func:`camera_topic`):
#: the frames (``sensor_msgs/Image``, the plant's)
IMAGE = 'image_raw'
#: their calibration (``sensor_msgs/CameraInfo``, the plant's)
CAMERA_INFO = 'camera_info'
#: where each frame's hole really is (``geometry_msgs/PointStamped``, the plant's simulation
#: truth)
TRUE_HOLE = 'true_hole'
#: where each frame's hole was measured (``geometry_msgs/PointStamped``, the supervisor's)
HOLE = 'hole'
#: What a walk's bag holds of each camera: the frames of the looks with the truth and the
#: measurement beside each.
RECORDED_CAMERA_TOPICS = (IMAGE, CAMERA_INFO, TRUE_HOLE, HOLE)


@dataclasses.dataclass(frozen=True)
class CameraParameters:
    """The wrist camera of each gripper (``gripper.camera.*``): mount and intrinsics."""

    enabled: bool = parameter(
        "whether the grippers carry a wrist camera; false is the paper's blind robot",
        source='chosen: off until the visually aligned fine motion is proven in campaigns')
    width: int = parameter('image width', 'px', 16, 4096,
                           source='chosen: enough pixels on the hole, a cheap frame')
    height: int = parameter('image height', 'px', 16, 4096,
                            source='chosen: enough pixels on the hole, a cheap frame')
    focal_length_x: float = parameter(
        'focal length along the image rows (plumb-bob fx)', 'px', 1.0, 100000.0,
        source='chosen: a 53 deg horizontal field of view at the default width')
    focal_length_y: float = parameter(
        'focal length down the image columns (plumb-bob fy)', 'px', 1.0, 100000.0,
        source='chosen: square pixels')
    principal_point: tuple[float, ...] = parameter(
        'principal point (cx, cy), from the centre of the top-left pixel', 'px', 0.0, 4096.0,
        source='chosen: the image centre')
    mount_position: tuple[float, ...] = parameter(
        "optical centre (x, y, z) in the gripper's frame (z along its axis, away from the truss)",
        'm', -0.5, 0.5,
        source="chosen: 45 mm off the axis, clear of the gripper's 35 mm radius body")
    aim_distance: float = parameter(
        "how far below the contact point the line of sight crosses the gripper's axis", 'm',
        0.001, 1.0,
        source='chosen: the face of the node at the approach height')
    near_clip: float = parameter('nearest distance the camera sees', 'm', 0.001, 1.0,
                                 source='chosen: in front of the lens')
    far_clip: float = parameter('farthest distance the camera sees', 'm', 0.01, 100.0,
                                source='chosen: past the truss behind the node')

    def __post_init__(self) -> None:
        if len(self.principal_point) != 2:
            raise ParameterError('gripper.camera.principal_point needs 2 values (cx, cy), got '
                                 f'{len(self.principal_point)}')
        if len(self.mount_position) != 3:
            raise ParameterError('gripper.camera.mount_position needs 3 values (x, y, z), got '
                                 f'{len(self.mount_position)}')
        if self.far_clip <= self.near_clip:
            raise ParameterError(f'gripper.camera.far_clip ({self.far_clip} m) must be beyond '
                                 f'near_clip ({self.near_clip} m)')


def optical_frame_name(gripper: str) -> str:
    """Return the TF frame of a gripper's camera (REP 104 optical frame)."""
    return f'camera_{gripper}_optical'


def camera_topic(gripper: str, name: str) -> str:
    """Return a topic of a gripper's camera, relative to the robot's namespace.

    ``name`` is one of :data:`IMAGE`, :data:`CAMERA_INFO`, :data:`TRUE_HOLE`, :data:`HOLE`.
    """
    return f'camera_{gripper}/{name}'


def mount_transform(position, aim_distance: float) -> np.ndarray:
    """Return the optical frame in the gripper's frame (4x4) of a mount.

    The line of sight runs from ``position`` [m] to the point of the gripper's axis
    ``aim_distance`` [m] below the contact point; the image's x axis is horizontal (normal to
    the plane of the axis and the line of sight), so the gripper's axis runs down the image's
    middle column, and the image's top is the side away from the camera.

    Raises
    ------
    ValueError
        If the line of sight would be parallel to the image's x axis (a camera on the axis).
    """
    position = np.asarray(position, dtype=float)
    sight = np.array([0.0, 0.0, -aim_distance]) - position
    sight /= np.linalg.norm(sight)
    radial = np.array([position[0], position[1], 0.0])
    if np.linalg.norm(radial) < 1e-9:
        radial = np.array([1.0, 0.0, 0.0])
    across = np.cross(radial, sight)  # horizontal, normal to the axis-and-sight plane
    if np.linalg.norm(across) < 1e-9:
        raise ValueError('the camera cannot look along its own offset from the axis')
    x_axis = across / np.linalg.norm(across)
    y_axis = np.cross(sight, x_axis)
    transform = np.eye(4)
    transform[:3, 0], transform[:3, 1], transform[:3, 2] = x_axis, y_axis, sight
    transform[:3, 3] = position
    return transform


def mount_rpy(transform: np.ndarray) -> tuple[float, float, float]:
    """Return URDF's fixed-axis roll, pitch, yaw [rad] of a transform's rotation.

    The rotation is ``Rz(yaw) Ry(pitch) Rx(roll)`` (URDF's ``<origin rpy>``).
    """
    r = np.asarray(transform, dtype=float)[:3, :3]
    pitch = math.asin(max(-1.0, min(1.0, -r[2, 0])))
    if abs(r[2, 0]) < 1.0 - 1e-12:
        return (math.atan2(r[2, 1], r[2, 2]), pitch, math.atan2(r[1, 0], r[0, 0]))
    return (math.atan2(-r[1, 2], r[1, 1]), pitch, 0.0)  # gimbal lock: roll takes it all


@dataclasses.dataclass(frozen=True)
class PlumbBob:
    """The calibration a ``sensor_msgs/CameraInfo`` carries (REP 104), row-major lists.

    Attributes
    ----------
    width, height : int
        [px]
    d : list of 5 float
        Distortion (k1, k2, t1, t2, k3): zero, the renderer being a pinhole.
    k : list of 9 float
        The camera matrix.
    r : list of 9 float
        Rectification: the identity (a monocular camera).
    p : list of 12 float
        Projection ``[K | 0]``.
    """

    width: int
    height: int
    d: list[float]
    k: list[float]
    r: list[float]
    p: list[float]


@dataclasses.dataclass(frozen=True)
class CameraModel:
    """A pinhole camera on a gripper: intrinsics and the optical frame in the gripper's frame.

    Attributes
    ----------
    width, height : int
        Image size [px].
    fx, fy, cx, cy : float
        Plumb-bob intrinsics [px].
    mount : ndarray, shape (4, 4)
        The optical frame in the gripper's frame.
    near, far : float
        Clipping distances [m].
    """

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    mount: np.ndarray
    near: float = 0.005
    far: float = 5.0

    @classmethod
    def from_parameters(cls, camera: CameraParameters, mount: np.ndarray | None = None
                        ) -> 'CameraModel':
        """Return the nominal camera of ``gripper.camera.*`` (or the same with another mount)."""
        nominal = mount_transform(camera.mount_position, camera.aim_distance)
        return cls(camera.width, camera.height, camera.focal_length_x, camera.focal_length_y,
                   camera.principal_point[0], camera.principal_point[1],
                   nominal if mount is None else np.asarray(mount, dtype=float),
                   camera.near_clip, camera.far_clip)

    @property
    def matrix(self) -> np.ndarray:
        """The 3x3 camera matrix K."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    def plumb_bob(self) -> PlumbBob:
        """Return the calibration of a ``sensor_msgs/CameraInfo`` (REP 104)."""
        k = self.matrix
        return PlumbBob(self.width, self.height, [0.0] * 5, k.reshape(-1).tolist(),
                        np.eye(3).reshape(-1).tolist(),
                        np.hstack([k, np.zeros((3, 1))]).reshape(-1).tolist())

    @property
    def horizontal_field_of_view(self) -> float:
        """[rad] Angle across the image's width."""
        return 2.0 * math.atan(0.5 * self.width / self.fx)

    def project(self, points_in_gripper) -> np.ndarray:
        """Return the pixels ``(u, v)`` of points [m] given in the gripper's frame, shape (n, 2).

        Points behind the camera come out as NaN.
        """
        points = np.atleast_2d(np.asarray(points_in_gripper, dtype=float))
        rotation, origin = self.mount[:3, :3], self.mount[:3, 3]
        optical = (points - origin) @ rotation
        with np.errstate(divide='ignore', invalid='ignore'):
            u = np.where(optical[:, 2] > 0.0, self.fx * optical[:, 0] / optical[:, 2] + self.cx,
                         np.nan)
            v = np.where(optical[:, 2] > 0.0, self.fy * optical[:, 1] / optical[:, 2] + self.cy,
                         np.nan)
        return np.column_stack([u, v])

    def ray(self, pixel) -> tuple[np.ndarray, np.ndarray]:
        """Return the line of sight of a pixel: origin [m] and unit direction, gripper frame."""
        u, v = float(pixel[0]), float(pixel[1])
        direction = np.array([(u - self.cx) / self.fx, (v - self.cy) / self.fy, 1.0])
        direction = self.mount[:3, :3] @ direction
        return self.mount[:3, 3].copy(), direction / np.linalg.norm(direction)

    def on_plane(self, pixel, depth: float) -> np.ndarray | None:
        """Return where a pixel's line of sight meets the plane ``z = -depth`` [m].

        The plane is normal to the gripper's axis, ``depth`` below its contact point (the node's
        face when the gripper is that high over it). Returns the point ``(x, y, z)`` in the
        gripper's frame, or None if the line of sight never reaches the plane.
        """
        origin, direction = self.ray(pixel)
        if direction[2] >= -1e-12:
            return None
        distance = (-depth - origin[2]) / direction[2]
        return None if distance <= 0.0 else origin + distance * direction

    def metres_per_pixel(self, depth: float) -> float:
        """[m] Size of a pixel on the plane ``z = -depth`` at the image's centre."""
        centre = self.on_plane((self.cx, self.cy), depth)
        beside = self.on_plane((self.cx + 1.0, self.cy), depth)
        if centre is None or beside is None:
            raise ValueError(f'the camera does not see the plane {depth} m below the gripper')
        return float(np.linalg.norm(beside - centre))
