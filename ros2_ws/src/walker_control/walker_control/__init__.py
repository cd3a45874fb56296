"""walker_control: Per-joint controllers of the walker (paper sections 2-4).

The ROS-free algorithms live in :mod:`walker_control.core` (plain Python and numpy, tested with
plain pytest); the rclpy nodes beside it only convert messages, parameters and clocks.
"""
