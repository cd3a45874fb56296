"""The controllers as the supervisor sees them: the mode they were told, and who fell back.

A controller whose input stalled for a moment falls back to HOLD and keeps holding until the
next mode command (:func:`~walker_supervisor.core.health.tell_mode_again`): while a step
expects it to track, the supervisor tells it the step's mode again, at most every
:data:`TELL_MODE_AGAIN_PERIOD`, and makes its ``control_mode`` publisher anew when repeating
the mode does not help (:class:`~walker_supervisor.core.health.ModeRepetition`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

from walker_supervisor.core.commands import Notice, RenewModePublisher, SetControlMode
from walker_supervisor.core.health import (
    ModeRepetition, controller_trouble, tell_mode_again, tracking_expected)

__all__ = ['ControllerReport', 'ControllerWatch', 'TELL_MODE_AGAIN_PERIOD']

#: [s] steady clock: least time between two mode commands sent again to controllers that fell
#: back to HOLD on a stall (one command serves all five)
TELL_MODE_AGAIN_PERIOD = 0.25


@dataclasses.dataclass(frozen=True)
class ControllerReport:
    """A controller's newest state report (``walker_msgs/ControllerState``).

    Attributes
    ----------
    stamp : float
        [s] on the graph's clock.
    stale : bool
        Its inputs timed out: it holds for that.
    holding : bool
        It reports the HOLD mode.
    """

    stamp: float
    stale: bool
    holding: bool


class ControllerWatch:
    """The last mode command, and telling it again to controllers that fell back."""

    def __init__(self) -> None:
        self.mode = ''  # the last mode commanded ('' before the first)
        self.base = ''
        self.commanded_at = -math.inf  # [s] graph clock
        self._told_again = -math.inf  # [s] steady clock
        self.repetition = ModeRepetition()

    def commanded(self, command: SetControlMode, now: float) -> SetControlMode:
        """Note a mode command sent at ``now`` [s]; return it."""
        self.mode, self.base, self.commanded_at = command.mode, command.base_gripper, now
        return command

    def _tracking(self, report: ControllerReport, step_busy: bool) -> bool:
        return tracking_expected(step_busy, self.mode, report.stamp, self.commanded_at)

    def trouble(self, report: ControllerReport, step_busy: bool) -> str:
        """Return what is wrong with a controller by its report ('' when nothing)."""
        return controller_trouble(report.stale, report.holding,
                                  self._tracking(report, step_busy))

    def fell_back(self, reports: Mapping[str, ControllerReport], step_busy: bool, now: float,
                  steady: float) -> list:
        """Return the commands that tell the mode again to the controllers that fell back."""
        fell = [joint for joint, report in reports.items()
                if tell_mode_again(report.stale, report.holding,
                                   self._tracking(report, step_busy))]
        if not fell:
            self.repetition.heard()
            return []
        if steady - self._told_again < TELL_MODE_AGAIN_PERIOD:
            return []
        self._told_again = steady
        names = ', '.join(fell)
        out = []
        if self.repetition.repeat():
            out += [RenewModePublisher(), Notice(
                f'controller {names} still in HOLD after the mode was repeated '
                f'{self.repetition.renew_after} times: control_mode publisher made anew')]
        out.append(Notice(f'controller {names} fell back to HOLD on a stall of its inputs, '
                          f'which are fresh again: mode {self.mode.upper()} commanded again'))
        return out + [self.commanded(SetControlMode(self.mode, self.base), now)]
