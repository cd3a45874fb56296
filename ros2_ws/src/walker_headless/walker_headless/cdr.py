"""CDR bytes of the messages a walk records every period, packed with precompiled layouts.

A walk's bag holds about three messages per control period (the joint states, the controller
states and the gripper poses at their rates, ``/clock``, the viz node's ``/tf``): encoded
through rosbags' generic serializer they would cost more than the controllers. Their layout is
fixed (the joint names, the frames), so each is packed here by one :class:`struct.Struct` built
once: little-endian
CDR (XCDR1, the encapsulation ``00 01 00 00``), each primitive aligned to its size from the
start of the data, as rosbags and Fast DDS write it. ``test_cdr.py`` checks every encoder
against rosbags' serializer of the message type's definition.

Stamps are integer nanoseconds.
"""

from __future__ import annotations

import itertools
import struct
from collections.abc import Sequence

__all__ = ['clock_cdr', 'JointStateEncoder', 'PoseEncoder', 'ControllerStateEncoder',
           'TransformsEncoder']

_HEADER = b'\x00\x01\x00\x00'
_NS_PER_S = 1_000_000_000
_SIZES = {'b': 1, 'B': 1, '?': 1, 'i': 4, 'I': 4, 'd': 8}


class _Layout:
    """A CDR layout built field by field: its constant parts packed once, its variable runs.

    Each field is a ``struct`` code (with the padding that aligns it before it) and either a
    constant value or None (a value given at every message). Consecutive constant fields are
    packed into bytes at once; consecutive variable fields become one :class:`struct.Struct`.
    """

    def __init__(self) -> None:
        self.offset = 0  # from the start of the data (after the encapsulation header)
        self.fields: list[tuple[str, object]] = []

    def _align(self, size: int) -> str:
        pad = -self.offset % size
        self.offset += pad
        return f'{pad}x' if pad else ''

    def primitive(self, code: str, value=None) -> '_Layout':
        """Add a primitive (``struct`` code); ``value`` makes it constant."""
        size = _SIZES[code]
        pad = self._align(size)
        self.offset += size
        self.fields.append((pad + code, value))
        return self

    def primitives(self, code: str, count: int) -> '_Layout':
        """Add ``count`` variable primitives of one code."""
        for _ in range(count):
            self.primitive(code)
        return self

    def string(self, text: str) -> '_Layout':
        """Add a constant string (length with the terminating NUL, then the bytes)."""
        data = text.encode() + b'\x00'
        self.primitive('I', len(data))
        self.offset += len(data)
        self.fields.append((f'{len(data)}s', data))
        return self

    def stamp(self) -> '_Layout':
        """Add a ``builtin_interfaces/Time`` (variable)."""
        return self.primitive('i').primitive('I')

    def packer(self):
        """Return ``pack(*values) -> bytes``: the variable fields' values, in order."""
        pieces: list = []  # bytes (constant) or (Struct, count) (variable run)
        for constant, run in itertools.groupby(self.fields, key=lambda f: f[1] is not None):
            run = list(run)
            codes = '<' + ''.join(code for code, _ in run)
            if constant:
                pieces.append(struct.pack(codes, *(value for _, value in run)))
            else:
                pieces.append((struct.Struct(codes).pack, len(run)))
        if len(pieces) == 1 and type(pieces[0]) is bytes:  # nothing variable
            message = _HEADER + pieces[0]
            return lambda: message
        if len(pieces) == 1:
            only = pieces[0][0]
            return lambda *values: _HEADER + only(*values)
        plan = tuple(pieces)

        def pack(*values) -> bytes:
            out = [_HEADER]
            start = 0
            for piece in plan:
                if type(piece) is bytes:
                    out.append(piece)
                else:
                    packer, count = piece
                    out.append(packer(*values[start:start + count]))
                    start += count
            return b''.join(out)
        return pack


def _split(stamp: int) -> tuple[int, int]:
    return divmod(int(stamp), _NS_PER_S)


_CLOCK = struct.Struct('<iI')


def clock_cdr(stamp: int) -> bytes:
    """``rosgraph_msgs/Clock`` of a time [ns]."""
    return _HEADER + _CLOCK.pack(*_split(stamp))


class JointStateEncoder:
    """``sensor_msgs/JointState`` of fixed joint names, empty frame.

    Parameters
    ----------
    names : sequence of str
        The joints, in the order of the values.
    """

    def __init__(self, names: Sequence[str]) -> None:
        count = len(names)
        layout = _Layout().stamp().string('').primitive('I', count)
        for name in names:
            layout.string(name)
        for _ in range(3):
            layout.primitive('I', count).primitives('d', count)
        self._pack = layout.packer()

    def encode(self, stamp: int, positions: Sequence[float], velocities: Sequence[float],
               efforts: Sequence[float]) -> bytes:
        """Return the message stamped ``stamp`` [ns]: angles [rad], speeds [rad/s], efforts."""
        return self._pack(*_split(stamp), *positions, *velocities, *efforts)


class PoseEncoder:
    """``geometry_msgs/PoseStamped`` in one frame.

    Parameters
    ----------
    frame : str
        The header's ``frame_id``.
    """

    def __init__(self, frame: str) -> None:
        self._pack = _Layout().stamp().string(frame).primitives('d', 7).packer()

    def encode(self, stamp: int, position: Sequence[float], orientation: Sequence[float]
               ) -> bytes:
        """Return the pose stamped ``stamp`` [ns]: position [m], orientation ``(x, y, z, w)``."""
        return self._pack(*_split(stamp), *position, *orientation)


class ControllerStateEncoder:
    """``walker_msgs/ControllerState`` of one joint, empty frame.

    Parameters
    ----------
    joint : str
        The physical joint.
    """

    #: The float64 fields after ``mode``, in the message's order.
    FLOATS = ('position_setpoint', 'velocity_setpoint', 'acceleration_setpoint', 'position',
              'velocity', 'acceleration', 'position_error', 'feedforward_effort',
              'proportional_effort', 'integral_effort', 'derivative_effort',
              'acceleration_feedback_effort', 'friction_compensation_effort', 'effort')

    def __init__(self, joint: str) -> None:
        self._pack = (_Layout().stamp().string('').string(joint).primitive('B')
                      .primitive('B').primitives('d', len(self.FLOATS)).primitive('?')
                      .primitive('?').packer())

    def encode(self, stamp: int, role: int, mode: int, values: Sequence[float],
               saturated: bool, stale: bool) -> bytes:
        """Return the state stamped ``stamp`` [ns]; ``values`` in the order of :attr:`FLOATS`."""
        return self._pack(*_split(stamp), role, mode, *values, saturated, stale)


class TransformsEncoder:
    """``tf2_msgs/TFMessage`` of fixed frames, every transform stamped alike.

    Parameters
    ----------
    frames : sequence of (str, str)
        ``(parent, child)`` frame ids of each transform, in order.
    """

    def __init__(self, frames: Sequence[tuple[str, str]]) -> None:
        layout = _Layout().primitive('I', len(frames))
        for parent, child in frames:
            layout.stamp().string(parent).string(child).primitives('d', 7)
        self._pack = layout.packer()
        self._count = len(frames)

    def encode(self, stamp: int, values: Sequence[float]) -> bytes:
        """Return the transforms stamped ``stamp`` [ns].

        ``values``: for each transform its translation [m] and rotation ``(x, y, z, w)``,
        seven floats, one transform after the other.
        """
        sec, nanosec = _split(stamp)
        flat: list = []
        for k in range(self._count):
            flat += (sec, nanosec, *values[7 * k:7 * k + 7])
        return self._pack(*flat)
