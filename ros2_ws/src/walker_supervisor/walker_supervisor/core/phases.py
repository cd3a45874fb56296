"""The vocabulary of a step: its phases (paper section 2, Figure 2) and how it ended.

A step runs EXTRACTION -> COARSE -> FINE -> INSERTION; IDLE between steps, SAFE_HOLD after a
fault. The values of :class:`Phase` are those of ``walker_msgs/StepPhase``.
"""

from __future__ import annotations

import dataclasses
import enum

__all__ = ['Phase', 'StepOutcome', 'SequencerError']


class Phase(enum.IntEnum):
    """Phases of a step; the values are those of ``walker_msgs/StepPhase``."""

    IDLE = 0
    EXTRACTION = 1
    COARSE = 2
    FINE = 3
    INSERTION = 4
    SAFE_HOLD = 5


class SequencerError(ValueError):
    """An event that the sequencer cannot accept in its current state."""


@dataclasses.dataclass
class StepOutcome:
    """How a step ended, with the figures the walk summary reports.

    Attributes
    ----------
    success : bool
    message : str
        Why it failed ('' on success).
    phase_durations : dict of str to float
        Time spent in each phase [s].
    duration : float
        Step time [s] from start to the screw-in (the gripper reported attached).
    insertion_error : float
        Tip distance [m] from the hole's axis when the screw-in was requested, at the mouth
        (forward kinematics of the measured joints: what the walker knows); before that, from
        the point above the hole when the descent started; NaN if insertion never started.
    insertion_attempts : int
    """

    success: bool
    message: str
    phase_durations: dict[str, float]
    duration: float
    insertion_error: float
    insertion_attempts: int
