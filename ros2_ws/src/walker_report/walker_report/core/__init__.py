"""ROS-free core of walker_report: no rclpy import anywhere below this package.

Bags are read with :mod:`walker_bag.core.bag_reader` (rosbags), figures drawn with matplotlib's
Agg canvas, the animation rendered with :mod:`walker_sim.core.render` (pybullet's software
renderer) and written with Pillow: nothing needs a display or a running ROS graph.
"""
