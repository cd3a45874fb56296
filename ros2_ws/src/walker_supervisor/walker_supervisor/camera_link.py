"""The supervisor's link to the plant's wrist cameras (ROS layer of the walk runner's looks).

:class:`CameraLink` carries out :class:`~walker_supervisor.core.commands.LookRequest`: it calls
the gripper's ``camera_<g>/trigger`` (``std_srvs/srv/Trigger``) and hands the first image of
that gripper's ``camera_<g>/image_raw`` stamped at or after the look's ``since`` to
:meth:`~walker_supervisor.core.runner.WalkRunner.frame_seen`; the commands it gives back are
carried out as every answer's (which frame answers which request:
:class:`~walker_supervisor.core.awaited_frames.AwaitedFrames`). A trigger whose service is not
discovered, a frame lost or one that never comes cost nothing here: the runner goes on blind after
:data:`~walker_supervisor.core.looking.LOOK_WAIT`, and the look is forgotten then. A robot
without cameras (``gripper.camera.enabled`` false) has neither subscription nor client.

Each frame that showed the hole (the runner's :class:`~walker_supervisor.core.commands.
HoleSighted`) is published on ``camera_<g>/hole`` (``geometry_msgs/PointStamped``, stamped with
the frame's exposure, in the gripper's frame ``gripper_<g>``: x, y the hole's axis from the
gripper's axis as that frame measured it, z the face's height the step assumed), beside the
plant's ``camera_<g>/true_hole`` of the same stamp, reliable, keep last 1.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from geometry_msgs.msg import PointStamped
from rclpy.node import Node
from sensor_msgs.msg import Image
from std_srvs.srv import Trigger

from walker_core.camera import HOLE, IMAGE, camera_topic
from walker_core.joint_roles import GRIPPERS
from walker_runtime.qos import IMAGE_QOS, LOOK_IMAGE_QOS
from walker_supervisor.clocks import Clocks
from walker_supervisor.core.awaited_frames import AwaitedFrames
from walker_supervisor.core.commands import HoleSighted, LookRequest
from walker_supervisor.core.runner import WalkRunner
from walker_supervisor.messages import hole_message, seconds, stamp_nanoseconds

__all__ = ['CameraLink', 'image_array', 'RGB8']

#: The one image encoding the hole finder takes.
RGB8 = 'rgb8'


def image_array(message: Image) -> np.ndarray:
    """Return an ``rgb8`` ``sensor_msgs/Image`` as an array (height, width, 3) of uint8.

    Rows may be padded (``step`` beyond three bytes a pixel); the padding is dropped.

    Raises
    ------
    ValueError
        If the encoding is not ``rgb8``, or the data does not fill ``height`` rows of ``step``
        bytes.
    """
    if message.encoding != RGB8:
        raise ValueError(f'image encoding {message.encoding!r} is not {RGB8!r}')
    height, width, step = message.height, message.width, message.step
    if step < 3 * width or len(message.data) < height * step:
        raise ValueError(f'image of {len(message.data)} bytes is not {height} rows of {step} '
                         f'bytes for {width} rgb8 pixels')
    rows = np.frombuffer(message.data, dtype=np.uint8, count=height * step).reshape(height, step)
    return rows[:, :3 * width].reshape(height, width, 3)


class CameraLink:
    """The cameras' triggers and images; each look's frame goes to ``runner``.

    Parameters
    ----------
    node : Node
    runner : WalkRunner
    clocks : Clocks
        ``now``: the graph's clock, the frames' stamps' clock.
    answer : callable
        Carries out the commands the runner gives back for a frame.
    enabled : bool
        The grippers carry cameras (``gripper.camera.enabled``).
    """

    def __init__(self, node: Node, runner: WalkRunner, clocks: Clocks,
                 answer: Callable[[list], None], enabled: bool) -> None:
        self._node, self._runner, self._clocks, self._answer = node, runner, clocks, answer
        self._triggers = {}
        self._holes = {}
        self._awaited = AwaitedFrames(GRIPPERS)
        if not enabled:
            return
        for gripper in GRIPPERS:
            self._triggers[gripper] = node.create_client(Trigger, f'camera_{gripper}/trigger')
            node.create_subscription(Image, camera_topic(gripper, IMAGE),
                                     lambda message, g=gripper: self._on_image(g, message),
                                     LOOK_IMAGE_QOS)
            self._holes[gripper] = node.create_publisher(
                PointStamped, camera_topic(gripper, HOLE), IMAGE_QOS)

    def handles(self, command) -> bool:
        """Return True for a command this object carries out."""
        return isinstance(command, (LookRequest, HoleSighted))

    def execute(self, command: LookRequest | HoleSighted) -> None:
        """Trigger the gripper's camera and wait for its frame (or for nothing: see above).

        A :class:`HoleSighted` is published on ``camera_<g>/hole``.
        """
        if isinstance(command, HoleSighted):
            publisher = self._holes.get(command.gripper)
            if publisher is not None:
                publisher.publish(hole_message(command))
            return
        client = self._triggers.get(command.gripper)
        if client is None:
            self._node.get_logger().warning(
                f'look with the camera of gripper {command.gripper} not taken: the robot has no '
                'such camera (gripper.camera.enabled)')
            return
        if not client.service_is_ready():
            self._node.get_logger().warning(
                f'look with the camera of gripper {command.gripper} not taken: the plant '
                f'{client.srv_name} service is not available')
            return
        self._awaited.asked(command.gripper, round(command.since * 1e9))
        client.call_async(Trigger.Request()).add_done_callback(
            lambda future, g=command.gripper: self._triggered(g, future))

    def _triggered(self, gripper: str, future) -> None:
        response = future.result()
        if response is None or not response.success:
            self._node.get_logger().warning(
                f'the camera of gripper {gripper} refused a frame: '
                f'{"no response" if response is None else response.message}')

    def _on_image(self, gripper: str, message: Image) -> None:
        """Hand the frame the oldest request awaits to the runner; ignore every other."""
        now = self._clocks.now()
        if not self._awaited.answers(gripper, stamp_nanoseconds(message.header.stamp), now):
            return
        try:
            image = image_array(message)
        except ValueError as error:
            self._node.get_logger().warning(
                f'frame of the camera of gripper {gripper} refused: {error}')
            return
        self._answer(self._runner.frame_seen(gripper, image, seconds(message.header.stamp),
                                             now))
