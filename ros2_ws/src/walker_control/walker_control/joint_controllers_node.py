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
``joint_controller_node`` for each joint of the node.
"""

from __future__ import annotations

import sys

from rcl_interfaces.msg import ParameterDescriptor, ParameterType

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_control.joint_controller_node import ControllerNode, run_controller_node

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
