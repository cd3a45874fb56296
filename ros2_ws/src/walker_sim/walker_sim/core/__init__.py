"""ROS-free core of walker_sim: no rclpy import anywhere below this package.

Modules: :mod:`~walker_sim.core.plant` (the plant behind ``reset()``, ``step(torques, dt)``,
``state()``), :mod:`~walker_sim.core.motor` (drives: torque limits, friction),
:mod:`~walker_sim.core.flexibility` (bending springs sized for the paper's modes),
:mod:`~walker_sim.core.grippers` (tolerance, jamming, interlock),
:mod:`~walker_sim.core.commands` (effort commands, watchdog, sim-time lock-step),
:mod:`~walker_sim.core.identification` (measuring the modes),
:mod:`~walker_sim.core.driven_modes` (the modes joint 1's coarse motion excites, held or under its
loop), :mod:`~walker_sim.core.render`
(headless images), :mod:`~walker_sim.core.config` (the ``sim.*`` parameters),
:mod:`~walker_sim.core.bullet` (pybullet helpers).

:func:`make_plant` builds a plant from a parameter file, for tools and experiments that run
other packages' cores on it (``ros2 run walker_headless figure6``).
"""

from __future__ import annotations

__all__ = ['make_plant']


def make_plant(params_file=None, *, other_attached: bool | None = None,
               other_height: float | None = None):
    """Build a :class:`~walker_sim.core.plant.WalkerPlant` from a parameter file.

    Parameters
    ----------
    params_file : str or Path, optional
        The parameter file (default: the installed ``walker.yaml``).
    other_attached : bool, optional
        Override ``sim.start.other_attached`` (False: the tip gripper starts free, so the arm
        can move).
    other_height : float, optional
        Override ``sim.start.other_height`` [m] (the free tip gripper's height above its node).

    Returns
    -------
    WalkerPlant
        Reset to its start configuration; ``reset()`` returns to it. Close it when done.

    Raises
    ------
    ParameterError
        If the file or the overrides are invalid.
    """
    from walker_core.parameter_file import ParameterFile
    from walker_core.parameter_schema import replace_in_section
    from walker_sim.core.config import plant_sections
    from walker_sim.core.plant import WalkerPlant

    params, sim = plant_sections(ParameterFile.read(params_file))
    changes = {f'sim.start.{name}': value
               for name, value in (('other_attached', other_attached),
                                   ('other_height', other_height)) if value is not None}
    if changes:
        sim = replace_in_section(sim, changes, 'sim.')
    return WalkerPlant(params, sim)
