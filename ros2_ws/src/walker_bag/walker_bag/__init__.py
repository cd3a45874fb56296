"""walker_bag: records the walker's walks as rosbag2 bags (MCAP storage) and reads them back.

The ROS-free part lives in :mod:`walker_bag.core` (the MCAP rosbag2 writer, metadata.yaml, QoS
and message-definition text, topic selection, bag reading); :mod:`walker_bag.recorder_node` is
the thin rclpy node that subscribes to the walker's topics and hands the received bytes to the
writer; :mod:`walker_bag.bag_info` prints a ``ros2 bag info``-like summary of a bag.
"""
