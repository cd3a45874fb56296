"""The one table of the parameter file's sections: who owns each, its prefix, who reads it.

:func:`~walker_config.core.configuration.configuration_of` builds a configuration from it,
and ``scripts/generate_parameter_docs.py`` writes docs/parameters.md from it: a new section
is added here, once. The nodes, which cannot import it (this package depends on theirs), are
checked against it: every section a node declares, under its prefix, is a row here
(``tests/test_structure.py``). Each row is one group of the file (``robot``, ``sim``, ...), in the
file's order; ``field`` names the :class:`~walker_config.core.configuration.
WalkerConfiguration` attribute built from it (a group may be part of a larger section: the
robot's four groups are ``walker``'s, ``control`` is part of ``controllers``).
"""

from __future__ import annotations

import dataclasses

from walker_bag.core.recorder_parameters import RECORDER_PREFIX, RecorderParameters
from walker_control.core.config import ControlParameters, ControllerSettings
from walker_core.robot_parameters import (
    GripperParameters, RobotParameters, TimingParameters, TrussParameters, WalkerParameters)
from walker_planner.core.parameters import PREFIX as PLANNER_PREFIX
from walker_planner.core.parameters import PlannerParameters
from walker_sim.core.config import SimParameters
from walker_supervisor.core.parameters import SupervisorParameters
from walker_supervisor.core.teleop import TeleopParameters
from walker_viz.core.parameters import VIZ_PREFIX, VizParameters

__all__ = ['ParameterGroup', 'SECTIONS', 'configuration_sections']


@dataclasses.dataclass(frozen=True)
class ParameterGroup:
    """One group of the parameter file.

    Attributes
    ----------
    group : str
        Its name, the first part of its parameters' names (``robot``, ``sim``).
    prefix : str
        What its leaves' names start with (``''`` for the robot's groups).
    leaves : type
        The dataclass of its leaves (their schema: description, unit, range, source).
    readers : str
        The nodes that declare it.
    field : str
        The configuration's attribute built from it.
    section : type
        The section that attribute holds, and ``section_prefix`` its prefix.
    """

    group: str
    prefix: str
    leaves: type
    readers: str
    field: str
    section: type
    section_prefix: str


_ROBOT = ('every node', 'walker', WalkerParameters, '')

#: Every group of the parameter file, in the file's order.
SECTIONS = (
    ParameterGroup('robot', '', RobotParameters, *_ROBOT),
    ParameterGroup('truss', '', TrussParameters, *_ROBOT),
    ParameterGroup('gripper', '', GripperParameters, *_ROBOT),
    ParameterGroup('timing', '', TimingParameters, *_ROBOT),
    ParameterGroup('recorder', RECORDER_PREFIX, RecorderParameters, 'the recorder', 'recorder',
                   RecorderParameters, RECORDER_PREFIX),
    ParameterGroup('supervisor', 'supervisor.', SupervisorParameters,
                   'the supervisor (`settle_time` from `walker_core.settling`, which the report '
                   'reads too)', 'supervisor', SupervisorParameters, 'supervisor.'),
    ParameterGroup('teleop', 'teleop.', TeleopParameters, 'the supervisor', 'teleop',
                   TeleopParameters, 'teleop.'),
    ParameterGroup('planner', PLANNER_PREFIX, PlannerParameters, 'the planner', 'planner',
                   PlannerParameters, PLANNER_PREFIX),
    ParameterGroup('control', 'control.', ControlParameters, 'the joint controllers',
                   'controllers', ControllerSettings, ''),
    ParameterGroup('sim', 'sim.', SimParameters, 'the plant', 'sim', SimParameters, 'sim.'),
    ParameterGroup('viz', VIZ_PREFIX, VizParameters, 'the viz node', 'viz', VizParameters,
                   VIZ_PREFIX),
)


def configuration_sections() -> dict[str, tuple[type, str]]:
    """Return each configuration attribute's section and prefix, in the file's order."""
    return {row.field: (row.section, row.section_prefix) for row in SECTIONS}
