"""ROS-free core of walker_viz: no rclpy import anywhere below this package.

Modules: :mod:`~walker_viz.core.robot_tree` (the TF tree of the URDF from the joint angles),
:mod:`~walker_viz.core.base_anchor` (which gripper holds the truss, where, and so where the
tree sits in the truss frame), :mod:`~walker_viz.core.markers` (truss, target and planned tip
path markers) and :mod:`~walker_viz.core.parameters` (the ``viz`` section of the parameter
file). Lengths in m, angles in rad, poses as 4x4 homogeneous matrices.
"""
