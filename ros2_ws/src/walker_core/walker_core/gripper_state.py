"""The states of a gripper: one vocabulary for the plant, the supervisor and every tool.

A gripper is FREE; SCREWING while its thread draws it into a node's hole (it is held from the
start of the screw-in); ATTACHED; UNSCREWING (still held until the thread is out); or JAMMED:
the screw-in missed the hole, the gripper stays free at the node it missed. The walker never
lets go of the truss: a gripper is unscrewed only while the other is ATTACHED.

:class:`GripperState` is a ``StrEnum``: a state is its lowercase name, equal to that string,
and written as it in text and JSON. Its :attr:`~GripperState.code` is the matching constant
of ``walker_msgs/GripperState`` (FREE 0 ... JAMMED 4), which the nodes put into and read out
of messages (:meth:`GripperState.of_code`; :func:`reported_state` for a message from outside,
whose code may be none of them).
"""

from __future__ import annotations

import enum

__all__ = ['GripperState', 'TURNING', 'UNKNOWN', 'reported_state']


class GripperState(enum.StrEnum):
    """State of one gripper; ``code`` is its ``walker_msgs/GripperState`` constant."""

    FREE = 'free'
    SCREWING = 'screwing'
    ATTACHED = 'attached'
    UNSCREWING = 'unscrewing'
    JAMMED = 'jammed'

    @property
    def code(self) -> int:
        """The ``walker_msgs/GripperState`` constant of this state (the members' order)."""
        return _CODES[self]

    @classmethod
    def of_code(cls, code: int) -> GripperState:
        """Return the state whose ``walker_msgs/GripperState`` constant is ``code``.

        Raises
        ------
        ValueError
            ``code`` is none of the message's constants.
        """
        try:
            return _STATES[code]
        except (KeyError, TypeError):
            raise ValueError(f'unknown gripper state code {code!r}: expected one of '
                             f'{", ".join(f"{c} ({s.name})" for c, s in _STATES.items())}'
                             ) from None


_STATES = dict(enumerate(GripperState))
_CODES = {state: code for code, state in _STATES.items()}

#: The states in which a gripper turns in its hole (a screw-in or an unscrew under way).
TURNING = frozenset((GripperState.SCREWING, GripperState.UNSCREWING))

#: The state of a gripper whose reported code is none of ``walker_msgs/GripperState``'s.
UNKNOWN = 'unknown'


def reported_state(code: int) -> str:
    """Return the state a message reports with ``code``: a :class:`GripperState`, or UNKNOWN."""
    try:
        return GripperState.of_code(code)
    except ValueError:
        return UNKNOWN
