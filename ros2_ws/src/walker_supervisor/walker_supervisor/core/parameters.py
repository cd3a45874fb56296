"""The supervisor's parameters (section ``supervisor.``) and every rule across them.

Each value's range is in its declaration (:func:`walker_core.parameter_schema.parameter`); the
rules that join two or more values are here, in one place:

* within the section (:func:`check_section`, run by the dataclass itself): the insertion
  alignment is tighter than the coarse-to-fine region; the descent region lies between them;
  the descent's axis tolerance is wider than the descent region;
* against the gripper (:func:`check_with_gripper`): the insertion alignment is tighter than,
  and the descent region no wider than, ``gripper.insertion_position_tolerance`` (the descent
  starts only with the tip inside it);
* against other nodes' sections (:func:`check_with_planner`, :func:`check_with_control`, for a
  loader that has them all): ``coarse_start_tolerance`` below ``planner.stream.start_tolerance``
  (the planner refuses a stream that starts farther), and ``relaxation_wait`` at least
  ``control.relaxation.duration`` (the next stance is measured once the dither is over).

A rule broken raises :class:`~walker_core.parameter_schema.ParameterError` naming the values;
the node refuses such an update and changes nothing.
"""

from __future__ import annotations

import dataclasses

from walker_core.parameter_schema import ParameterError, parameter
from walker_core.settling import settle_time_parameter

__all__ = ['SupervisorParameters', 'check_section', 'check_with_gripper', 'check_with_planner',
           'check_with_control']


@dataclasses.dataclass(frozen=True)
class SupervisorParameters:
    """Switching regions and fault limits of the step (section ``supervisor.``)."""

    coarse_to_fine_region: float = parameter(
        'tip distance from the point above the target at which coarse motion hands over to '
        'fine motion', 'm', 0.001, 0.5, read_only=False)
    insertion_alignment: float = parameter(
        'largest tip distance from the point above the hole at which insertion may start, '
        "and from the hole's axis at its mouth at which the screw-in may start",
        'm', 1e-5, 0.05, read_only=False)
    settle_velocity: float = parameter(
        'joints slower than this count as still: the descent starts with every joint below '
        'it, the screw-in after mouth_settle_time below it',
        'rad/s', 1e-4, 1.0, read_only=False)
    settle_time: float = settle_time_parameter()  # declared in the model: the report uses it
    phase_timeout: float = parameter(
        'time a phase may overrun its planned duration before the step is aborted', 's',
        0.1, 600.0, read_only=False)
    max_insertion_attempts: int = parameter(
        'screw-in attempts before a jammed insertion aborts the step', '', 1, 10,
        read_only=False)
    watchdog_timeout: float = parameter(
        'the plant, its gripper heartbeat and each joint controller must be heard from this '
        'often (steady clock), or the walker goes to safe hold', 's', 0.05, 60.0,
        read_only=False)
    coarse_start_tolerance: float = parameter(
        'largest joint distance from the start of the coarse motion at which it may begin: '
        'the lifted arm waits in EXTRACTION until it is there; and from the first point of a '
        'way back that is a line (gripper vertical), beyond which the gripper is first turned '
        'vertical where it is (keep it below planner.stream.start_tolerance, which refuses a '
        'stream that starts farther)', 'rad',
        1e-4, 0.5, read_only=False)
    relaxation_wait: float = parameter(
        "time after a screw-in that the controllers' relaxation dither "
        '(control.relaxation.duration) needs to free the joints from the bend the seat locked '
        'in: the next step measures its stance only after it (during its unscrewing, with the '
        'chain still closed), and a walk ends only after it (0: no wait)', 's', 0.0, 5.0,
        read_only=False)
    mouth_settle_time: float = parameter(
        "time the joints must stay still at the hole's mouth, after the descent, before the "
        'tip is checked against the axis and the gripper screwed in (after a correction line '
        'at the mouth: settle_time)', 's', 0.0, 10.0,
        read_only=False)
    descent_region: float = parameter(
        'largest tip distance from the point above the hole at which the descent may start '
        'while the tip is still closing on it, once the motion there has ended (at or below '
        'insertion_alignment it may also start with the tip at rest); at most '
        "the gripper's insertion_position_tolerance", 'm', 1e-5, 0.05, read_only=False)
    descent_axis_tolerance: float = parameter(
        "largest distance of the tip (forward kinematics) from the hole's axis during the "
        'descent; farther, the descent is stopped and the gripper lifted straight back to the '
        "approach height, to come over the hole again (an insertion attempt, as a jam is); "
        'more than descent_region', 'm', 1e-4, 0.05, read_only=False)
    descent_arrival_time: float = parameter(
        'a tip within descent_region descends while it closes on the point above the hole '
        'only if, at the speed its joints give it now, it would not get there within this '
        'time: faster, it is swinging through the point (a stall of a real-time loop), not '
        "coming in behind joint 1's filter", 's', 0.001, 1.0, read_only=False)
    sweep_lead: float = parameter(
        "how long before the lift ends the coarse motion's setpoints begin, streamed with the "
        "lift's as one motion (they add): joint 1's reference filter holds the sweep back, "
        'so it starts while the gripper rises; a freed gripper waits up to this long for the '
        "sweep's plan, then lifts alone (0: the coarse motion starts once the lift has "
        "ended and the arm is there); at most the lift's duration", 's', 0.0, 1.0,
        read_only=False)

    def __post_init__(self) -> None:
        check_section(self)


def check_section(settings: SupervisorParameters) -> None:
    """Check the rules within the section (raises ParameterError naming the values)."""
    if settings.insertion_alignment >= settings.coarse_to_fine_region:
        raise ParameterError(
            f'supervisor.insertion_alignment ({settings.insertion_alignment} m) must be smaller '
            f'than supervisor.coarse_to_fine_region ({settings.coarse_to_fine_region} m)')
    if not settings.descent_axis_tolerance > settings.descent_region:
        raise ParameterError(
            f'supervisor.descent_axis_tolerance ({settings.descent_axis_tolerance} m) must be '
            f'larger than supervisor.descent_region ({settings.descent_region} m): the descent '
            f'may start that far off the axis')
    if not (settings.insertion_alignment <= settings.descent_region
            < settings.coarse_to_fine_region):
        raise ParameterError(
            f'supervisor.descent_region ({settings.descent_region} m) must be at least '
            f'supervisor.insertion_alignment ({settings.insertion_alignment} m) and smaller '
            f'than supervisor.coarse_to_fine_region ({settings.coarse_to_fine_region} m)')


def check_with_gripper(settings: SupervisorParameters, gripper) -> None:
    """Check the section against the ``gripper.`` section (its insertion tolerance)."""
    tolerance = gripper.insertion_position_tolerance
    if settings.insertion_alignment >= tolerance:
        raise ParameterError(
            f'supervisor.insertion_alignment ({settings.insertion_alignment} m) must be '
            f'smaller than gripper.insertion_position_tolerance ({tolerance} m)')
    if settings.descent_region > tolerance:
        raise ParameterError(
            f'supervisor.descent_region ({settings.descent_region} m) must not exceed '
            f'gripper.insertion_position_tolerance ({tolerance} m): the descent starts '
            f'only with the tip inside it')


def check_with_planner(settings: SupervisorParameters, stream_start_tolerance: float) -> None:
    """Check ``coarse_start_tolerance`` against ``planner.stream.start_tolerance`` [rad]."""
    if not settings.coarse_start_tolerance < stream_start_tolerance:
        raise ParameterError(
            f'supervisor.coarse_start_tolerance ({settings.coarse_start_tolerance} rad) must be '
            f'smaller than planner.stream.start_tolerance ({stream_start_tolerance} rad): the '
            f'planner refuses a stream that starts farther from the joints')


def check_with_control(settings: SupervisorParameters, relaxation_duration: float) -> None:
    """Check ``relaxation_wait`` against ``control.relaxation.duration`` [s]."""
    if settings.relaxation_wait < relaxation_duration:
        raise ParameterError(
            f'supervisor.relaxation_wait ({settings.relaxation_wait} s) must be at least '
            f'control.relaxation.duration ({relaxation_duration} s): the next step measures '
            f'its stance once the relaxation is over')
