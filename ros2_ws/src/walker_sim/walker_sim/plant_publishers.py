"""The plant node's publishers and the messages it sends on them (ROS layer).

What is published when is decided by the node and :mod:`walker_sim.core.outputs`; this module
only owns the publishers, with their QoS (:mod:`walker_runtime.qos`), and converts the plant's
state into messages (:mod:`walker_sim.messages`).
"""

from __future__ import annotations

from collections.abc import Mapping

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from rosgraph_msgs.msg import Clock as ClockMsg
from sensor_msgs.msg import JointState
from std_msgs.msg import String

from walker_core.joint_roles import GRIPPERS
from walker_core.robot_parameters import WalkerParameters
from walker_core.urdf import description_urdf, flex_joints
from walker_runtime.listened import ListenedPublisher
from walker_msgs.msg import GripperStates, JointAccelerations
from walker_sim.core.plant import PlantState
from walker_sim.messages import (
    CLOCK_QOS, LATCHED_QOS, SENSOR_QOS, accelerations_msg, clock_msg, flexible_joint_state_msg,
    gripper_states_msg, joint_state_msg, pose_msg, time_msg)

__all__ = ['PlantPublishers']


class PlantPublishers:
    """Every topic the plant node publishes: its namespace's, ``/clock`` and ``/diagnostics``.

    Parameters
    ----------
    node : Node
    params : WalkerParameters
        The model: the URDF of ``robot_description`` and the links' bending joints.
    sim_time : bool
        Whether ``/clock`` is published.
    """

    def __init__(self, node: Node, params: WalkerParameters, sim_time: bool) -> None:
        self._node = node
        create = node.create_publisher
        # sent only while subscribed (walker_runtime.listened): the controllers of a
        # composed graph take them by call, and often nobody else listens
        self._accelerations = ListenedPublisher(
            create(JointAccelerations, 'joint_accelerations', SENSOR_QOS))
        self._joint_states = create(JointState, 'joint_states', SENSOR_QOS)
        self._flexible = create(JointState, 'flexible_joint_states', SENSOR_QOS)
        self._bend_names = [joint.name for joint in flex_joints(
            params.robot.flexibility.segments_per_link)]
        self._poses = {name: ListenedPublisher(create(PoseStamped, name, SENSOR_QOS))
                       for name in ('tip_pose', 'gripper_a_pose', 'gripper_b_pose')}
        self._grippers = create(GripperStates, 'gripper_states', LATCHED_QOS)
        self._description = create(String, 'robot_description', LATCHED_QOS)
        self._diagnostics = create(DiagnosticArray, '/diagnostics', 10)
        self._clock = create(ClockMsg, '/clock', CLOCK_QOS) if sim_time else None
        self._description.publish(String(data=description_urdf(params)))

    def clock(self, stamp: int) -> None:
        """Publish ``/clock`` at ``stamp`` [ns] (sim time only)."""
        if self._clock is not None:
            self._clock.publish(clock_msg(stamp))

    def state(self, state: PlantState, stamp: int) -> tuple:
        """Publish ``joint_accelerations`` then ``joint_states`` of ``state``, stamped [ns].

        Returns both messages (the controllers in this process take them by call).
        """
        accelerations = accelerations_msg(state, stamp)
        joint_states = joint_state_msg(state, stamp)
        self._accelerations.publish(accelerations)
        self._joint_states.publish(joint_states)
        return accelerations, joint_states

    def poses(self, state: PlantState, bending, stamp: int) -> None:
        """Publish the tip's and the grippers' poses and ``flexible_joint_states`` [ns].

        A pose nobody subscribes to is not built (nor is ``joint_accelerations`` sent).
        """
        if self._poses['tip_pose'].heard:
            self._poses['tip_pose'].publish(pose_msg(state.poses[state.tip], stamp))
        self._flexible.publish(flexible_joint_state_msg(state, self._bend_names, bending,
                                                        stamp))
        for gripper in GRIPPERS:
            publisher = self._poses[f'gripper_{gripper}_pose']
            if publisher.heard:  # built only for a subscriber (walker_runtime.listened)
                publisher.publish(pose_msg(state.poses[gripper], stamp))

    def grippers(self, state: PlantState, stamp: int) -> None:
        """Publish ``gripper_states`` of ``state``, stamped [ns]."""
        self._grippers.publish(gripper_states_msg(state, stamp))

    def diagnostics(self, sim, time: float, lockstep, gate, counts: Mapping[str, int],
                    longest_tick_interval: float | None, stamp: int) -> None:
        """Publish the plant's ``/diagnostics`` status, stamped ``stamp`` [ns].

        Missed command periods per joint (WARN when any), expired, refused and clamped
        commands (``counts``), lock-step and decision-gate timeouts, the controllers not waited
        for, and in real time the longest wall time between two ticks [s] since the loop
        closed.
        """
        missed = sum(lockstep.missed.values())
        values = {f'missed {joint}': count for joint, count in lockstep.missed.items()}
        values.update({f'{name} commands': count for name, count in counts.items()})
        values['lock-step timeouts'] = lockstep.timeouts
        if sim.wait_for_decisions:
            values['supervisor gate timeouts'] = gate.timeouts
        values['not waited for'] = ', '.join(sorted(lockstep.lost))
        if longest_tick_interval is not None:
            values['longest tick interval [ms]'] = f'{longest_tick_interval * 1e3:.1f}'
        status = DiagnosticStatus(
            name=f'{self._node.get_fully_qualified_name()}: plant', hardware_id='walker_sim',
            message=f'{sim.clock_mode}, t={time:.3f} s, {missed} missed command periods',
            level=DiagnosticStatus.OK if missed == 0 else DiagnosticStatus.WARN)
        status.values = [KeyValue(key=k, value=str(v)) for k, v in values.items()]
        array = DiagnosticArray(status=[status])
        array.header.stamp = time_msg(stamp)
        self._diagnostics.publish(array)
