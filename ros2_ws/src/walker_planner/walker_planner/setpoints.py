"""What the planner sends the controllers: setpoints, one topic per joint, or whole trajectories.

* ``controllers/<joint>/setpoint`` (walker_msgs/JointCommand; reliable, keep last 10), on the
  stream node whose thread paces them; also handed by call to controllers in the same process
  (:mod:`walker_control.setpoint_handover`) when a composed graph asks for it;
* ``controllers/joint_trajectory`` (trajectory_msgs/JointTrajectory; reliable, keep last 10),
  one message per trajectory (``planner.send_whole_trajectories``).
"""

from __future__ import annotations

from rclpy.duration import Duration
from rclpy.node import Node
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
from walker_msgs.msg import JointCommand

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_planner.conversions import to_duration, to_time
from walker_planner.core.streaming import SampledTrajectory
from walker_runtime.qos import COMMAND_QOS

__all__ = ['SetpointPublishers', 'TrajectoryPublisher', 'ACK_WAIT']

#: [s] wall time a whole trajectory waits to be acknowledged by every subscriber
ACK_WAIT = 1.0


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


class TrajectoryPublisher:
    """Publish whole trajectories on ``controllers/joint_trajectory``, once each.

    Reliable, keep last 10 (``COMMAND_QOS``, the controllers' subscription): a trajectory is
    sent once and followed to its end, so it must not be dropped as a setpoint could be; the
    controllers sample even a late one at its own time (joint_trajectory_controller's
    contract, ``walker_control.core.trajectory_follower``). Each is waited for until every
    matched subscriber has acknowledged it (:data:`ACK_WAIT` at most, and a warning after
    that): sent before the goal's acceptance, which a sim-time supervisor holds the clock for,
    it is then in the controllers' readers before their next state. A controller not matched
    yet (just started) does not get it: volatile, as joint_trajectory_controller's topic.
    """

    def __init__(self, node: Node) -> None:
        self._publisher = node.create_publisher(JointTrajectory, 'controllers/joint_trajectory',
                                                COMMAND_QOS)
        self._logger = node.get_logger()

    def send(self, start: int, trajectory: SampledTrajectory) -> None:
        """Publish ``trajectory`` (physical order) whose time 0 applies at ``start`` [ns].

        Points carry velocities and accelerations only when the trajectory has them: with
        positions only the controllers interpolate linearly, as the stream does.
        """
        count = len(trajectory.times)
        velocities = trajectory.velocities if trajectory.velocities is not None \
            else [()] * count
        accelerations = trajectory.accelerations \
            if trajectory.accelerations is not None and trajectory.velocities is not None \
            else [()] * count
        message = JointTrajectory(joint_names=list(PHYSICAL_JOINT_NAMES))
        message.header.stamp = to_time(start)
        message.points = [
            JointTrajectoryPoint(positions=list(map(float, p)), velocities=list(map(float, v)),
                                 accelerations=list(map(float, a)),
                                 time_from_start=to_duration(float(t)))
            for t, p, v, a in zip(trajectory.times, trajectory.positions, velocities,
                                  accelerations, strict=True)]
        self._publisher.publish(message)
        if not self._publisher.wait_for_all_acked(Duration(seconds=ACK_WAIT)):
            self._logger.warning(f'a trajectory was not acknowledged by every subscriber of '
                                 f'controllers/joint_trajectory within {ACK_WAIT:g} s')
