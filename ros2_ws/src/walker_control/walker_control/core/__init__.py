"""ROS-free core of walker_control: no rclpy import anywhere below this package."""
