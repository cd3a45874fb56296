"""ROS-free core of walker_sim: no rclpy import anywhere below this package."""
