"""walker_core: the walker robot model that every package shares, free of ROS.

Modules: :mod:`~walker_core.parameter_schema` (typed sections of the parameter file),
:mod:`~walker_core.robot_parameters` (the robot, truss and gripper sections),
:mod:`~walker_core.joint_roles` (physical joints and their roles J1..J5),
:mod:`~walker_core.kinematics` (eqs (1)-(7)), :mod:`~walker_core.dynamics` (eqs (9)-(13)),
:mod:`~walker_core.truss` (the truss grid), :mod:`~walker_core.urdf` (the robot as URDF,
generated from the parameters). No module here imports rclpy or a message package (a global
test checks it): the ROS layer every node shares is the ``walker_runtime`` package.
"""
