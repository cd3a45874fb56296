"""The runtime's ROS-free rules (plain Python, tested with plain pytest)."""
