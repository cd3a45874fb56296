"""ROS-free core of walker_planner: no rclpy import anywhere below this package."""
