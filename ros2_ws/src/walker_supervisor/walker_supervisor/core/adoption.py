"""Taking up a step an earlier supervisor left unfinished (a restart), free of ROS.

While a step runs the supervisor keeps it on record (:class:`RecordedStep`: its nodes, base,
the heading of its base frame and the truss map it was planned on; the ROS layer keeps it in a
file, :mod:`walker_supervisor.step_state`). A supervisor that starts with a gripper free reads
it back and takes the step up, in safe hold for an operator's resume, only if the grippers are
as the record says: the base attached in the base node, the other not attached. A record
that does not describe the walker is forgotten, so that it cannot be taken up later by mistake.

The step is taken up in the frame it was planned in: the base node and the target where the
map on record puts them, with the recorded heading. The heading was measured through the map's
estimates of the stance's nodes, so it fits those and not the nodes' nominal places; on a
truss as built, a target taken from the parameter file instead would sit off the hole by the
nodes' placement errors and the heading's error through them.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np

from walker_core.gripper_state import GripperState
from walker_core.joint_roles import other_gripper, physical_to_roles
from walker_core.kinematics import KinematicsError, WalkerKinematics
from walker_supervisor.core.route import PlannedStep, step_sweep
from walker_supervisor.core.step_geometry import BaseFrame, StepTargets, recovery_targets
from walker_supervisor.core.truss_map import TrussMap

__all__ = ['RecordedStep', 'AdoptionRefusedError', 'adopt_step']


@dataclasses.dataclass(frozen=True)
class RecordedStep:
    """What is needed to complete an interrupted step.

    Attributes
    ----------
    base_gripper, base_node, from_node, to_node : str
    heading : float
        [rad] of the base frame in the truss frame.
    survey : dict or None
        The truss map the step was planned on (a survey file's content), or None (a record
        written without one: the nodes' nominal places are taken).
    """

    base_gripper: str
    base_node: str
    from_node: str
    to_node: str
    heading: float
    survey: dict | None = None


class AdoptionRefusedError(ValueError):
    """The recorded step cannot be taken up; the message says why."""


def adopt_step(record: RecordedStep, grippers: Mapping[str, str], nodes: Mapping[str, str],
               positions: np.ndarray, survey: TrussMap, kinematics: WalkerKinematics,
               approach_height: float) -> tuple[PlannedStep, StepTargets] | None:
    """Return the recorded step and its targets from where the arm is, or None.

    Parameters
    ----------
    record : RecordedStep
    grippers, nodes : mapping of str to str
        Each gripper's reported state and node now.
    positions : ndarray, shape (5,)
        Joint angles now, physical order [rad].
    survey : TrussMap
        The truss map to take the nodes' places from (the record's, loaded by the caller).
    kinematics
    approach_height : float
        [m] above a hole where insertion starts (``gripper.approach_height``).

    Returns
    -------
    tuple or None
        None when the record does not describe the walker now (forget it).

    Raises
    ------
    AdoptionRefusedError
        The record describes the walker, but its step cannot be completed from here.
    """
    base = record.base_gripper
    if base not in ('a', 'b') or grippers.get(base) != GripperState.ATTACHED \
            or grippers.get(other_gripper(base)) == GripperState.ATTACHED \
            or nodes.get(base) != record.base_node:
        return None
    try:
        sweep = step_sweep(survey.truss, record.base_node, record.from_node, record.to_node)
        step = PlannedStep(base, record.base_node, record.from_node, record.to_node, sweep)
        frame = BaseFrame(survey.position(record.base_node), record.heading)
        targets = recovery_targets(kinematics, frame, step, survey.position(step.from_node),
                                   survey.position(step.to_node),
                                   physical_to_roles(positions, base), approach_height)
    except (ValueError, KinematicsError) as error:
        raise AdoptionRefusedError(str(error)) from None
    return step, targets
