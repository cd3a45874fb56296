"""ROS-free core of walker_supervisor: no rclpy import anywhere below this package."""
