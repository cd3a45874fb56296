"""The vocabulary of a step: its phases (paper section 2, Figure 2), stages, and how it ended.

A step runs EXTRACTION -> COARSE -> FINE -> INSERTION; IDLE between steps, SAFE_HOLD after a
fault. The values of :class:`Phase` are those of ``walker_msgs/StepPhase``. Within a phase the
step is at one :class:`Stage` (what it waits for now).
"""

from __future__ import annotations

import dataclasses
import enum
import math

__all__ = ['Phase', 'Stage', 'StepOutcome', 'SequencerError']


class Phase(enum.IntEnum):
    """Phases of a step; the values are those of ``walker_msgs/StepPhase``."""

    IDLE = 0
    EXTRACTION = 1
    COARSE = 2
    FINE = 3
    INSERTION = 4
    SAFE_HOLD = 5


class Stage(enum.StrEnum):
    """Where a step is within its phase: what it waits for (its value is what the logs say)."""

    NONE = ''  # no step under way
    UNSCREWING = 'unscrewing'  # EXTRACTION: the moving gripper unscrews (then waits for the
    # sweep's plan, at most sweep_lead)
    LIFTING = 'lifting'  # EXTRACTION: the lift along the hole's axis streams (with the sweep)
    LIFTED = 'lifted'  # EXTRACTION: the lift ended; waiting for the joints at the sweep's start
    MOVING = 'moving'  # COARSE: the sweep streams; FINE: a fine line or a way back streams
    ARRIVING = 'arriving'  # COARSE or FINE: the motion there ended (or runs on); waiting for
    # the tip to come within the region, or to come to rest
    LOOKING = 'looking'  # FINE: a frame of the moving gripper's wrist camera is awaited
    SETTLING = 'settling'  # FINE, INSERTION: waiting for the joints to be still (or, above the
    # hole, for the tip to close on it slowly enough to descend)
    DESCENDING = 'descending'  # INSERTION: the descent along the axis streams
    ALIGNING = 'aligning'  # INSERTION: a fine line at the mouth, onto the axis, streams
    SCREWING = 'screwing'  # INSERTION: the gripper screws in
    RETRY_LIFT = 'retry_lift'  # INSERTION: lifted back to the approach height after a jam, or
    # a descent that left the axis


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
    search_probes : int
        Probes of a search on a jam the step moved to (0: it screwed in at the estimate).
    hole_offset : float
        [m] horizontal distance from the map's estimate of the probe that screwed in (0 at the
        estimate; NaN if none did).
    """

    success: bool
    message: str
    phase_durations: dict[str, float]
    duration: float
    insertion_error: float
    insertion_attempts: int
    search_probes: int = 0
    hole_offset: float = math.nan
