"""The screw grippers: insertion tolerance, jamming, the release interlock, screw timing.

Plain logic, no simulator: the plant asks it what a command does and applies the result (a
rigid attachment constraint while screwing in and attached, none when free).

A screw-in succeeds only when the gripper's contact point is within
``gripper.insertion_position_tolerance`` of the hole (the segment of the hole axis from the
mouth down to ``truss.hole_depth``) and its axis within ``gripper.insertion_axis_tolerance`` of
the hole axis; the thread then takes ``gripper.screw_time`` to draw it in (SCREWING) before it
is ATTACHED. Outside the tolerance the thread jams at once (JAMMED): the gripper stays free and
the message says by how much it missed. Unscrewing takes ``gripper.screw_time`` too
(UNSCREWING, still attached) and is refused, by the plant itself as by the hardware's
interlock, unless the other gripper is ATTACHED: the walker never lets go of the truss.

The tip (:attr:`GripperLogic.tip`) is the gripper that moves or moves next: the one unscrewed
last, free, screwing in or jammed; once it is ATTACHED, the other one (the gripper the next step
releases, as the supervisor makes the gripper that just screwed in its base). While both are
attached at the start, it is the gripper that is not the start's base.

A fouled thread (debris, a damaged hole) can be injected for tests of the supervisor's retry and
abort: :attr:`GripperLogic.fouled_screw_ins` coming screw-ins jam whatever the alignment.
"""

from __future__ import annotations

import dataclasses
import math

from walker_core.gripper_state import TURNING, GripperState
from walker_core.joint_roles import GRIPPERS, other_gripper, validate_gripper

__all__ = ['HoleAlignment', 'GripperStatus', 'GripperCommandError',
           'InterlockError', 'ScrewOutcome', 'GripperLogic', 'hole_alignment']

# [s] a screw timer within this of its end has ended (sums of float steps are not exact)
_TIME_EPSILON = 1e-9


class GripperCommandError(ValueError):
    """A gripper command that is refused; nothing changed. The message says why."""


class InterlockError(GripperCommandError):
    """Releasing this gripper would leave the walker holding on to nothing."""


@dataclasses.dataclass(frozen=True)
class HoleAlignment:
    """Where a gripper is relative to the nearest hole.

    Attributes
    ----------
    node : str
        Name of the nearest node.
    position_error : float
        Distance [m] of the gripper's contact point from the hole (the axis segment from the
        mouth to the bottom).
    axis_error : float
        Angle [rad] between the gripper axis and the hole axis.
    """

    node: str
    position_error: float
    axis_error: float


def hole_alignment(position, z_axis, truss, hole_depth: float,
                   node_errors: dict[str, tuple[float, float, float]] | None = None
                   ) -> HoleAlignment:
    """Measure a gripper against the nearest hole.

    Parameters
    ----------
    position : sequence of 3 float
        Gripper contact point [m] in the truss frame.
    z_axis : sequence of 3 float
        Gripper axis (unit vector pointing away from the truss when inserted).
    truss : walker_core.truss.Truss
        The truss; holes have their mouth at each node (z = 0) and axis +z.
    hole_depth : float
        Depth [m] of the holes.
    node_errors : dict, optional
        Node name -> placement error (x, y, z) [m] of the nodes that are off the grid
        (:class:`walker_sim.core.imperfections.NodePlacement`); the nearest node is found on
        the grid, errors being far smaller than the spacing.

    Notes
    -----
    Plain float arithmetic: the plant measures both grippers every control period.
    """
    x, y, z = (float(v) for v in position)
    column = min(max(round((x - truss.origin[0]) / truss.spacing), 0), truss.columns - 1)
    row = min(max(round((y - truss.origin[1]) / truss.spacing), 0), truss.rows - 1)
    node = f'n{column}_{row}'
    dx = x - (truss.origin[0] + column * truss.spacing)
    dy = y - (truss.origin[1] + row * truss.spacing)
    if node_errors and node in node_errors:
        error_x, error_y, error_z = node_errors[node]
        dx, dy, z = dx - error_x, dy - error_y, z - error_z
    dz = z + min(max(-z, 0.0), hole_depth)  # from the nearest point of the hole segment
    ax, ay, az = (float(v) for v in z_axis)
    cosine = min(max(az / math.sqrt(ax * ax + ay * ay + az * az), -1.0), 1.0)
    return HoleAlignment(node=node,
                         position_error=math.sqrt(dx * dx + dy * dy + dz * dz),
                         axis_error=math.acos(cosine))


@dataclasses.dataclass(frozen=True)
class GripperStatus:
    """One gripper's state, as ``walker_msgs/GripperState`` reports it.

    Attributes
    ----------
    name : str
        ``'a'`` or ``'b'``.
    mode : GripperState
        FREE, SCREWING, ATTACHED, UNSCREWING or JAMMED.
    node : str
        Node the gripper is attached to, screwing into or jammed at (``''`` when free).
    message : str
        Why the last command failed, or ``''``.
    progress : float
        Fraction of the screw-in or unscrew done, in [0, 1] (0 when neither is under way).
    """

    name: str
    mode: GripperState
    node: str = ''
    message: str = ''
    progress: float = 0.0


@dataclasses.dataclass(frozen=True)
class ScrewOutcome:
    """Result of a screw-in request that was not refused.

    Attributes
    ----------
    success : bool
        True when the screw-in started; False when it jammed.
    status : GripperStatus
        The gripper's state after the request.
    """

    success: bool
    status: GripperStatus


class GripperLogic:
    """State machine of both grippers and the base gripper.

    Parameters
    ----------
    position_tolerance : float
        Insertion position tolerance [m].
    axis_tolerance : float
        Insertion axis tolerance [rad].
    screw_time : float
        Duration [s] of a screw-in or an unscrew.
    """

    def __init__(self, position_tolerance: float, axis_tolerance: float,
                 screw_time: float) -> None:
        self.position_tolerance = position_tolerance
        self.axis_tolerance = axis_tolerance
        self.screw_time = screw_time
        self._status = {g: GripperStatus(g, GripperState.FREE) for g in GRIPPERS}
        self._elapsed = dict.fromkeys(GRIPPERS, 0.0)
        self._base = 'a'
        self._tip = 'b'
        #: Coming screw-ins that jam whatever the alignment (an injected fouled thread); each
        #: one that jams counts it down.
        self.fouled_screw_ins = 0

    @classmethod
    def from_parameters(cls, params) -> 'GripperLogic':
        """Build from the shared ``gripper.*`` parameters."""
        g = params.gripper
        return cls(g.insertion_position_tolerance, g.insertion_axis_tolerance, g.screw_time)

    # ------------------------------------------------------------------ state
    def reset(self, attached: dict[str, str], base: str) -> None:
        """Set the start state: ``attached`` maps gripper -> node for the attached ones.

        Raises
        ------
        GripperCommandError
            If the base gripper is not among the attached ones.
        """
        validate_gripper(base)
        if base not in attached:
            raise GripperCommandError(f'the base gripper {base!r} must start attached')
        for gripper in GRIPPERS:
            node = attached.get(gripper)
            mode = GripperState.ATTACHED if node else GripperState.FREE
            self._status[gripper] = GripperStatus(gripper, mode, node or '')
            self._elapsed[gripper] = 0.0
        self._base = base
        self._tip = other_gripper(base)

    def timers(self) -> dict[str, tuple[GripperStatus, float]]:
        """Each gripper's status and the seconds [s] its screw-in or unscrew has run."""
        return {g: (self._status[g], self._elapsed[g]) for g in GRIPPERS}

    def restore(self, timers: dict[str, tuple[GripperState, str, float]], base: str,
                tip: str = '') -> None:
        """Put every gripper back in a recorded state: gripper -> ``(mode, node, elapsed)``.

        The inverse of :meth:`timers` (a plant started again, :mod:`walker_sim.core.snapshot`);
        ``tip`` is the recorded :attr:`tip` (empty: the gripper that is not ``base``).

        Raises
        ------
        GripperCommandError
            If a gripper is missing, or the base gripper is not held by the truss (nothing
            changes).
        """
        validate_gripper(base)
        if set(timers) != set(GRIPPERS):
            raise GripperCommandError(f'a gripper state for each of {GRIPPERS} is needed, got '
                                      f'{sorted(timers)}')
        if timers[base][0] not in (GripperState.ATTACHED, GripperState.SCREWING,
                                   GripperState.UNSCREWING):
            raise GripperCommandError(f'the base gripper {base!r} must be held by the truss')
        tip = validate_gripper(tip) if tip else other_gripper(base)
        for gripper, (mode, node, elapsed) in timers.items():
            busy = mode in TURNING
            progress = min(1.0, elapsed / self.screw_time) if busy else 0.0
            self._status[gripper] = GripperStatus(gripper, GripperState(mode), node,
                                                  progress=progress)
            self._elapsed[gripper] = float(elapsed)
        self._base = base
        self._tip = tip

    def status(self, gripper: str) -> GripperStatus:
        """State of one gripper."""
        return self._status[validate_gripper(gripper)]

    def statuses(self) -> dict[str, GripperStatus]:
        """``'a'``/``'b'`` -> state of the gripper (a new dict)."""
        return dict(self._status)

    @property
    def base(self) -> str:
        """The gripper holding the walker: the attached one, or the one attached longest."""
        return self._base

    @property
    def tip(self) -> str:
        """The gripper that moves or moves next (see the module's description)."""
        return self._tip

    @property
    def busy(self) -> bool:
        """True while a screw-in or an unscrew is under way."""
        return not TURNING.isdisjoint([status.mode for status in self._status.values()])

    def holds(self, gripper: str) -> bool:
        """Return True while the gripper is held by its node (screwing, attached, unscrewing)."""
        return self.status(gripper).mode in (GripperState.SCREWING, GripperState.ATTACHED,
                                             GripperState.UNSCREWING)

    # --------------------------------------------------------------- commands
    def request_screw_in(self, gripper: str, alignment: HoleAlignment, where: str = ''
                         ) -> ScrewOutcome:
        """Start screwing a gripper into the hole under it, or jam.

        ``where`` (optional) says where the gripper is against the node (the plant's contact:
        resting on its face, say); a jam's message ends with it.

        Raises
        ------
        GripperCommandError
            If the gripper is already attached, screwing or unscrewing (nothing changes).
        """
        current = self.status(gripper)
        if current.mode in (GripperState.ATTACHED, GripperState.SCREWING,
                            GripperState.UNSCREWING):
            raise GripperCommandError(
                f'gripper {gripper} is {current.mode.name} at node {current.node}: screw-in '
                f'needs a free gripper')
        misses = []
        if alignment.position_error > self.position_tolerance:
            misses.append(f'position error {alignment.position_error * 1e3:.2f} mm exceeds '
                          f'the tolerance {self.position_tolerance * 1e3:.2f} mm')
        if alignment.axis_error > self.axis_tolerance:
            misses.append(f'axis error {math.degrees(alignment.axis_error):.2f} deg exceeds '
                          f'the tolerance {math.degrees(self.axis_tolerance):.2f} deg')
        if self.fouled_screw_ins > 0:
            self.fouled_screw_ins -= 1
            misses.append(f'the thread is fouled (injected fault; {self.fouled_screw_ins} '
                          f'more screw-ins will jam)')
        if misses:
            message = (f'jammed at node {alignment.node}: ' + '; '.join(misses))
            if where:
                message += f'; {where}'
            self._status[gripper] = GripperStatus(gripper, GripperState.JAMMED, alignment.node,
                                                  message)
            return ScrewOutcome(False, self._status[gripper])
        self._status[gripper] = GripperStatus(gripper, GripperState.SCREWING, alignment.node)
        self._elapsed[gripper] = 0.0
        return ScrewOutcome(True, self._status[gripper])

    def request_unscrew(self, gripper: str) -> GripperStatus:
        """Start unscrewing a gripper (or back a jammed one out at once).

        Raises
        ------
        InterlockError
            If the other gripper is not ATTACHED (nothing changes).
        GripperCommandError
            If the gripper is free, or already screwing or unscrewing.
        """
        current = self.status(gripper)
        other = self.status(other_gripper(gripper))
        if current.mode == GripperState.JAMMED:
            self._status[gripper] = GripperStatus(gripper, GripperState.FREE)
            return self._status[gripper]
        if current.mode != GripperState.ATTACHED:
            raise GripperCommandError(
                f'gripper {gripper} is {current.mode.name}: only an attached gripper can be '
                f'unscrewed')
        if other.mode != GripperState.ATTACHED:
            raise InterlockError(
                f'interlock: gripper {gripper} holds the walker and gripper {other.name} is '
                f'{other.mode.name}, not ATTACHED; releasing {gripper} would let go of the '
                f'truss')
        self._status[gripper] = GripperStatus(gripper, GripperState.UNSCREWING, current.node)
        self._elapsed[gripper] = 0.0
        self._tip = gripper
        if self._base == gripper:
            self._base = other.name
        return self._status[gripper]

    def advance(self, dt: float) -> list[GripperStatus]:
        """Advance the screw timers by ``dt`` seconds; return the grippers that changed state.

        A screw-in completes as ATTACHED, an unscrew as FREE.
        """
        changed = []
        for gripper in GRIPPERS:
            status = self._status[gripper]
            if status.mode not in TURNING:
                continue
            self._elapsed[gripper] += dt
            done = self._elapsed[gripper] >= self.screw_time - _TIME_EPSILON
            progress = 1.0 if done else self._elapsed[gripper] / self.screw_time
            if not done:
                self._status[gripper] = dataclasses.replace(status, progress=progress)
                continue
            if status.mode == GripperState.SCREWING:
                self._status[gripper] = GripperStatus(gripper, GripperState.ATTACHED, status.node)
                self._tip = other_gripper(gripper)
            else:
                self._status[gripper] = GripperStatus(gripper, GripperState.FREE)
            changed.append(self._status[gripper])
        return changed
