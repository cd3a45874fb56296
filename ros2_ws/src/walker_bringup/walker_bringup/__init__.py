"""walker_bringup: bring the walker node graph up as processes, walk, shut down cleanly.

ROS 2 launch is not available, so :mod:`~walker_bringup.graph` describes the nodes as data,
:mod:`~walker_bringup.processes` runs and supervises them, :mod:`~walker_bringup.graph_client`
talks to the running graph, and :mod:`~walker_bringup.session` is the one way to run a walk
(the graph or the headless runner behind it); :mod:`~walker_bringup.run` is run_all.py's
command line for it.
"""
