"""The plant's physical state on disk: what a plant started again restores (ROS-free).

A killed plant is the hardware stand-in dying: the robot it stands for does not go back to its
start pose when its driver restarts, a driver re-reads its encoders. The plant therefore writes
a small snapshot of its state (:class:`PlantSnapshot`: simulated time, the pose of the body's
root, every joint's angle and rate, rotors and bending joints included, each gripper's mode,
node and screw timer, where each gripper other than the root is held) at a modest rate and on
every gripper change (:class:`SnapshotSchedule`), written atomically (a reader sees the old
file or the new one, never half of one), and a plant started with a snapshot restores it
(:meth:`walker_sim.core.plant.WalkerPlant.restore`) instead of taking its start pose.

The truss is the parameter file's (the plant takes the same file when started again); the
snapshot holds which of its nodes each gripper is screwed into.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
from pathlib import Path

__all__ = ['PlantSnapshot', 'SnapshotError', 'SnapshotSchedule', 'SnapshotKeeper',
           'write_snapshot', 'read_snapshot', 'SNAPSHOT_PERIOD']

#: [s] of wall-clock time between two snapshots while nothing changes. A plant started again
#: restores a state at most this old (plus the gripper changes, written at once).
SNAPSHOT_PERIOD = 0.1
_VERSION = 1


class SnapshotError(ValueError):
    """A snapshot that cannot be read or does not fit this plant; nothing was restored."""


@dataclasses.dataclass(frozen=True)
class PlantSnapshot:
    """The plant's physical state at one instant.

    Attributes
    ----------
    time_steps : int
        Physics steps since the start (simulated time = ``time_steps`` * physics step).
    root : str
        The gripper the simulated body is rooted at (``'a'`` or ``'b'``).
    base : str
        The gripper holding the walker (the gripper logic's base).
    root_position : tuple of float, shape (3,)
        Position [m] of the root gripper's frame in the truss frame.
    root_orientation : tuple of float, shape (4,)
        Its unit quaternion ``(x, y, z, w)``.
    positions, velocities : tuple of float
        Angle [rad] and rate [rad/s] of every movable joint of the rooted body (joints,
        rotors, bending joints), in the body's own order.
    grippers : dict
        Gripper -> ``{'mode': name, 'node': str, 'elapsed': s}`` (the screw timer).
    holds : dict
        Gripper other than the root held by the truss -> ``(position, orientation)`` of the
        point it is held at [m, unit quaternion].
    pulls : dict
        Gripper being screwed in -> ``(start, seat)``, each ``(position, orientation)``.
    fouled_screw_ins : int
        Screw-ins that will jam whatever the alignment (an injected fault).
    tip : str
        The gripper that moves or moves next (the gripper logic's tip; empty in a snapshot
        written before it was recorded: the gripper that is not ``base``).
    """

    time_steps: int
    root: str
    base: str
    root_position: tuple[float, ...]
    root_orientation: tuple[float, ...]
    positions: tuple[float, ...]
    velocities: tuple[float, ...]
    grippers: dict[str, dict]
    holds: dict[str, tuple]
    pulls: dict[str, tuple]
    fouled_screw_ins: int = 0
    tip: str = ''

    def as_dict(self) -> dict:
        """Return the snapshot as plain JSON data."""
        return {'version': _VERSION, **dataclasses.asdict(self)}

    @classmethod
    def from_dict(cls, data: dict) -> 'PlantSnapshot':
        """Build a snapshot from :meth:`as_dict` data.

        Raises
        ------
        SnapshotError
            If the data is not a snapshot of this version or a value is missing or not finite.
        """
        if not isinstance(data, dict) or data.get('version') != _VERSION:
            raise SnapshotError(f'not a plant snapshot of version {_VERSION}')
        fields = {f.name for f in dataclasses.fields(cls)}
        missing = sorted(fields - {'fouled_screw_ins', 'tip'} - set(data))
        if missing:
            raise SnapshotError(f'the snapshot lacks {", ".join(missing)}')
        try:
            snapshot = cls(
                time_steps=int(data['time_steps']), root=str(data['root']),
                base=str(data['base']),
                root_position=_floats(data['root_position'], 3),
                root_orientation=_floats(data['root_orientation'], 4),
                positions=_floats(data['positions']), velocities=_floats(data['velocities']),
                grippers={str(g): {'mode': str(s['mode']), 'node': str(s['node']),
                                   'elapsed': float(s['elapsed'])}
                          for g, s in data['grippers'].items()},
                holds={str(g): _pose(p) for g, p in data['holds'].items()},
                pulls={str(g): (_pose(p[0]), _pose(p[1])) for g, p in data['pulls'].items()},
                fouled_screw_ins=int(data.get('fouled_screw_ins', 0)),
                tip=str(data.get('tip', '')))
        except (KeyError, TypeError, ValueError, IndexError) as error:
            raise SnapshotError(f'a malformed snapshot: {error}') from None
        if len(snapshot.positions) != len(snapshot.velocities):
            raise SnapshotError('the snapshot has not as many joint rates as angles')
        return snapshot


def _floats(values, count: int | None = None) -> tuple[float, ...]:
    result = tuple(float(v) for v in values)
    if count is not None and len(result) != count:
        raise ValueError(f'expected {count} numbers, got {len(result)}')
    if not all(math.isfinite(v) for v in result):
        raise ValueError('a value is not finite')
    return result


def _pose(value) -> tuple[tuple[float, ...], tuple[float, ...]]:
    return _floats(value[0], 3), _floats(value[1], 4)


def write_snapshot(path: str | Path, snapshot: PlantSnapshot) -> None:
    """Write ``snapshot`` to ``path`` atomically (a new file renamed over the old one)."""
    path = Path(path)
    temporary = path.with_name(f'.{path.name}.{os.getpid()}.tmp')
    with open(temporary, 'w') as stream:
        json.dump(snapshot.as_dict(), stream)
    os.replace(temporary, path)


def read_snapshot(path: str | Path) -> PlantSnapshot | None:
    """Read the snapshot at ``path``; None when there is none.

    Raises
    ------
    SnapshotError
        If the file exists but holds no readable snapshot.
    """
    try:
        text = Path(path).read_text()
    except FileNotFoundError:
        return None
    except OSError as error:
        raise SnapshotError(f'cannot read the plant snapshot {path}: {error}') from None
    try:
        return PlantSnapshot.from_dict(json.loads(text))
    except json.JSONDecodeError as error:
        raise SnapshotError(f'the plant snapshot {path} is not JSON: {error}') from None


class SnapshotSchedule:
    """When the plant writes its snapshot: every ``period`` seconds, and on gripper changes.

    Parameters
    ----------
    period : float
        Seconds [s] of the caller's clock (wall clock: the rate costs the machine, not the
        simulation) between two snapshots while the grippers do not change.
    """

    def __init__(self, period: float = SNAPSHOT_PERIOD) -> None:
        if not (math.isfinite(period) and period > 0.0):
            raise ValueError(f'the snapshot period must be a positive number of seconds, got '
                             f'{period!r}')
        self.period = period
        self._last = -math.inf
        self._grippers: object = None

    def due(self, now: float, grippers: object) -> bool:
        """Return True when a snapshot is due at ``now`` [s] with the gripper key ``grippers``.

        A snapshot is due once ``period`` has passed since the last one, and at once when the
        grippers' key (their modes and nodes) differs from the last snapshot's. Each True
        counts as written.
        """
        if grippers != self._grippers or now - self._last >= self.period:
            self._last, self._grippers = now, grippers
            return True
        return False


class SnapshotKeeper:
    """The plant's snapshot file: restored from at start, written on its schedule.

    Parameters
    ----------
    path : str or Path
        The file ('' : no snapshot is kept).
    period : float
        Seconds between two snapshots while the grippers do not change.
    """

    def __init__(self, path: str | Path, period: float = SNAPSHOT_PERIOD) -> None:
        self.path = Path(path) if path else None
        self.schedule = SnapshotSchedule(period)

    def restore_into(self, plant):
        """Restore ``plant`` from the file when there is one; return its state, else None.

        Raises
        ------
        SnapshotError
            If the file exists but does not hold a snapshot this plant can take.
        """
        if self.path is None:
            return None
        snapshot = read_snapshot(self.path)
        if snapshot is None:
            return None
        try:
            return plant.restore(snapshot)
        except ValueError as error:
            raise SnapshotError(f'the plant snapshot {self.path} does not fit: {error}') from None

    def keep(self, plant, now: float, grippers: object) -> bool:
        """Write the plant's snapshot when due at ``now`` [s]; return True when written."""
        if self.path is None or not self.schedule.due(now, grippers):
            return False
        write_snapshot(self.path, plant.snapshot())
        return True
