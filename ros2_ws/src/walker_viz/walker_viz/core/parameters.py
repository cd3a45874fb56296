"""The ``viz`` section of the parameter file: how often and how the walker's TF is drawn.

Loaded like every section of ``walker_core/config/walker.yaml`` into a frozen dataclass that
refuses bad values with :class:`walker_core.parameter_schema.ParameterError`.
"""

from __future__ import annotations

import dataclasses

from walker_core.parameter_schema import parameter

__all__ = ['VizParameters', 'VIZ_PREFIX']

#: Prefix of the section's parameters in the parameter file.
VIZ_PREFIX = 'viz.'


@dataclasses.dataclass(frozen=True)
class VizParameters:
    """Settings of the TF and marker publisher (``viz.*``)."""

    tf_rate: float = parameter(
        'rate at which the moving transforms are sent on /tf: with straight links the newest '
        "joint state's, with viz.flexible every flexible joint state received since (in sim "
        'time on the simulated clock)', 'Hz', 1.0, 1000.0)
    flexible: bool = parameter(
        'draw the links bent as the plant reports them on flexible_joint_states (the '
        "simulated plant's joints with its passive bending joints, all moving on /tf); false: "
        'straight links from joint_states, the bends fixed on /tf_static (a robot that does '
        'not measure its bending)')
