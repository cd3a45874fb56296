"""ROS-free part of walkerctl: status text, the hole offset in a gripper's frame, progress."""
