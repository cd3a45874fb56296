"""walker_teleop: ``walkerctl``, the operator's command-line tool for a running walker.

The ROS-free part (:mod:`walker_teleop.core`) turns what the graph publishes into the text an
operator reads (status, progress); :mod:`walker_teleop.client` is the rclpy client of the
supervisor's and the plant's topics, services and actions; :mod:`walker_teleop.walkerctl` is
the command line on top of both.
"""
