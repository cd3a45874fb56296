"""Feeling the node's face at the end of a descent, from the joints alone.

The walker has no tip sensor (paper section 2). A descent is commanded
``supervisor.insertion_overtravel`` past the hole's nominal mouth, so that it meets the face of
a node that sits lower than the parameter file says; the face then stops the gripper, and the
forward kinematics of the measured joints stop going down while the setpoints still do. That
is contact: the point to screw in, and where the node's mouth really is in height (a node
higher than nominal stops the descent sooner, and is not passed through: the face holds it).

:class:`DescentContact` watches the tip's height (forward kinematics of the joints, base frame)
tick by tick while the descent streams: below ``mouth + overtravel`` (the highest a node may
sit), a tip that has gone down less than :data:`CONTACT_SPEED` for :data:`CONTACT_DWELL` has met
the face. A descent that ends before that is judged at rest: a tip that stopped more than
:data:`SHORT_OF_THE_END` above the descent's end was stopped by the face (the joints' PD
tracking error holds it there); one that reached the end found no face.
"""

from __future__ import annotations

import dataclasses
import math

__all__ = ['CONTACT_SPEED', 'CONTACT_DWELL', 'SHORT_OF_THE_END', 'DescentContact']

#: [m/s] A tip going down slower than this has stopped (the descent meets the face at 10-20
#: mm/s, and streams at up to 200 mm/s).
CONTACT_SPEED = 0.002
#: [s] ... for this long: two decision periods, longer than the descent's own end takes to
#: slow below :data:`CONTACT_SPEED` (its last 8 ms).
CONTACT_DWELL = 0.04
#: [m] A tip at rest this far above the descent's end was stopped by the face: the joints
#: track a free descent to a tenth of a millimetre.
SHORT_OF_THE_END = 3e-4


@dataclasses.dataclass
class DescentContact:
    """Contact of one descent with the node's face.

    Parameters
    ----------
    mouth : float
        [m] Height of the hole's nominal mouth (base frame).
    end : float
        [m] Height the descent is commanded to (``mouth - insertion_overtravel``).

    Attributes
    ----------
    height : float
        [m] Tip height at contact (NaN: no contact felt yet).
    judged : bool
        The descent has ended and been judged.
    """

    mouth: float
    end: float
    height: float = math.nan
    judged: bool = False
    _last: tuple[float, float] | None = None
    _still_since: float | None = None

    @property
    def felt(self) -> bool:
        """True once the face has been felt."""
        return not math.isnan(self.height)

    @property
    def face_offset(self) -> float:
        """[m] Where the face was felt against the nominal mouth (negative: lower); NaN."""
        return self.height - self.mouth

    def update(self, now: float, tip_height: float) -> bool:
        """Take the tip's height [m] at time ``now`` [s]; return True when contact is felt."""
        if self.felt:
            return False
        last, self._last = self._last, (now, tip_height)
        if last is None or now <= last[0]:
            return False
        sinking = (last[1] - tip_height) / (now - last[0])
        below_the_highest_face = tip_height < self.mouth + (self.mouth - self.end)
        if not below_the_highest_face or sinking >= CONTACT_SPEED:
            self._still_since = None
            return False
        if self._still_since is None:
            self._still_since = last[0]
        if now - self._still_since < CONTACT_DWELL:
            return False
        self.height = tip_height
        return True

    def at_rest(self, tip_height: float) -> bool:
        """Judge a descent that has ended, the tip at rest at ``tip_height`` [m].

        Returns True (and records the height) if the face stopped it short of the end.
        """
        if not self.felt and tip_height > self.end + SHORT_OF_THE_END:
            self.height = tip_height
        return self.felt
