"""walker_sim: the pybullet plant of the walker, the simulator that stands in for the hardware.

The ROS-free physics lives in :mod:`walker_sim.core` (tested with plain pytest); beside it,
:mod:`walker_sim.plant_node` puts it on the ROS graph (with :mod:`walker_sim.messages` for the
conversions and QoS), and :mod:`walker_sim.identify_modes` and :mod:`walker_sim.render_walker`
are command-line tools that need no graph.
"""
