"""walker_runtime: the ROS layer every walker node shares (the model is in walker_core).

Modules: :mod:`~walker_runtime.qos` (the QoS profile of every topic),
:mod:`~walker_runtime.node_parameters` (the typed parameter sections declared on a node, runtime
updates guarded), :mod:`~walker_runtime.spinning` (node processes, executors, signals, sampled
subscriptions), :mod:`~walker_runtime.realtime` (``SCHED_FIFO`` for the loop's processes) and
:mod:`~walker_runtime.core` (the ROS-free rules behind them: when a silent subscription is made
anew).
"""
