"""When the plant says what: the rates of its slower outputs, and its gripper states' changes.

Every control period the plant publishes its joint states (and accelerations); ``/clock``
(``sim.clock_rate``) and the gripper poses (``sim.pose_rate``) go out at their own, lower
rates on the same stamps, and the gripper states when they change. The plant node and the
headless lock-step loop (``walker_headless``) decide this with the same objects, so a walk
records the same messages either way. Stamps are integer nanoseconds.
"""

from __future__ import annotations

from walker_core.joint_roles import GRIPPERS

__all__ = ['StampedRate', 'gripper_states_key']

_NS_PER_S = 1e9


class StampedRate:
    """Whether an output at ``rate`` [Hz] is due at a stamp [ns].

    Due at the first stamp, then once at least a period (less a nanosecond of rounding) of the
    stamps' time has passed since the last one due; a stamp that goes back (a plant reset) is
    due at once.

    Parameters
    ----------
    rate : float
        Outputs per second of the stamps' time (> 0).
    """

    def __init__(self, rate: float) -> None:
        if not rate > 0.0:
            raise ValueError(f'rate must be > 0 Hz, got {rate!r}')
        self.rate = float(rate)
        self.last: int | None = None  # [ns] stamp of the last output due

    def due(self, stamp: int, force: bool = False) -> bool:
        """Say whether the output is due at ``stamp`` [ns] (``force``: due anyway); mark it."""
        last = self.last
        if not force and last is not None and 0 <= stamp - last < _NS_PER_S / self.rate - 1:
            return False
        self.last = stamp
        return True


def gripper_states_key(state) -> tuple:
    """Return what a ``gripper_states`` message says of a plant state, to tell a change.

    ``state``: a :class:`~walker_sim.core.plant.PlantState`. Each gripper's mode, node and
    message (not its alignment, which moves with every period).
    """
    return tuple((state.statuses[g].mode, state.statuses[g].node, state.statuses[g].message)
                 for g in GRIPPERS)
