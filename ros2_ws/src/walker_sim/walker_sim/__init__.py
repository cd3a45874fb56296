"""walker_sim: The pybullet plant of the walker: the simulator that stands in for the hardware.

The ROS-free algorithms live in :mod:`walker_sim.core` (plain Python and numpy, tested with
plain pytest); the rclpy nodes beside it only convert messages, parameters and clocks.
"""
