"""Conversions between the plant core's state and ROS messages; the plant's QoS profiles.

No node here: plain functions that the plant node calls, so that the node's callbacks stay one
line of conversion and one call into the core. The QoS profiles are those of
:mod:`walker_runtime.qos`, the same for every node.
"""

from __future__ import annotations

from builtin_interfaces.msg import Time
from geometry_msgs.msg import PointStamped, PoseStamped
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState

from walker_core.joint_roles import GRIPPERS, PHYSICAL_JOINT_NAMES
from walker_core.urdf import GRIPPER_LINKS
from walker_runtime.qos import CLOCK_QOS, COMMAND_QOS, LATCHED_QOS, SENSOR_QOS
from walker_msgs.msg import GripperState, GripperStates, JointAccelerations
from walker_sim.core.plant import GripperReport, PlantState, Pose

__all__ = [
    'SENSOR_QOS', 'COMMAND_QOS', 'LATCHED_QOS', 'CLOCK_QOS', 'TRUSS_FRAME', 'time_msg',
    'stamp_ns', 'joint_state_msg', 'flexible_joint_state_msg', 'accelerations_msg', 'pose_msg',
    'gripper_state_msg', 'gripper_states_msg', 'clock_msg', 'true_hole_msg',
]

#: Frame of every pose the plant publishes: the truss (world) frame.
TRUSS_FRAME = 'truss'

_NS_PER_S = 1_000_000_000


def time_msg(nanoseconds: int) -> Time:
    """``builtin_interfaces/Time`` of a time in integer nanoseconds."""
    seconds, rest = divmod(int(nanoseconds), _NS_PER_S)
    return Time(sec=seconds, nanosec=rest)


def stamp_ns(stamp: Time) -> int:
    """Integer nanoseconds of a ``builtin_interfaces/Time``."""
    return stamp.sec * _NS_PER_S + stamp.nanosec


def joint_state_msg(state: PlantState, stamp: int) -> JointState:
    """``sensor_msgs/JointState`` of the five actuated joints (effort = applied torque)."""
    message = JointState()
    message.header.stamp = time_msg(stamp)
    message.name = list(PHYSICAL_JOINT_NAMES)
    message.position = state.position.tolist()
    message.velocity = state.velocity.tolist()
    message.effort = state.effort.tolist()
    return message


def flexible_joint_state_msg(state: PlantState, bend_names: list[str], bending,
                             stamp: int) -> JointState:
    """``sensor_msgs/JointState`` of every joint the plant simulates, angles [rad] only.

    The five actuated joints, then the passive bending joints (``bending``, named
    ``bend_names``), named and signed as the plant view of :mod:`walker_core.urdf` rooted at
    gripper a (:func:`walker_core.urdf.flex_joints`), whichever body the physics is rooted at.
    """
    message = JointState()
    message.header.stamp = time_msg(stamp)
    message.name = [*PHYSICAL_JOINT_NAMES, *bend_names]
    message.position = [*state.position.tolist(), *(float(a) for a in bending)]
    return message


def accelerations_msg(state: PlantState, stamp: int) -> JointAccelerations:
    """``walker_msgs/JointAccelerations`` of the five actuated joints."""
    message = JointAccelerations()
    message.header.stamp = time_msg(stamp)
    message.name = list(PHYSICAL_JOINT_NAMES)
    message.acceleration = state.acceleration.tolist()
    return message


def pose_msg(pose: Pose, stamp: int) -> PoseStamped:
    """``geometry_msgs/PoseStamped`` in the truss frame."""
    message = PoseStamped()
    message.header.stamp = time_msg(stamp)
    message.header.frame_id = TRUSS_FRAME
    position, orientation = message.pose.position, message.pose.orientation
    position.x, position.y, position.z = (float(v) for v in pose.position)
    orientation.x, orientation.y, orientation.z, orientation.w = (
        float(v) for v in pose.orientation)
    return message


def gripper_state_msg(report: GripperReport) -> GripperState:
    """``walker_msgs/GripperState`` of one gripper."""
    status, alignment = report.status, report.alignment
    return GripperState(name=status.name, state=status.mode.code,
                        node=status.node, position_error=alignment.position_error,
                        axis_error=alignment.axis_error, message=status.message)


def gripper_states_msg(state: PlantState, stamp: int) -> GripperStates:
    """``walker_msgs/GripperStates``: both grippers (a, b).

    Not which of them is the base: the supervisor decides that (``phase``, ``control_mode``);
    the body the plant roots its physics at (``PlantState.base``) is the simulator's own.
    """
    message = GripperStates()
    message.header.stamp = time_msg(stamp)
    message.grippers = [gripper_state_msg(state.grippers[g]) for g in GRIPPERS]
    return message


def clock_msg(stamp: int) -> Clock:
    """``rosgraph_msgs/Clock`` of a time in integer nanoseconds."""
    return Clock(clock=time_msg(stamp))


def true_hole_msg(frame, stamp: int) -> PointStamped:
    """``camera_<g>/true_hole`` of a wrist camera's frame, stamped ``stamp`` [ns]: the truth.

    Where the hole nearest the gripper's axis really is at the frame's instant
    (:attr:`~walker_sim.core.wrist_camera.CameraFrame.mouth_in_gripper`), in the gripper's frame
    ``gripper_<g>`` [m]: what the simulation knows and a camera's user does not, published as
    the true gripper poses are, for a report or a test to compare a measurement with.
    """
    message = PointStamped()
    message.header.stamp = time_msg(stamp)
    message.header.frame_id = GRIPPER_LINKS[frame.gripper]
    message.point.x, message.point.y, message.point.z = (
        float(v) for v in frame.mouth_in_gripper)
    return message

