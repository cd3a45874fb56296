"""The bring-up's ROS-free part: the whole configuration, every section and every rule."""
