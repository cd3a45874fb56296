"""Taking up a step an earlier supervisor left unfinished (a restart), free of ROS.

While a step runs the supervisor keeps it on record (:class:`RecordedStep`: its nodes, base
and the heading of its base frame; the ROS layer keeps it in a file,
:mod:`walker_supervisor.step_state`). A supervisor that starts with a gripper free reads it
back and takes the step up, in safe hold for an operator's resume, only if the grippers are
as the record says: the base attached in the base node, the other not attached. A record
that does not describe the walker is forgotten, so that it cannot be taken up later by mistake.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np

from walker_core.gripper_state import GripperState
from walker_core.joint_roles import other_gripper, physical_to_roles
from walker_core.kinematics import KinematicsError, WalkerKinematics
from walker_core.truss import Truss
from walker_supervisor.core.route import PlannedStep, step_sweep
from walker_supervisor.core.step_geometry import BaseFrame, StepTargets, recovery_targets

__all__ = ['RecordedStep', 'AdoptionRefusedError', 'adopt_step']


@dataclasses.dataclass(frozen=True)
class RecordedStep:
    """What is needed to complete an interrupted step.

    Attributes
    ----------
    base_gripper, base_node, from_node, to_node : str
    heading : float
        [rad] of the base frame in the truss frame.
    """

    base_gripper: str
    base_node: str
    from_node: str
    to_node: str
    heading: float


class AdoptionRefusedError(ValueError):
    """The recorded step cannot be taken up; the message says why."""


def adopt_step(record: RecordedStep, grippers: Mapping[str, str], nodes: Mapping[str, str],
               positions: np.ndarray, truss: Truss, kinematics: WalkerKinematics,
               approach_height: float) -> tuple[PlannedStep, StepTargets] | None:
    """Return the recorded step and its targets from where the arm is, or None.

    Parameters
    ----------
    record : RecordedStep
    grippers, nodes : mapping of str to str
        Each gripper's reported state and node now.
    positions : ndarray, shape (5,)
        Joint angles now, physical order [rad].
    truss, kinematics
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
        sweep = step_sweep(truss, record.base_node, record.from_node, record.to_node)
        step = PlannedStep(base, record.base_node, record.from_node, record.to_node, sweep)
        frame = BaseFrame(truss.position(record.base_node), record.heading)
        targets = recovery_targets(kinematics, frame, step, truss.position(step.from_node),
                                   truss.position(step.to_node),
                                   physical_to_roles(positions, base), approach_height)
    except (ValueError, KinematicsError) as error:
        raise AdoptionRefusedError(str(error)) from None
    return step, targets
