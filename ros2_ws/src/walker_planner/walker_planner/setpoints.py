"""The planner's setpoint publishers, one per joint (ROS layer).

``controllers/<joint>/setpoint`` (walker_msgs/JointCommand; reliable, keep last 10), on the
stream node whose thread paces them; also handed by call to controllers in the same process
(:mod:`walker_control.setpoint_handover`) when a composed graph asks for it.
"""

from __future__ import annotations

from rclpy.node import Node
from walker_msgs.msg import JointCommand

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_planner.conversions import to_time
from walker_runtime.qos import COMMAND_QOS

__all__ = ['SetpointPublishers']


class SetpointPublishers:
    """Publish one setpoint per physical joint, stamped alike.

    The five messages are reused (the caller serialises its calls): building them every
    period cost more than computing the setpoints.
    """

    def __init__(self, node: Node) -> None:
        self._messages = [JointCommand(joint_name=name) for name in PHYSICAL_JOINT_NAMES]
        self._publishers = [node.create_publisher(JointCommand, f'controllers/{name}/setpoint',
                                                  COMMAND_QOS)
                            for name in PHYSICAL_JOINT_NAMES]
        #: also called with each stamp's setpoints, ``sink(stamp, positions, velocities,
        #: accelerations)`` (controllers in this process; None: publishing only)
        self.sink = None

    def send(self, stamp: int, positions, velocities, accelerations) -> None:
        """Publish the setpoints [rad, rad/s, rad/s^2] (physical order), stamped ``stamp`` [ns]."""
        time = to_time(stamp)
        for j, (command, publisher) in enumerate(zip(self._messages, self._publishers,
                                                     strict=True)):
            command.header.stamp = time
            command.position = positions[j]
            command.velocity = velocities[j]
            command.acceleration = accelerations[j]
            publisher.publish(command)
        if self.sink is not None:
            self.sink(stamp, positions, velocities, accelerations)
