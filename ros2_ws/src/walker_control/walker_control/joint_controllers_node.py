"""rclpy node of several joints' controllers in one process: one state in, one effort out.

The five joint controllers of ``joint_controller_node``, or any of them, in one node (as
ros2_control's controller manager runs its controllers in one process)::

    ros2 run walker_control joint_controllers_node --ros-args -r __ns:=/walker
        -r __node:=controllers --params-file walker.yaml      (one command line)

``joint_names`` (default: all five physical joints) chooses the joints. Each joint's controller
is the same core with the same parameters, setpoint topic, state topic, watchdog and fault
handling as in a node of its own; what the joints share is the node's ``joint_states``,
``joint_accelerations`` and ``control_mode`` subscriptions, and its answer: one
``effort_commands`` message (``sensor_msgs/JointState``) naming every joint, stamped with the
state it answers. Per control period the graph then carries two messages through the loop
instead of six, and one process is woken instead of five. The price is the isolation: a joint
controller that dies takes the other joints' with it (the plant's drive watchdogs then hold
every joint, and the supervisor holds the walk, as for one dead controller).

Topics (relative to the namespace; QoS as in docs/architecture.md) are those of
``joint_controller_node`` for each joint of the node. In a composed sim-time graph the plant
hands it the states by call (``answer_plant_directly``), and the planner's stream its
setpoints (:meth:`JointControllersNode.take_setpoints_by_call`): those subscriptions are then
gone.
"""

from __future__ import annotations

import sys

from rcl_interfaces.msg import ParameterDescriptor, ParameterType

from sensor_msgs.msg import JointState

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_control.joint_controller_node import ControllerNode, run_controller_node
from walker_control.setpoint_handover import SetpointHandover

__all__ = ['JointControllersNode', 'DEFAULT_NODE_NAME', 'main']

#: The node's name unless remapped.
DEFAULT_NODE_NAME = 'controllers'


class JointControllersNode(ControllerNode):
    """The controllers of the joints ``joint_names`` in one node (see the module docstring).

    Raises
    ------
    ValueError
        If ``joint_names`` is empty, names a joint twice or a joint the walker has not.
    ParameterError
        If the parameters are invalid or fail the stability check (refuses to start).
    """

    _joints_parameter = 'joint_names'

    def __init__(self, node_name: str = DEFAULT_NODE_NAME, **kwargs) -> None:
        super().__init__(node_name, **kwargs)
        self._setpoint_handover: SetpointHandover | None = None

    def take_setpoints_by_call(self) -> SetpointHandover:
        """Take the setpoints of a planner in this process by call; return where it sends them.

        Only with the states by call (:meth:`answer_plant_directly`: sim time, the plant in
        this process). The planner's stream sends to the returned handover's ``push``
        (:mod:`walker_control.setpoint_handover`); the ``controllers/<joint>/setpoint``
        subscriptions are destroyed (their messages would be the same setpoints again).

        Raises
        ------
        ValueError
            When the states do not come by call.
        """
        if self._states is not None:
            raise ValueError('setpoints are taken by call only with the states by call '
                             '(answer_plant_directly)')
        guard = self.create_guard_condition(self.take_handed_setpoints)
        self._setpoint_handover = SetpointHandover(self.joints, guard.trigger)
        for channel in self._channels:
            channel.setpoint_subscription.destroy()
        return self._setpoint_handover

    def take_handed_setpoints(self) -> None:
        """Take the setpoints handed over since the last state; answer a state waiting for them.

        The guard condition a push from another thread triggers calls it (a stream started
        by the planner's action thread reaches a state that waits for its first setpoints).
        """
        if self._take_queued_setpoints():
            self._answer_waiting_state()

    def take_state(self, msg: JointState) -> None:
        """Answer a joint state handed over by the plant, the setpoints handed over first."""
        self._take_queued_setpoints()
        super().take_state(msg)

    def _take_queued_setpoints(self) -> int:
        handover = self._setpoint_handover
        return 0 if handover is None else handover.take_into(self._take_setpoint)

    def _take_setpoint(self, index: int, stamp: float, position: float, velocity: float,
                       acceleration: float) -> None:
        self._channels[index].take_setpoint_values(stamp, position, velocity, acceleration)

    def _declare_joints(self) -> list[str]:
        return list(self.declare_parameter(
            'joint_names', list(PHYSICAL_JOINT_NAMES), ParameterDescriptor(
                type=ParameterType.PARAMETER_STRING_ARRAY,
                description='physical joints this node drives, each once (of: '
                            + ', '.join(PHYSICAL_JOINT_NAMES) + ')', read_only=True)).value
                    or ())  # an empty list arrives as no value


def main(args: list[str] | None = None) -> int:
    """Run the joints' controllers until interrupted; exit code 2 when they refuse to start."""
    return run_controller_node(JointControllersNode, DEFAULT_NODE_NAME,
                               sys.argv if args is None else args)


if __name__ == '__main__':
    sys.exit(main())
