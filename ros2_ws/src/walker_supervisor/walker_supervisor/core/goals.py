"""Whether a ``step`` or ``walk_to`` goal can be taken, and its steps (free of ROS).

A goal is judged when it arrives, before anything moves, in this order: its target (a node
name, on the truss), the walker (no other goal under way, not in safe hold, measured, healthy,
no operator command under way, both grippers attached on neighbouring nodes), and the route
(``walk_to``: a sequence of steps within the yaw joints' limits; ``step``: one step away).
A refusal is a :class:`GoalRefusedError` whose message says why; nothing changed.
"""

from __future__ import annotations

from collections.abc import Mapping

from walker_core.gripper_state import GripperState
from walker_core.joint_roles import other_gripper
from walker_core.truss import Truss, UnknownNodeError
from walker_supervisor.core.route import (
    PlannedStep, Stance, UnreachableTargetError, YawLimits, plan_route, possible_steps)

__all__ = ['GOALS', 'GoalRefusedError', 'check_target', 'stance_now', 'goal_route']

#: The goals a walker takes: a walk to a node, or one step.
GOALS = ('walk_to', 'step')


class GoalRefusedError(ValueError):
    """A goal that cannot be taken now; the message says why. Nothing changed."""


def check_target(truss: Truss, target: str) -> None:
    """Refuse a target that is not a node name, or not a node of the truss.

    Raises
    ------
    GoalRefusedError
        Naming what is wrong with ``target``.
    """
    try:
        truss.index(target)
    except UnknownNodeError as error:
        raise GoalRefusedError(str(error)) from None


def stance_now(base: str, grippers: Mapping[str, str], nodes: Mapping[str, str],
               truss: Truss) -> Stance:
    """Return the stance a goal starts from: both grippers attached, on neighbouring nodes.

    Parameters
    ----------
    base : str
        The base gripper.
    grippers, nodes : mapping of str to str
        Each gripper's reported state and node.

    Raises
    ------
    GoalRefusedError
        A gripper is not attached, or the two are not on neighbouring nodes (an operator may
        have screwed one in elsewhere).
    """
    other = other_gripper(base)
    if any(grippers.get(g) != GripperState.ATTACHED for g in (base, other)):
        raise GoalRefusedError('a walk starts only with both grippers attached (now: '
                               + ', '.join(f'{g}: {grippers.get(g, "unknown")}'
                                           for g in ('a', 'b')) + ')')
    stance = Stance(base, nodes[base], nodes[other])
    if stance.other_node not in truss.neighbors(stance.base_node):
        raise GoalRefusedError(f'the grippers are in {stance.base_node} and '
                               f'{stance.other_node}, which are not neighbouring nodes')
    return stance


def goal_route(goal: str, truss: Truss, stance: Stance, target: str,
               yaws: tuple[float, float], yaw_limits: YawLimits) -> list[PlannedStep]:
    """Return the steps of a goal from ``stance``.

    Parameters
    ----------
    goal : str
        'walk_to' (the route to ``target``; empty when a gripper is in it) or 'step' (the one
        step to ``target``).
    yaws, yaw_limits : tuple of float
        The yaw joints' angles now and their limits [rad].

    Raises
    ------
    GoalRefusedError
        No route reaches ``target``, or it is not one step away.
    """
    try:
        if goal == 'walk_to':
            return plan_route(truss, stance, target, yaws=yaws, yaw_limits=yaw_limits)
        reachable = possible_steps(truss, stance, yaws, yaw_limits)
    except (UnknownNodeError, UnreachableTargetError) as error:
        raise GoalRefusedError(str(error)) from None
    steps = [s for s in reachable if s.to_node == target][:1]
    if not steps:
        raise GoalRefusedError(
            f'{target!r} is not one step away: from the base in {stance.base_node} a step '
            'reaches ' + (', '.join(sorted({s.to_node for s in reachable}))
                          or "no node within the yaw joints' limits"))
    return steps
