"""The settling window: how long the joints stay still before the tip counts as at rest.

The supervisor waits it before it judges where a motion left the tip (``supervisor.settle_time``,
:class:`walker_supervisor.core.parameters.SupervisorParameters`); the walk report measures the
tip's residual vibration over the same window before each insertion. The parameter is declared
here, once, so that both take it from the model and the report needs nothing of the
supervisor.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from walker_core.parameter_schema import parameter

__all__ = ['SETTLING_PREFIX', 'SettlingWindow', 'settle_time_parameter']

#: The window is a leaf of the supervisor's group of the parameter file.
SETTLING_PREFIX = 'supervisor.'


def settle_time_parameter() -> Any:
    """Declare ``settle_time`` [s] (a dataclass field of a section under ``supervisor.``)."""
    return parameter(
        'time the joints must be still after a motion of joint 1 before the tip is judged',
        's', 0.0, 10.0, read_only=False,
        source='chosen: joint 1 comes in behind its filter slowly enough to look still for 0.1 s')


@dataclasses.dataclass(frozen=True)
class SettlingWindow:
    """The settling window alone, read from the supervisor's group (``supervisor.settle_time``)."""

    settle_time: float = settle_time_parameter()
