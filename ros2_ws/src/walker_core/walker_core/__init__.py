"""walker_core: the walker robot model that every package shares, free of ROS.

Modules: :mod:`~walker_core.parameter_schema` (typed sections of the parameter file),
:mod:`~walker_core.robot_parameters` (the robot, truss and gripper sections),
:mod:`~walker_core.joint_roles` (physical joints and their roles J1..J5),
:mod:`~walker_core.kinematics` (eqs (1)-(7)), :mod:`~walker_core.dynamics` (eqs (9)-(13)),
:mod:`~walker_core.truss` (the truss grid), :mod:`~walker_core.urdf` (the robot as URDF,
generated from the parameters). Only :mod:`~walker_core.node_parameters` imports rclpy: it
declares the sections on a node.
"""
