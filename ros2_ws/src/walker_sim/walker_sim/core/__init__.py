"""ROS-free core of walker_sim: no rclpy import anywhere below this package.

Modules: :mod:`~walker_sim.core.plant` (the plant behind ``reset()``, ``step(torques, dt)``,
``state()``), :mod:`~walker_sim.core.motor` (drives: torque limits, friction),
:mod:`~walker_sim.core.flexibility` (bending springs sized for the paper's modes),
:mod:`~walker_sim.core.grippers` (tolerance, jamming, interlock),
:mod:`~walker_sim.core.commands` (effort commands, watchdog, sim-time lock-step),
:mod:`~walker_sim.core.identification` (measuring the modes), :mod:`~walker_sim.core.render`
(headless images), :mod:`~walker_sim.core.config` (the ``sim.*`` parameters),
:mod:`~walker_sim.core.bullet` (pybullet helpers).
"""
