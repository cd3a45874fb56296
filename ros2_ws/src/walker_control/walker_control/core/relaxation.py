"""Relaxing a closed chain: a decaying dither that frees the joints from locked-in stress.

When a gripper is screwed in off the hole's axis, the hole draws it onto the axis while the
joints stay where their friction holds them: the links bend instead, and the stress stays locked
in by the joints' stiction once both grippers are attached. The joint angles then no longer
describe where the grippers are (by up to about 1.4 mm at the tip on the default plant), and the
base heading the supervisor recovers from them at the next step (eq. (1)'s forward kinematics
against the two nodes) is off by that much over the reach: the next insertion misses by it, and
its own seat locks in more.

A torque dither whose amplitude exceeds the breakaway friction and decays to zero lets each
joint slide, cycle by cycle, to where the links' elastic torque vanishes (within the shrinking
dither), as a decaying alternating field demagnetises iron::

    tau_d(t) = A (1 - t / T) sin(2 pi f t),    0 <= t < T

with ``A`` a multiple of the joint's breakaway friction, ``f`` well below the control rate and
``T`` a few periods of it. On the plant, 3 times the breakaway level at 10 Hz for 0.3 s takes a
1.06 mm bend down to 0.02 mm. With one gripper free the same dither moves the arm by a fraction
of a milliradian and ends at rest.
"""

from __future__ import annotations

import dataclasses
import math

__all__ = ['RelaxationDither']


@dataclasses.dataclass(frozen=True)
class RelaxationDither:
    """The decaying dither of one joint.

    Parameters
    ----------
    amplitude : float
        Initial amplitude ``A`` [N*m], >= 0.
    frequency : float
        Dither frequency ``f`` [Hz], > 0.
    duration : float
        Time ``T`` [s] over which the amplitude decays to zero, >= 0 (0: no dither).

    Raises
    ------
    ValueError
        A negative or non-finite amplitude or duration, or a frequency that is not positive.
    """

    amplitude: float
    frequency: float
    duration: float

    def __post_init__(self) -> None:
        for name in ('amplitude', 'duration'):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f'relaxation {name} must be finite and >= 0, got {value!r}')
        if not (math.isfinite(self.frequency) and self.frequency > 0.0):
            raise ValueError(f'relaxation frequency must be positive, got {self.frequency!r}')

    def done(self, elapsed: float) -> bool:
        """Return True once ``elapsed`` [s] since the start reaches the duration."""
        return elapsed >= self.duration

    def torque(self, elapsed: float) -> float:
        """Dither torque [N*m] ``elapsed`` seconds after the start (0 outside ``[0, T)``)."""
        if elapsed < 0.0 or self.done(elapsed):
            return 0.0
        envelope = self.amplitude * (1.0 - elapsed / self.duration)
        return envelope * math.sin(2.0 * math.pi * self.frequency * elapsed)
