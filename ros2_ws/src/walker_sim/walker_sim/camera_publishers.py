"""The wrist cameras' topics of the plant node (ROS layer): images and calibration, when heard.

For each gripper ``g`` whose robot carries cameras (``gripper.camera.enabled``), the plant
publishes ``camera_<g>/image_raw`` (``sensor_msgs/Image``, ``rgb8``) and
``camera_<g>/camera_info`` (``sensor_msgs/CameraInfo``, plumb-bob, REP 104) in the frame
``camera_<g>_optical``, at ``sim.camera.frame_rate`` of plant time, and only while a
subscriber listens to the image: a frame is rendered for nobody else (its cost:
docs/perception.md). Each message is stamped with the frame's exposure, the instant it shows.
A robot without cameras gets no publisher at all.
"""

from __future__ import annotations

from rclpy.node import Node
from sensor_msgs.msg import CameraInfo, Image

from walker_core.camera import PLUMB_BOB, CameraModel, optical_frame_name
from walker_core.joint_roles import GRIPPERS
from walker_runtime.listened import ListenedPublisher
from walker_sim.core.outputs import StampedRate
from walker_sim.core.wrist_camera import CameraFrame
from walker_sim.messages import SENSOR_QOS, time_msg

__all__ = ['CameraPublishers', 'image_msg', 'camera_info_msg', 'image_topic', 'info_topic']


def image_topic(gripper: str) -> str:
    """Return a gripper's image topic (relative: in the robot's namespace)."""
    return f'camera_{gripper}/image_raw'


def info_topic(gripper: str) -> str:
    """Return a gripper's camera calibration topic (relative)."""
    return f'camera_{gripper}/camera_info'


def image_msg(frame: CameraFrame, stamp: int) -> Image:
    """``sensor_msgs/Image`` of a frame (``rgb8``, rows top first), stamped [ns]."""
    rows, columns, _ = frame.image.shape
    message = Image(height=rows, width=columns, encoding='rgb8', is_bigendian=0,
                    step=3 * columns)
    message.header.stamp = time_msg(stamp)
    message.header.frame_id = optical_frame_name(frame.gripper)
    message.data = frame.image.tobytes()
    return message


def camera_info_msg(model: CameraModel, gripper: str, stamp: int) -> CameraInfo:
    """``sensor_msgs/CameraInfo`` of the camera's model, stamped [ns]."""
    calibration = model.plumb_bob()
    message = CameraInfo(height=calibration.height, width=calibration.width,
                         distortion_model=PLUMB_BOB)
    message.header.stamp = time_msg(stamp)
    message.header.frame_id = optical_frame_name(gripper)
    message.d = calibration.d
    message.k = calibration.k
    message.r = calibration.r
    message.p = calibration.p
    return message


class CameraPublishers:
    """The cameras' publishers of a plant node, or none when the robot has no camera.

    Parameters
    ----------
    node : Node
    params : WalkerParameters
        The model: ``gripper.camera.*``.
    frame_rate : float
        [Hz] Frames per second of plant time while heard (``sim.camera.frame_rate``).
    """

    def __init__(self, node: Node, params, frame_rate: float) -> None:
        camera = params.gripper.camera
        self._model = CameraModel.from_parameters(camera) if camera.enabled else None
        self._rate = StampedRate(frame_rate)
        self._images: dict[str, ListenedPublisher] = {}
        self._infos = {}
        if self._model is None:
            return
        for gripper in GRIPPERS:
            self._images[gripper] = ListenedPublisher(
                node.create_publisher(Image, image_topic(gripper), SENSOR_QOS))
            self._infos[gripper] = node.create_publisher(CameraInfo, info_topic(gripper),
                                                         SENSOR_QOS)

    def publish(self, plant, stamp: int) -> None:
        """Render and publish the heard cameras' frames when due at ``stamp`` [ns]."""
        heard = [g for g, publisher in self._images.items() if publisher.heard]
        if not heard or not self._rate.due(stamp):
            return
        for gripper in heard:
            self._images[gripper].publish(image_msg(plant.camera_frame(gripper), stamp))
            self._infos[gripper].publish(camera_info_msg(self._model, gripper, stamp))
