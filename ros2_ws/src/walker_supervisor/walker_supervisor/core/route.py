"""Route planning over the truss: which steps take the walker to a target node.

The walker stands with both grippers screwed in: the *base* gripper at ``base_node`` and the
other at ``other_node``, on neighbouring nodes. A step keeps the base and swings the other
gripper around it to another neighbour of the base node (a sweep of 90 or 180 degrees about the
base yaw axis); the gripper that moved becomes the new base.

The grippers keep their heading in the truss frame while they swing (the planner turns the tip
yaw J5 with the base yaw J1), so every sweep turns *both* physical yaw joints by the sweep angle,
whichever gripper is the base. Their limits therefore bound how far the walker's heading can
wind up: a route that turns the same way too often is impossible, and a half turn must go the
way that keeps later steps possible. The search state is (base node, other node, base gripper,
yaw angles), searched with Dijkstra's algorithm on the time each step takes.
"""

from __future__ import annotations

import dataclasses
import heapq
import math
from collections.abc import Callable

import numpy as np

from walker_core.joint_roles import other_gripper, validate_gripper
from walker_core.truss import Truss, UnknownNodeError

__all__ = ['Stance', 'PlannedStep', 'UnreachableTargetError', 'possible_steps', 'plan_route',
           'step_sweep', 'NO_LIMITS']


class UnreachableTargetError(ValueError):
    """No sequence of steps brings a gripper to the target node."""


@dataclasses.dataclass(frozen=True)
class Stance:
    """Both grippers screwed in on neighbouring nodes.

    Attributes
    ----------
    base_gripper : str
        ``'a'`` or ``'b'``: the gripper acting as the base (role J1 side).
    base_node, other_node : str
        Nodes of the base gripper and of the other gripper.
    """

    base_gripper: str
    base_node: str
    other_node: str

    def __post_init__(self) -> None:
        validate_gripper(self.base_gripper)
        if self.base_node == self.other_node:
            raise ValueError(f'both grippers cannot be in node {self.base_node!r}')

    @property
    def other_gripper(self) -> str:
        """The gripper that is not the base (the one the next step moves)."""
        return other_gripper(self.base_gripper)

    def node_of(self, gripper: str) -> str:
        """Node a gripper is screwed into."""
        return self.base_node if validate_gripper(gripper) == self.base_gripper \
            else self.other_node


@dataclasses.dataclass(frozen=True)
class PlannedStep:
    """One step: the non-base gripper swings about the base from one node to another.

    Attributes
    ----------
    base_gripper : str
        Gripper that stays attached (the base during the step).
    base_node : str
        Node it is attached to (the pivot).
    from_node, to_node : str
        Where the moving gripper leaves and where it is inserted.
    sweep : float
        Signed rotation of the moving gripper about the base yaw axis [rad], counterclockwise
        seen from above positive: +-pi/2, or +-pi for a half turn (its direction chosen by the
        route, to keep the yaw joints inside their limits).
    """

    base_gripper: str
    base_node: str
    from_node: str
    to_node: str
    sweep: float

    @property
    def moving_gripper(self) -> str:
        """The gripper that moves in this step."""
        return other_gripper(self.base_gripper)

    @property
    def is_half_turn(self) -> bool:
        """True for a 180 degree sweep."""
        return math.isclose(abs(self.sweep), math.pi)

    def stance_after(self) -> Stance:
        """Stance once the moving gripper is screwed in: it becomes the base."""
        return Stance(self.moving_gripper, self.to_node, self.base_node)


def step_sweep(truss: Truss, base_node: str, from_node: str, to_node: str) -> float:
    """Signed sweep angle [rad] about ``base_node`` from ``from_node`` to ``to_node``.

    A half turn is returned as +pi (it can go either way). Raises ValueError when either node is
    not a neighbour of the base node.
    """
    neighbours = truss.neighbors(base_node)
    for node in (from_node, to_node):
        if node not in neighbours:
            raise ValueError(f'node {node!r} is not next to the base node {base_node!r}: a step '
                             f'can only reach {", ".join(neighbours)}')
    if from_node == to_node:
        raise ValueError(f'the moving gripper is already in {to_node!r}')
    origin = truss.position(base_node)[:2]
    start = truss.position(from_node)[:2] - origin
    end = truss.position(to_node)[:2] - origin
    angle = math.atan2(start[0] * end[1] - start[1] * end[0], float(np.dot(start, end)))
    return math.pi if math.isclose(abs(angle), math.pi) else angle


YawLimits = tuple[float, float]
#: Without limits every sweep is possible.
NO_LIMITS: YawLimits = (-math.inf, math.inf)


def possible_steps(truss: Truss, stance: Stance, yaws: tuple[float, float] = (0.0, 0.0),
                   yaw_limits: YawLimits = NO_LIMITS) -> list[PlannedStep]:
    """Every step the walker can take from a stance, with the direction of each sweep.

    Parameters
    ----------
    truss, stance
        Where the walker stands.
    yaws : tuple of float
        Angles of the physical yaw joints ``a_yaw_joint`` and ``b_yaw_joint`` now [rad].
    yaw_limits : tuple of float
        Lower and upper limit of both yaw joints [rad].

    Returns
    -------
    list of PlannedStep
        One per reachable neighbour of the base, and per direction of a half turn, that keeps
        both yaw joints within their limits.
    """
    steps = []
    for node in truss.neighbors(stance.base_node):
        if node == stance.other_node:
            continue
        sweep = step_sweep(truss, stance.base_node, stance.other_node, node)
        for signed in ((math.pi, -math.pi) if math.isclose(sweep, math.pi) else (sweep,)):
            if all(yaw_limits[0] <= yaw + signed <= yaw_limits[1] for yaw in yaws):
                steps.append(PlannedStep(stance.base_gripper, stance.base_node,
                                         stance.other_node, node, signed))
    return steps


def _default_step_cost(step: PlannedStep) -> float:
    """Cost of a step when no timing model is given: a half turn counts as a bit more."""
    return 1.0 + 0.1 * abs(step.sweep) / math.pi


def plan_route(truss: Truss, stance: Stance, target: str,
               step_cost: Callable[[PlannedStep], float] | None = None,
               yaws: tuple[float, float] = (0.0, 0.0),
               yaw_limits: YawLimits = NO_LIMITS) -> list[PlannedStep]:
    """Plan the steps that bring a gripper into ``target`` at the least total cost.

    Parameters
    ----------
    truss : Truss
        The truss the walker stands on.
    stance : Stance
        Where the grippers are now.
    target : str
        Node to reach.
    step_cost : callable, optional
        Cost of a step, e.g. its duration [s]; by default about one per step, a half turn a
        little more.
    yaws : tuple of float
        Angles of ``a_yaw_joint`` and ``b_yaw_joint`` now [rad]; each step turns both by its
        sweep.
    yaw_limits : tuple of float
        Limits of the yaw joints [rad].

    Returns
    -------
    list of PlannedStep
        Empty when a gripper is already in the target node.

    Raises
    ------
    UnknownNodeError
        The target, or a node of the stance, is not on the truss.
    UnreachableTargetError
        No sequence of steps reaches the target (a truss too small to turn on, or yaw joints
        too wound up to turn the way the route needs).
    """
    truss.index(target)
    truss.index(stance.base_node)
    truss.index(stance.other_node)
    if stance.other_node not in truss.neighbors(stance.base_node):
        raise UnknownNodeError(f'the grippers are in {stance.base_node!r} and '
                               f'{stance.other_node!r}, which are not neighbouring nodes')
    if target in (stance.base_node, stance.other_node):
        return []
    cost = step_cost or _default_step_cost
    turns = round((yaws[0] - yaws[1]) / (math.pi / 2))  # keys hold quarter turns

    def key(s: Stance, yaw_a: float) -> tuple:
        return (s.base_node, s.other_node, s.base_gripper, round(yaw_a / (math.pi / 2)), turns)

    start = key(stance, yaws[0])
    best: dict[tuple, float] = {start: 0.0}
    previous: dict[tuple, tuple[tuple, PlannedStep]] = {}
    states = {start: (stance, yaws)}
    queue: list[tuple[float, int, tuple]] = [(0.0, 0, start)]
    counter = 1
    while queue:
        total, _, state = heapq.heappop(queue)
        if total > best.get(state, math.inf):
            continue
        current, current_yaws = states[state]
        if current.base_node == target:
            route = []
            while state in previous:
                state, step = previous[state]
                route.append(step)
            return route[::-1]
        for step in possible_steps(truss, current, current_yaws, yaw_limits):
            after = step.stance_after()
            after_yaws = (current_yaws[0] + step.sweep, current_yaws[1] + step.sweep)
            after_key = key(after, after_yaws[0])
            candidate = total + cost(step)
            if candidate < best.get(after_key, math.inf):
                best[after_key] = candidate
                previous[after_key] = (state, step)
                states[after_key] = (after, after_yaws)
                heapq.heappush(queue, (candidate, counter, after_key))
                counter += 1
    raise UnreachableTargetError(
        f'no sequence of steps from the stance {stance.base_node}/{stance.other_node} reaches '
        f'{target!r}: the truss ({truss.columns} x {truss.rows} nodes) offers no turn that '
        f"leads there within the yaw joints' limits [{yaw_limits[0]:.2f}, "
        f'{yaw_limits[1]:.2f}] rad (now {yaws[0]:.2f} and {yaws[1]:.2f} rad)')
