"""The rules that tie the supervisor's parameters to the shared ones (ROS-free).

The supervisor node checks them at start and on every runtime update of ``supervisor.*``;
``walker_bringup.core.configuration`` runs them with every other rule between sections.
"""

from __future__ import annotations

from walker_core.parameter_schema import ParameterError
from walker_core.robot_parameters import WalkerParameters
from walker_supervisor.core.sequencer import SupervisorParameters

__all__ = ['check_against_walker']


def check_against_walker(settings: SupervisorParameters, params: WalkerParameters) -> None:
    """Check ``supervisor.*`` against the gripper's insertion tolerance.

    Raises
    ------
    ParameterError
        Naming the parameters: an insertion alignment not smaller than
        ``gripper.insertion_position_tolerance``, or a descent region larger than it.
    """
    tolerance = params.gripper.insertion_position_tolerance
    if settings.insertion_alignment >= tolerance:
        raise ParameterError(
            f'supervisor.insertion_alignment ({settings.insertion_alignment} m) must be '
            f'smaller than gripper.insertion_position_tolerance ({tolerance} m)')
    if settings.descent_region > tolerance:
        raise ParameterError(
            f'supervisor.descent_region ({settings.descent_region} m) must not exceed '
            f'gripper.insertion_position_tolerance ({tolerance} m): the descent starts '
            f'only with the tip inside it')
