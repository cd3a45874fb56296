"""ROS-free core of walker_bag: no rclpy import anywhere below this package.

Modules: :mod:`~walker_bag.core.errors` (the bag errors), :mod:`~walker_bag.core.qos` (QoS
profiles in rosbag2's metadata form), :mod:`~walker_bag.core.message_definitions` (``ros2msg``
schema text and type hashes of installed interfaces), :mod:`~walker_bag.core.bag_metadata`
(``metadata.yaml``, version 9), :mod:`~walker_bag.core.bag_writer` (the MCAP bag writer),
:mod:`~walker_bag.core.bag_reader` (decoded messages of a bag),
:mod:`~walker_bag.core.bag_recovery` (a complete copy of a bag cut short by a crash),
:mod:`~walker_bag.core.topic_selection` (which topics to record) and
:mod:`~walker_bag.core.recorder_parameters` (the ``recorder`` section of the parameter file).

Timestamps are integer nanoseconds, as rosbag2 stores them: since the Unix epoch for wall-clock
recordings, since the simulation's epoch for sim-time recordings.
"""
