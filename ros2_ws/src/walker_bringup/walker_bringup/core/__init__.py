"""The bring-up's ROS-free part: when a node that died is started again."""
