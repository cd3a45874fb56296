"""Controller modes (paper section 2): off, hold, coarse motion and fine motion.

The values equal the constants of ``walker_msgs/ControlMode`` and ``walker_msgs/ControllerState``.
"""

from __future__ import annotations

import enum

__all__ = ['Mode', 'GAIN_MODES']


class Mode(enum.IntEnum):
    """Mode of a joint controller."""

    OFF = 0      #: zero torque
    HOLD = 1     #: hold a position (safe state; no integral action)
    COARSE = 2   #: speed: low gains, acceleration feedback (joint 1)
    FINE = 3     #: precision: higher gains, integral action

    @property
    def key(self) -> str:
        """Lower-case name, as used in the parameter file (``control.coarse...``)."""
        return self.name.lower()

    @property
    def tracks_setpoints(self) -> bool:
        """True in the modes that follow the setpoint stream (coarse, fine)."""
        return self in (Mode.COARSE, Mode.FINE)


#: Modes with a gain set in the parameter file (OFF has none).
GAIN_MODES = (Mode.HOLD, Mode.COARSE, Mode.FINE)
