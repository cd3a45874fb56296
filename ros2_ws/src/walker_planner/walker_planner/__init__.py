"""walker_planner: Trajectory planner of the walker (paper section 5).

The ROS-free algorithms live in :mod:`walker_planner.core` (plain Python and numpy, tested with
plain pytest); the rclpy nodes beside it only convert messages, parameters and clocks.
"""
