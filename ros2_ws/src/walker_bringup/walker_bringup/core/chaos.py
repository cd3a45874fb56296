"""A seeded chaos run: which node fails, in which phase of a step, how, and what it came to.

Part of the chaos operator tool, documented in docs/reliability.md ("The chaos driver as an
operator tool").

The ROS-free half of the chaos driver (:mod:`walker_bringup.chaos_driver`). From a seed,
:func:`plan_faults` lays out the faults of a run: which node of the graph's nine (the recorder,
the plant, the five joint controllers, the planner, the supervisor), in which of the four
phases of a step (extraction, coarse motion, fine motion, insertion), how (``SIGKILL``, a
crash the bring-up answers with a restart, or ``SIGSTOP`` held for a few seconds, a freeze,
then ``SIGCONT``), and how long after the phase began. The plan covers every node and every
phase once it has at least as many faults as there are of them, and never fails one node twice
in a row (the bring-up gives up on a node that dies too often in a row, which is another test).

What each fault came to (:class:`FaultOutcome`) is gathered by the driver;
:func:`summarise_outcomes` turns the outcomes into the run's figures: faults by kind, node and
phase, how many were held and recovered, grip losses, the time to recover (median and maximum)
and the resumes needed. :class:`GripCount` counts the instants with no gripper attached.
"""

from __future__ import annotations

import dataclasses
import math
import random
import statistics
from collections import Counter
from collections.abc import Iterable, Sequence

__all__ = ['NODES', 'PHASES', 'KILL', 'FREEZE', 'KINDS', 'Fault', 'plan_faults',
           'FaultOutcome', 'GripCount', 'summarise_outcomes', 'moved_on', 'next_target', 'SETTLE']

#: The nine nodes of a recorded graph of separate processes (``run_all.py --serve``).
NODES = ('recorder', 'plant', 'controller_a_yaw', 'controller_a_pitch', 'controller_vertex',
         'controller_b_pitch', 'controller_b_yaw', 'planner', 'supervisor')
#: The four phases of a step, in the order a step runs them (``walker_msgs/StepPhase``).
PHASES = ('EXTRACTION', 'COARSE', 'FINE', 'INSERTION')
#: A crash: the process ends at once, the bring-up starts it again.
KILL = 'SIGKILL'
#: A freeze: the process is stopped for a while, then continued (``SIGCONT``).
FREEZE = 'SIGSTOP'
KINDS = (KILL, FREEZE)
#: [s] how long a freeze lasts, by default: beyond the shipped watchdog (1 s), so the
#: supervisor sees the frozen node as silent, as the faults of the reliability issue did
DEFAULT_FREEZE = (2.0, 5.0)
#: [s] wall-clock wait after the phase began before the fault, by default
DEFAULT_DELAY = (0.0, 0.5)
#: [s] wall clock the walker must go on without a hold before a fault counts as recovered
SETTLE = 5.0


@dataclasses.dataclass(frozen=True)
class Fault:
    """One planned fault.

    Attributes
    ----------
    index : int
        Its place in the run (0-based).
    node : str
        The node's name in the graph (``plant``, ``controller_vertex``, ...).
    phase : str
        The phase of a step it is planned in (one of :data:`PHASES`).
    kind : str
        :data:`KILL` or :data:`FREEZE`.
    delay : float
        Wall-clock seconds after the phase began before the fault (>= 0).
    hold : float
        Seconds the process stays stopped, for a freeze (0 for a kill).
    """

    index: int
    node: str
    phase: str
    kind: str
    delay: float
    hold: float

    def __post_init__(self) -> None:
        if self.phase not in PHASES:
            raise ValueError(f'fault {self.index}: phase must be one of {PHASES}, got '
                             f'{self.phase!r}')
        if self.kind not in KINDS:
            raise ValueError(f'fault {self.index}: kind must be one of {KINDS}, got '
                             f'{self.kind!r}')
        for name in ('delay', 'hold'):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f'fault {self.index}: {name} must be a number of seconds '
                                 f'>= 0, got {value!r}')
        if (self.kind == FREEZE) != (self.hold > 0.0):
            raise ValueError(f'fault {self.index}: a freeze holds for a time > 0 and a kill '
                             f'for none, got {self.kind} for {self.hold} s')

    def describe(self) -> str:
        """One line: ``#3 SIGSTOP planner in COARSE (+0.2 s, 3.1 s)``."""
        held = f', {self.hold:.1f} s' if self.kind == FREEZE else ''
        return (f'#{self.index} {self.kind} {self.node} in {self.phase} '
                f'(+{self.delay:.1f} s{held})')


def _range(name: str, bounds: tuple[float, float]) -> tuple[float, float]:
    low, high = (float(b) for b in bounds)
    if not (math.isfinite(low) and math.isfinite(high) and 0.0 <= low <= high):
        raise ValueError(f'{name} must be (low, high) seconds with 0 <= low <= high, got '
                         f'{bounds!r}')
    return low, high


def _blocks(rng: random.Random, items: Sequence[str], count: int,
            order: Sequence[str] | None = None) -> list[str]:
    """``count`` items, from rounds of all of them, no item twice in a row.

    Each round shuffled, or sorted as in ``order``.
    """
    chosen: list[str] = []
    while len(chosen) < count:
        block = list(items)
        rng.shuffle(block)
        if order is not None:
            block.sort(key=order.index)
        if chosen and len(block) > 1 and block[0] == chosen[-1]:
            block.append(block.pop(0))
        chosen += block
    return chosen[:count]


def plan_faults(seed: int, count: int, nodes: Sequence[str] = NODES,
                phases: Sequence[str] = PHASES, freeze_share: float = 0.5,
                freeze: tuple[float, float] = DEFAULT_FREEZE,
                delay: tuple[float, float] = DEFAULT_DELAY,
                in_step_order: bool = False) -> tuple[Fault, ...]:
    """Plan ``count`` faults from ``seed``: the same seed gives the same plan.

    Nodes come in shuffled rounds of all of ``nodes``, phases in shuffled rounds of all of
    ``phases``, so every node and every phase has a fault once ``count`` reaches their number;
    no node fails twice in a row. The kinds are a shuffled mix with ``round(freeze_share *
    count)`` freezes.

    Parameters
    ----------
    seed : int
        Seed of the plan's random choices.
    count : int
        Number of faults (>= 1).
    nodes : sequence of str
        The nodes to fail (default: the nine of :data:`NODES`).
    phases : sequence of str
        The phases to fail them in (a subset of :data:`PHASES`, default all four).
    freeze_share : float
        Share of freezes among the faults, in [0, 1].
    freeze : (float, float)
        Range [s] of a freeze's length, drawn uniformly.
    delay : (float, float)
        Range [s] of the wait after the phase began, drawn uniformly.
    in_step_order : bool
        Each round of phases in the order a step runs them, so that its faults can fall in
        one step (a fault whose phase has passed waits for the next step's).

    Returns
    -------
    tuple of Fault
        In the order the driver applies them.

    Raises
    ------
    ValueError
        Naming the argument that is out of range (no node, an unknown phase, ...).
    """
    if isinstance(count, bool) or not isinstance(count, int) or count < 1:
        raise ValueError(f'count must be a whole number of faults >= 1, got {count!r}')
    if isinstance(seed, bool) or not isinstance(seed, int):
        raise ValueError(f'seed must be an integer, got {seed!r}')
    nodes, phases = tuple(nodes), tuple(phases)
    if not nodes or len(set(nodes)) != len(nodes) or not all(
            isinstance(n, str) and n for n in nodes):
        raise ValueError(f'nodes must be distinct node names, got {nodes!r}')
    if not phases or len(set(phases)) != len(phases) or not set(phases) <= set(PHASES):
        raise ValueError(f'phases must be distinct phases among {PHASES}, got {phases!r}')
    if not (isinstance(freeze_share, (int, float)) and 0.0 <= freeze_share <= 1.0):
        raise ValueError(f'freeze_share must be in [0, 1], got {freeze_share!r}')
    freeze, delay = _range('freeze', freeze), _range('delay', delay)
    if freeze_share > 0.0 and freeze[0] <= 0.0:
        raise ValueError(f'freeze must last more than 0 s, got {freeze!r}')
    rng = random.Random(seed)
    chosen_nodes = _blocks(rng, nodes, count)
    chosen_phases = _blocks(rng, phases, count, PHASES if in_step_order else None)
    freezes = round(freeze_share * count)
    kinds = [FREEZE] * freezes + [KILL] * (count - freezes)
    rng.shuffle(kinds)
    return tuple(
        Fault(index, node, phase, kind, round(rng.uniform(*delay), 3),
              round(rng.uniform(*freeze), 3) if kind == FREEZE else 0.0)
        for index, (node, phase, kind) in enumerate(zip(chosen_nodes, chosen_phases, kinds,
                                                        strict=True)))


@dataclasses.dataclass
class FaultOutcome:
    """What one fault came to, as the driver saw it.

    Attributes
    ----------
    fault : Fault
        The fault planned.
    phase : str
        The phase the walker was in when the fault was applied (the phase seen last).
    held : bool
        The supervisor held the step (``SAFE_HOLD``) after the fault.
    recovered : bool
        The node is back (started again, or continued) and the walker has left the hold by
        ``resume`` (or never held) and moves on.
    resumes : int
        Resumes the supervisor accepted before the walker moved on.
    time_to_recover : float
        Wall-clock seconds from the fault to the walker moving on again (nan if never).
    reason : str
        The hold's reason, or why the fault was not recovered.
    """

    fault: Fault
    phase: str
    held: bool = False
    recovered: bool = False
    resumes: int = 0
    time_to_recover: float = math.nan
    reason: str = ''

    def as_dict(self) -> dict:
        """Return the outcome as JSON-ready fields."""
        return {**dataclasses.asdict(self.fault), 'phase_seen': self.phase,
                'held': self.held, 'recovered': self.recovered, 'resumes': self.resumes,
                'time_to_recover': None if math.isnan(self.time_to_recover)
                else round(self.time_to_recover, 3), 'reason': self.reason}


def next_target(targets: Sequence[str], current: str, attached: set[str]) -> str:
    """Return where the walker walks next: ``current`` until a gripper is in it, then another.

    Parameters
    ----------
    targets : sequence of str
        The truss nodes the walker walks between.
    current : str
        The target walked to so far.
    attached : set of str
        The nodes a gripper is screwed into now.

    Raises
    ------
    ValueError
        If every target holds a gripper: a walk goal would end at once with nothing walked
        (two nodes one step apart that both hold a gripper once a step ends, such as the
        start's base node and a node next to it).
    """
    if current not in attached:
        return current
    free = [target for target in targets if target not in attached]
    if not free:
        raise ValueError(f'every target ({", ".join(targets)}) has a gripper in it: there is '
                         'no step to walk; choose targets one step apart from different nodes')
    return free[0]


def moved_on(phases: Sequence[tuple[float, bool]], back: float, now: float,
             settle: float = SETTLE) -> float | None:
    """Tell when the walker moved on for good after a fault; None while it has not.

    It has moved on when, since the faulty node came back, a phase other than the hold was
    published after the last hold, the walker is not holding now, and ``settle`` seconds have
    passed since without another hold (a hold the fault brings late, a node started again that
    does not answer yet, is resumed meanwhile).

    Parameters
    ----------
    phases : sequence of (float, bool)
        Each phase message seen, in order: when it was received [s] and whether it is the
        hold (``SAFE_HOLD``).
    back : float
        When the faulty node came back [s] (started again, or continued).
    now : float
        The time now [s], on the same clock.
    settle : float
        Seconds without a hold it takes.

    Returns
    -------
    float or None
        When the first phase after the last hold was received [s].
    """
    if not phases or phases[-1][1]:
        return None
    since = max((t for t, hold in phases if t > back and hold), default=back)
    moved = next((t for t, hold in phases if t > since and not hold), None)
    return moved if moved is not None and now - moved >= settle else None


class GripCount:
    """Count the instants (gripper-state messages) with no gripper attached."""

    def __init__(self) -> None:
        self.instants = 0
        self.losses = 0
        self.first_loss_stamp: float | None = None

    def add(self, attached: Iterable[str], stamp: float) -> None:
        """Count one instant: the names of the grippers attached, its stamp [s]."""
        self.instants += 1
        if not list(attached):
            self.losses += 1
            if self.first_loss_stamp is None:
                self.first_loss_stamp = stamp


def _by(outcomes: Sequence[FaultOutcome], key) -> dict[str, int]:
    return dict(sorted(Counter(key(o) for o in outcomes).items()))


def summarise_outcomes(outcomes: Sequence[FaultOutcome], grip_losses: int,
                       bag_grip_losses: int | None = None) -> dict:
    """Return the run's figures from its outcomes.

    Parameters
    ----------
    outcomes : sequence of FaultOutcome
        One per fault applied.
    grip_losses : int
        Instants with no gripper attached seen live.
    bag_grip_losses : int, optional
        The same counted in the bag afterwards.

    Returns
    -------
    dict
        ``faults`` (the number), ``by_kind``, ``by_node``, ``by_phase`` (planned) and
        ``by_phase_seen``, ``held``, ``recovered``, ``grip_losses`` (live and bag),
        ``time_to_recover`` (``median``, ``max`` [s] over the recovered faults) and
        ``resumes`` (``total``, ``max`` for one fault).
    """
    times = [o.time_to_recover for o in outcomes if o.recovered]
    resumes = [o.resumes for o in outcomes]
    return {
        'faults': len(outcomes),
        'by_kind': _by(outcomes, lambda o: o.fault.kind),
        'by_node': _by(outcomes, lambda o: o.fault.node),
        'by_phase': _by(outcomes, lambda o: o.fault.phase),
        'by_phase_seen': _by(outcomes, lambda o: o.phase),
        'held': sum(o.held for o in outcomes),
        'recovered': sum(o.recovered for o in outcomes),
        'grip_losses': {'live': grip_losses, 'bag': bag_grip_losses},
        'time_to_recover': {'median': round(statistics.median(times), 3) if times else None,
                            'max': round(max(times), 3) if times else None},
        'resumes': {'total': sum(resumes), 'max': max(resumes, default=0)},
    }
