"""The controllers as the supervisor sees them: the mode they were told, and who fell back.

A controller whose input stalled for a moment falls back to HOLD and keeps holding until the
next mode command (:func:`~walker_supervisor.core.health.tell_mode_again`): while a step
expects it to track, the supervisor tells it the step's mode again, at most every
:data:`TELL_MODE_AGAIN_PERIOD`, and makes its ``control_mode`` publisher anew when repeating
the mode does not help (:class:`~walker_supervisor.core.health.ModeRepetition`).

A controller that reports a mode (or a base, by its joint's role) other than the one commanded,
and not the HOLD of a fallback, was put there by no command of this supervisor: a publisher that
wrote ``control_mode`` in its name (without SROS2 the ``commander`` field authenticates
nothing). The supervisor commands its mode again at once (at most every
:data:`TELL_MODE_AGAIN_PERIOD`), reports the disagreement on ``/diagnostics`` as the
controller's trouble and on the console, and holds once it has lasted
``supervisor.mode_mismatch_hold_time`` (steady clock) in spite of the corrections.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_supervisor.core.commands import Notice, RenewModePublisher, SetControlMode
from walker_supervisor.core.health import (
    ModeRepetition, controller_trouble, tell_mode_again, tracking_expected)

__all__ = ['ControllerReport', 'ControllerWatch', 'TELL_MODE_AGAIN_PERIOD', 'MODE_REPORT_GRACE',
           'expected_role']

#: [s] steady clock: least time between two mode commands sent again to controllers that fell
#: back to HOLD on a stall (one command serves all five)
TELL_MODE_AGAIN_PERIOD = 0.25
#: [s] graph clock: a report stamped this soon after a mode command may still show the mode
#: before it (the controllers take it at their next state)
MODE_REPORT_GRACE = 0.1


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
    mode : str
        The mode it reports ('off', 'hold', 'coarse', 'fine'; '' when not told).
    role : int
        Its joint's role 1..5 for the base it follows (0 when not told).
    """

    stamp: float
    stale: bool
    holding: bool
    mode: str = ''
    role: int = 0


def expected_role(joint: str, base: str) -> int:
    """Role 1..5 of a physical joint with ``base`` the base gripper (0: unknown joint/base)."""
    if joint not in PHYSICAL_JOINT_NAMES or base not in ('a', 'b'):
        return 0
    index = PHYSICAL_JOINT_NAMES.index(joint)
    return index + 1 if base == 'a' else len(PHYSICAL_JOINT_NAMES) - index


def _base_of(reports: Mapping[str, ControllerReport]) -> str:
    """Return the base the controllers' roles say they follow (``'a'`` when none tells)."""
    for joint, report in reports.items():
        for base in ('a', 'b'):
            if report.role and report.role == expected_role(joint, base) \
                    and report.role != expected_role(joint, 'b' if base == 'a' else 'a'):
                return base
    return 'a'


class ControllerWatch:
    """The last mode command, and telling it again to controllers that fell back."""

    def __init__(self) -> None:
        self.mode = ''  # the last mode commanded ('' before the first)
        self.base = ''
        self.commanded_at = -math.inf  # [s] graph clock
        self._told_again = -math.inf  # [s] steady clock
        self._corrected = -math.inf  # [s] steady clock: the last correction of a mismatch
        self.mismatch_since: float | None = None  # [s] steady clock: a mismatch unbroken since
        self.repetition = ModeRepetition()

    def commanded(self, command: SetControlMode, now: float) -> SetControlMode:
        """Note a mode command sent at ``now`` [s]; return it.

        A command of another mode or base ends a disagreement with the one before (the
        controllers have a new command to follow); the same command again, a correction,
        does not.
        """
        if (command.mode, command.base_gripper) != (self.mode, self.base):
            self.mismatch_since = None
        self.mode, self.base, self.commanded_at = command.mode, command.base_gripper, now
        return command

    def expect_idle_hold(self) -> None:
        """Expect HOLD of controllers never commanded, the walker idle (they start holding).

        The base stays unknown until a command names it: no role is checked before.
        """
        if not self.mode:
            self.mode, self.base, self.commanded_at = 'hold', '', -math.inf

    def _tracking(self, report: ControllerReport, step_busy: bool) -> bool:
        return tracking_expected(step_busy, self.mode, report.stamp, self.commanded_at)

    def trouble(self, report: ControllerReport, step_busy: bool, joint: str = '') -> str:
        """Return what is wrong with a controller by its report ('' when nothing)."""
        return self.disagreement(joint, report) or controller_trouble(
            report.stale, report.holding, self._tracking(report, step_busy))

    def disagreement(self, joint: str, report: ControllerReport) -> str | None:
        """How a controller's reported mode or base differs from the command ('' if not).

        None when its report cannot tell: no command yet, inputs stale, a report from just
        after the command (:data:`MODE_REPORT_GRACE`). HOLD while another mode is commanded is
        a fallback (:meth:`fell_back`), not a disagreement.
        """
        if not self.mode or not report.mode or report.stale \
                or report.stamp < self.commanded_at + MODE_REPORT_GRACE:
            return None
        if report.mode != self.mode and not report.holding:
            return (f'in mode {report.mode.upper()}, commanded {self.mode.upper()} by this '
                    f'supervisor')
        role = expected_role(joint, self.base)
        if report.role and role and report.role != role:
            return (f'in role J{report.role}, J{role} with base {self.base} commanded by this '
                    f'supervisor')
        return ''

    def unexpected_modes(self, reports: Mapping[str, ControllerReport], now: float,
                         steady: float) -> list:
        """Return the commands that correct controllers in a mode nobody commanded.

        The mode commanded again (at most every :data:`TELL_MODE_AGAIN_PERIOD` of ``steady``
        [s]) and a warning naming each controller, its mode and the commanded one;
        :attr:`mismatch_since` keeps when the disagreement began (until a report agrees).
        """
        judged = {joint: self.disagreement(joint, report) for joint, report in reports.items()}
        wrong = {joint: what for joint, what in judged.items() if what}
        if not wrong:
            if any(what == '' for what in judged.values()):
                self.mismatch_since = None
            return []
        if self.mismatch_since is None:
            self.mismatch_since = steady
        if steady - self._corrected < TELL_MODE_AGAIN_PERIOD:
            return []
        self._corrected = steady
        names = '; '.join(f'controller {joint} {what}' for joint, what in wrong.items())
        base = self.base or _base_of(reports)
        return [Notice(f'{names}: put there by no command of this supervisor (another '
                       f'control_mode publisher?); mode {self.mode.upper()} for base '
                       f'{base} commanded again', 'warning'),
                self.commanded(SetControlMode(self.mode, base), now)]

    def mismatch_lasted(self, steady: float, limit: float) -> bool:
        """Return True once a disagreement has lasted ``limit`` [s] of ``steady`` unbroken."""
        return self.mismatch_since is not None and steady - self.mismatch_since >= limit

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
