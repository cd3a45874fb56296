"""Reference shaping: the setpoint passed through the joint's own command filter.

The low-pass filter of Figure 3 sits on the whole command, feed-forward included, so the joint
follows the feed-forward ``F(s)`` later than the setpoint asks: about ``n / wf`` seconds (0.5 s
for joint 1's fourth-order filter at 8 rad/s). Compared with the raw setpoint, the feedback sees
that delay as an error and fights it; on the walker, joint 1 then lagged its 90 deg sweep by
0.1 rad at the end of the plan and overshot after it, and the tip took 4 s to come within 1 mm
of the target.

Shaping the reference with the same filter makes the feedback compare the joint with the motion
the filtered feed-forward produces: on the rigid model, ``theta = F theta_r`` satisfies the
loop exactly, and the feedback is left with what the model misses (the two-degree-of-freedom
structure of servo design). The motion arrives ``n / wf`` later, smoothly, with no overshoot.
The filter is outside the feedback loop, so the stability check (eqs (14)-(16)) is unchanged.

The same filter shapes position, velocity and acceleration: it is linear and time-invariant,
so each shaped signal is the derivative of the one before. The feed-forward itself takes the
setpoint's own acceleration and effort (the command filter shapes them already); the shaped
acceleration is what acceleration feedback compares the measured one with: with
``-Ka I (a - F a_r)`` instead of ``-Ka I a`` the rigid joint follows ``F theta_r`` exactly also
in coarse mode (``I theta'' = F [I a_r - Ka I (theta'' - F a_r)]`` holds for
``theta'' = F a_r``), and the loop, hence the stability check, is the same.
"""

from __future__ import annotations

from walker_control.core.inputs import Setpoint
from walker_control.core.lowpass import LowPassFilter

__all__ = ['ReferenceShaper']


class ReferenceShaper:
    """Position, velocity and acceleration of a setpoint through copies of the command filter.

    Parameters
    ----------
    order, corner, sample_time, kind
        The command filter's design (:class:`~walker_control.core.lowpass.LowPassFilter`);
        order 0 passes the setpoint through unchanged.
    """

    def __init__(self, order: int, corner: float, sample_time: float, kind: str) -> None:
        self._position = LowPassFilter(order, corner, sample_time, kind)
        self._velocity = LowPassFilter(order, corner, sample_time, kind)
        self._acceleration = LowPassFilter(order, corner, sample_time, kind)

    def reset_to(self, position: float, velocity: float = 0.0) -> None:
        """Start in the steady state of a joint at ``position`` [rad], ``velocity`` [rad/s].

        The acceleration starts at 0; a setpoint equal to that state passes with no transient.
        """
        self._position.reset_to(position)
        self._velocity.reset_to(velocity)
        self._acceleration.reset_to(0.0)

    def update(self, setpoint: Setpoint, samples: int = 1) -> Setpoint:
        """Shape ``samples`` samples of the (held) setpoint; effort passes as given."""
        return Setpoint(position=self._position.update(setpoint.position, samples),
                        velocity=self._velocity.update(setpoint.velocity, samples),
                        acceleration=self._acceleration.update(setpoint.acceleration, samples),
                        effort=setpoint.effort)
