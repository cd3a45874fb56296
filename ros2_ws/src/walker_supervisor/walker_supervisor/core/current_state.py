"""Whether a sim-time decision waits for the plant's state at its own time (free of ROS).

In sim time the plant publishes ``/clock`` and then the joint state of the same stamp. The
supervisor's tick fires when the clock reaches the tick's time; taken at once, the newest joint
state it holds can be the plant's previous one (at a fifth to a quarter of the ticks of a
walk), so the graph would decide on the state of an instant before the headless loop, which
decides at the stamp, and the two walks would drift apart. A decision in sim time therefore
waits, for a bounded wall time, for a joint state stamped at its time or later.

A state that does not come within the bound (a plant frozen or gone, a subscription gone deaf)
is not waited for again until a state arrives on time: a source that has fallen silent must not
slow every tick by the bound.
"""

from __future__ import annotations

__all__ = ['CurrentState', 'STATE_WAIT']

#: [s] wall time a decision waits at most for the joint state of its own time
STATE_WAIT = 0.05


class CurrentState:
    """Whether the decision at a simulated time waits for the joint state of that time.

    Parameters
    ----------
    wait : float
        Wall time [s] a decision waits at most (> 0).

    Raises
    ------
    ValueError
        If ``wait`` is not a positive number of seconds.
    """

    def __init__(self, wait: float = STATE_WAIT) -> None:
        if not wait > 0.0:
            raise ValueError(f'wait must be > 0 s, got {wait!r}')
        self.wait = float(wait)
        self._late = False  # the last wait ran out: do not wait until a state comes on time
        self.waits = 0  # decisions that waited for their state
        self.timeouts = 0  # waits that ran out

    def awaits(self, newest: int | None, now: int) -> bool:
        """Return True if the decision at ``now`` [ns] waits for a newer state.

        ``newest`` is the stamp [ns] of the newest joint state received (None: none yet).
        """
        if newest is not None and newest >= now:
            self._late = False
            return False
        return newest is not None and not self._late

    def waited(self, newest: int | None, now: int) -> None:
        """Note the end of a wait: ``newest`` is the newest stamp [ns] when it ended."""
        self.waits += 1
        if newest is None or newest < now:
            self.timeouts += 1
            self._late = True
