"""The walker seen in a ROS user's own tools: TF, markers, the live Foxglove view."""
