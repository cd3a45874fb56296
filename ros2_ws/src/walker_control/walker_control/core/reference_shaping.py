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

An input shaper (:mod:`~walker_control.core.input_shaping`, ``control.shaping``) shapes the
setpoint the same way, before everything else (:class:`InputShapedSetpoint`): position,
velocity, acceleration and effort through the same impulses, so they stay each other's
derivatives and the feed-forward asks for the shaped motion. It is outside the loop too: the
stability check is that of the loop it feeds.
"""

from __future__ import annotations

from collections.abc import Callable

from walker_control.core.input_shaping import DiscreteShaper, Shaper
from walker_control.core.inputs import Setpoint
from walker_control.core.lowpass import LowPassFilter

__all__ = ['ReferenceShaper', 'InputShapedSetpoint', 'RestartingShaper']


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


class InputShapedSetpoint:
    """Position, velocity, acceleration and effort of a setpoint through an input shaper.

    Parameters
    ----------
    shaper : Shaper
        The impulses (:mod:`~walker_control.core.input_shaping`).
    sample_time : float
        Control period [s]; impulses off its grid are split between neighbouring samples.
    """

    def __init__(self, shaper: Shaper, sample_time: float) -> None:
        self._signals = tuple(DiscreteShaper(shaper, sample_time) for _ in range(4))

    def reset_to(self, position: float, velocity: float = 0.0) -> None:
        """Start in the steady state of a joint at ``position`` [rad], ``velocity`` [rad/s]."""
        for signal, value in zip(self._signals, (position, velocity, 0.0, 0.0), strict=True):
            signal.reset_to(value)

    def update(self, setpoint: Setpoint, samples: int = 1) -> Setpoint:
        """Shape ``samples`` samples of the (held) setpoint."""
        position, velocity, acceleration, effort = self._signals
        return Setpoint(position=position.update(setpoint.position, samples),
                        velocity=velocity.update(setpoint.velocity, samples),
                        acceleration=acceleration.update(setpoint.acceleration, samples),
                        effort=effort.update(setpoint.effort, samples))


class RestartingShaper:
    """A :class:`ReferenceShaper` of a design that may change, started at the joint's state.

    The controller keeps one for its reference shaping and one for its setpoint filter. Each
    sample it says which design is in force (None: none, the setpoint passes unchanged) and
    whether tracking begins anew (into or out of HOLD, a role change); the shaper then restarts
    at the measured position and velocity, as it does when the design changes.
    """

    def __init__(self, factory: Callable[..., ReferenceShaper | InputShapedSetpoint]
                 = ReferenceShaper) -> None:
        self._factory = factory
        self._shaper: ReferenceShaper | InputShapedSetpoint | None = None
        self._design: tuple | None = None

    @property
    def active(self) -> bool:
        """True while a shaper runs (a design was in force at the last sample)."""
        return self._shaper is not None

    def stop(self) -> None:
        """Drop the shaper: the next sample with a design starts it afresh."""
        self._shaper = None

    def update(self, design: tuple | None, restart: bool, position: float, velocity: float,
               setpoint: Setpoint, samples: int = 1) -> Setpoint:
        """Return ``setpoint`` shaped over ``samples`` periods by ``design``, if any.

        Parameters
        ----------
        design : tuple or None
            The arguments of the factory: ``(order, corner, sample_time, kind)`` of the filter
            (:class:`ReferenceShaper`), ``(shaper, sample_time)`` of an input shaper.
        restart : bool
            Start again at ``position`` [rad] and ``velocity`` [rad/s] even if the design is
            the same.
        """
        if design is None:
            self._shaper = None
            return setpoint
        if self._shaper is None or design != self._design or restart:
            self._shaper = self._factory(*design)
            self._shaper.reset_to(position, velocity)
            self._design = design
        return self._shaper.update(setpoint, samples)
