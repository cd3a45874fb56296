"""walker_supervisor: the step-phase supervisor that walks the robot across the truss.

The ROS-free logic lives in :mod:`walker_supervisor.core` (route planning, step geometry, the
phase state machine); the node beside it only converts messages and calls the core.
"""
