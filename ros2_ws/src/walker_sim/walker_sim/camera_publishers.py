"""The wrist cameras' topics and triggers of the plant node (ROS layer): frames on request.

For each gripper ``g`` whose robot carries cameras (``gripper.camera.enabled``), the plant
serves ``camera_<g>/trigger`` (``std_srvs/srv/Trigger``) and publishes ``camera_<g>/image_raw``
(``sensor_msgs/Image``, ``rgb8``) and ``camera_<g>/camera_info`` (``sensor_msgs/CameraInfo``,
plumb-bob, REP 104) in the frame ``camera_<g>_optical``, with the simulation's truth of each frame
on ``camera_<g>/true_hole`` (``geometry_msgs/PointStamped``: where the hole really is, in the
gripper's frame, :func:`~walker_sim.messages.true_hole_msg`). A trigger is answered at once; the
frame is exposed at the plant's next published state (in sim time inside the lock-step, so it
shows the plant at a step) and rendered by the cameras' render process while the plant steps
on (:meth:`walker_sim.core.plant.WalkerPlant.expose_camera`). Image, calibration and truth are
sent, stamped with the exposure (the instant the image shows), at the first state at or after
the frame's ``ready_time`` (its exposure latency later) once its render is done: in sim time
the plant waits for the render there; in real time it never waits, and the frame goes out at
the first state its render is done by (:mod:`walker_sim.core.frame_delivery`). Streaming is
opt-in: with ``sim.camera.frame_rate`` above 0 a frame is also exposed at that rate of plant
time while a subscriber listens to the image; at 0 (the default) a frame is rendered only when
triggered, for a frame costs hundreds of control periods of rendering (docs/perception.md). A
robot without cameras gets no publisher and no service at all.
"""

from __future__ import annotations

from functools import partial

from geometry_msgs.msg import PointStamped
from rclpy.node import Node
from sensor_msgs.msg import CameraInfo, Image
from std_srvs.srv import Trigger

from walker_core.camera import PLUMB_BOB, TRUE_HOLE, CameraModel, camera_topic, optical_frame_name
from walker_core.joint_roles import GRIPPERS
from walker_runtime.listened import ListenedPublisher
from walker_runtime.qos import IMAGE_QOS, LOOK_IMAGE_QOS
from walker_sim.core.frame_delivery import FrameDelivery
from walker_sim.core.outputs import StampedRate
from walker_sim.core.wrist_camera import CameraFrame
from walker_sim.messages import time_msg, true_hole_msg

__all__ = ['CameraPublishers', 'image_msg', 'camera_info_msg', 'image_topic', 'info_topic',
           'trigger_service']


def image_topic(gripper: str) -> str:
    """Return a gripper's image topic (relative: in the robot's namespace)."""
    return f'camera_{gripper}/image_raw'


def info_topic(gripper: str) -> str:
    """Return a gripper's camera calibration topic (relative)."""
    return f'camera_{gripper}/camera_info'


def trigger_service(gripper: str) -> str:
    """Return the service that asks a gripper's camera for one frame (relative)."""
    return f'camera_{gripper}/trigger'


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
    """The cameras' publishers and triggers of a plant node, or none without cameras.

    Parameters
    ----------
    node : Node
    params : WalkerParameters
        The model: ``gripper.camera.*``.
    sim : SimParameters
        ``sim.camera.frame_rate`` [Hz]: frames per second of plant time while heard (0: a
        frame only when triggered); ``sim.clock_mode``: in ``sim_time`` (lock-step) a frame
        due is waited for, in ``real_time`` never.
    """

    def __init__(self, node: Node, params, sim) -> None:
        camera, frame_rate = params.gripper.camera, sim.camera.frame_rate
        self._model = CameraModel.from_parameters(camera) if camera.enabled else None
        self._rate = StampedRate(frame_rate) if frame_rate > 0.0 else None
        self._images: dict[str, ListenedPublisher] = {}
        self._infos = {}
        self._truths = {}
        self._asked: set[str] = set()  # triggered, exposed at the next published state
        self._exposed = FrameDelivery(wait_for_renders=sim.clock_mode == 'sim_time')
        if self._model is None:
            return
        for gripper in GRIPPERS:
            self._images[gripper] = ListenedPublisher(
                node.create_publisher(Image, image_topic(gripper), LOOK_IMAGE_QOS))
            self._infos[gripper] = node.create_publisher(CameraInfo, info_topic(gripper),
                                                         IMAGE_QOS)
            self._truths[gripper] = node.create_publisher(
                PointStamped, camera_topic(gripper, TRUE_HOLE), IMAGE_QOS)
            node.create_service(Trigger, trigger_service(gripper),
                                partial(self._on_trigger, gripper))

    def _on_trigger(self, gripper: str, request: Trigger.Request,
                    response: Trigger.Response) -> Trigger.Response:
        """Take a trigger: one frame of ``gripper``'s camera at the next published state."""
        self._asked.add(gripper)
        response.success = True
        response.message = f'a frame of camera {gripper} comes at the next plant step'
        return response

    def publish(self, plant, stamp: int) -> None:
        """Expose the frames asked for or due at ``stamp`` [ns]; send those due by then."""
        asked, self._asked = self._asked, set()
        if self._rate is not None:
            heard = [g for g, publisher in self._images.items() if publisher.heard]
            if heard and self._rate.due(stamp):
                asked.update(heard)
        for gripper in sorted(asked):
            self._exposed.add(plant.expose_camera(gripper), stamp)
        if not self._exposed:
            return
        for exposure, frame in self._exposed.due(stamp):
            self._images[frame.gripper].publisher.publish(image_msg(frame, exposure))
            self._infos[frame.gripper].publish(camera_info_msg(self._model, frame.gripper,
                                                               exposure))
            self._truths[frame.gripper].publish(true_hole_msg(frame, exposure))
