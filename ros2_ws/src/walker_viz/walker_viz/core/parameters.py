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
        'rate at which the moving transforms are sent on /tf', 'Hz', 1.0, 1000.0,
        source='chosen: smooth in RViz and Foxglove (robot_state_publisher sends 20 Hz)')
    flexible: bool = parameter(
        'draw the links bent as the plant reports them; false: straight links from joint_states',
        source='chosen: a swing bends the links by up to 6 mm at the tip')
