"""ROS-free core of walker_control: no rclpy import anywhere below this package.

Modules: :mod:`~walker_control.core.lowpass` (digital filters), :mod:`~walker_control.core.pid`,
:mod:`~walker_control.core.accel_feedback`, :mod:`~walker_control.core.friction_compensation`,
:mod:`~walker_control.core.feedforward` (the parts of Figure 3);
:mod:`~walker_control.core.joint_controller` (Figure 3 composed, modes, bumpless transfer);
:mod:`~walker_control.core.stability` (eq (14), Routh-Hurwitz (15)/(16), the sampled loop);
:mod:`~walker_control.core.config` (the ``control`` parameters, stability-checked);
:mod:`~walker_control.core.inputs` (setpoint validation and selection, input watchdog);
:mod:`~walker_control.core.modes`.
"""
