"""The supervisor's parameters (section ``supervisor.``) and every rule across them.

Each value's range is in its declaration (:func:`walker_core.parameter_schema.parameter`); the
rules that join two or more values are here, in one place:

* within the section (:func:`check_section`, run by the dataclass itself): the insertion
  alignment is tighter than the coarse-to-fine region; the descent region lies between them;
  the descent's axis tolerance is wider than the descent region; the search radius lies
  inside the coarse-to-fine region;
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
        'tip distance from the point above the target at which COARSE hands over to FINE',
        'm', 0.001, 0.5, read_only=False,
        source='paper section 1: the phase switches on an error region; chosen: 3 cm')
    insertion_alignment: float = parameter(
        'largest tip error above the hole to descend from rest, and from the axis to screw in',
        'm', 1e-5, 0.05, read_only=False,
        source="chosen: a quarter of the 2 mm insertion tolerance, the benchmark's 0.5 mm")
    settle_velocity: float = parameter(
        'joints slower than this count as still', 'rad/s', 1e-4, 1.0, read_only=False,
        source='chosen')
    settle_time: float = settle_time_parameter()  # declared in the model: the report uses it
    phase_timeout: float = parameter(
        'time a phase may overrun its plan before the step is aborted',
        's', 0.1, 600.0, read_only=False,
        source="chosen: joint 1's fine loop needs seconds to settle after an overshoot")
    motion_end_margin: float = parameter(
        "time past a motion's planned end (graph and steady clock) to wait for its end, then hold",
        's', 0.1, 60.0, read_only=False,
        source='chosen: controllers finish a whole trajectory without the planner; above its lag')
    max_insertion_attempts: int = parameter(
        'screw-in attempts before a jammed insertion aborts the step', '', 1, 10, read_only=False,
        source='chosen: a bounded retry')
    watchdog_timeout: float = parameter(
        'silence of the plant or a controller (steady clock) that puts the walker in safe hold',
        's', 0.05, 60.0, read_only=False,
        source='chosen: a loaded 2-core machine starves a process for over a second at times')
    mode_mismatch_hold_time: float = parameter(
        'time a controller may stay in a mode the supervisor did not command before a hold',
        's', 0.0, 60.0, read_only=False,
        source='chosen: four corrections; a real controller takes a command at its next state')
    coarse_start_tolerance: float = parameter(
        'largest joint distance from the start of the coarse motion, or of a way back, to begin '
        'it', 'rad', 1e-4, 0.5, read_only=False,
        source='chosen: below planner.stream.start_tolerance')
    relaxation_wait: float = parameter(
        "time after a screw-in until the controllers' relaxation is over (0: no wait)",
        's', 0.0, 5.0, read_only=False,
        source='chosen: control.relaxation.duration and a margin')
    mouth_settle_time: float = parameter(
        "time the joints must be still at the hole's mouth before the screw-in",
        's', 0.0, 10.0, read_only=False,
        source='chosen: the descent hardly moves joint 1')
    descent_region: float = parameter(
        'tip distance from the point above the hole within which a closing tip may descend',
        'm', 1e-5, 0.05, read_only=False,
        source='chosen: the insertion tolerance; the tip reaches the axis during the descent')
    descent_axis_tolerance: float = parameter(
        "tip distance from the hole's axis beyond which a descent is stopped and lifted back",
        'm', 1e-4, 0.05, read_only=False,
        source='chosen: ordinary descents are at most 2.2-3.0 mm off')
    descent_arrival_time: float = parameter(
        'a closing tip that would reach the point above the hole sooner is swinging through it',
        's', 0.001, 1.0, read_only=False,
        source='chosen: one decision period')
    sweep_lead: float = parameter(
        "how long before the lift ends the coarse motion's setpoints begin (0: after it)",
        's', 0.0, 1.0, read_only=False,
        source="chosen: joint 1's filter holds the sweep back while the gripper rises")
    node_prior_std: float = parameter(
        "standard deviation of a truss node's place relative to a neighbour's, along x, y and z",
        'm', 0.0, 0.02, read_only=False,
        source="chosen: two nodes placed to 1.4 mm each; the frame's heading error adds to it")
    joint_reading_std: float = parameter(
        "standard deviation of a joint's reading, offset and noise together (the map's survey)",
        'rad', 0.0, 0.01, read_only=False,
        source="chosen: an output encoder's calibration to 0.2 mrad")
    search_radius: float = parameter(
        "upper bound on a search probe's distance from a hole's estimate (0: jams retried in "
        'place)', 'm', 0.0, 0.029, read_only=False,
        source='chosen: half the approach region; at most 121 probes, 13.5 mm covered')
    search_sigmas: float = parameter(
        "standard deviations of the node's estimate that a search covers",
        '', 0.0, 10.0, read_only=False, source='chosen: 3, 99 % of a normal placement error')
    # last, with their values also here: sections built field by field keep working without
    # them
    max_looks: int = dataclasses.field(default=4, metadata=parameter(
        'looks through the wrist camera before a descent (0: the blind descent, camera or not)',
        '', 0, 10, read_only=False,
        source='chosen: a look, one from higher for the height, one to confirm, one more'
        ).metadata)
    look_settle_time: float = dataclasses.field(default=0.3, metadata=parameter(
        "time the joints must be still before a look after the approach's first", 's',
        0.0, 10.0, read_only=False,
        source='chosen: as settle_time; the links ring on after the joints are still'
        ).metadata)
    look_frames: int = dataclasses.field(default=3, metadata=parameter(
        "frames of one look, half a period of the model's joint-1 mode apart, binomially weighted",
        '', 1, 5, read_only=False,
        source="chosen: 3 cancel the link's ringing to 5 % within 15 % of its frequency"
        ).metadata)
    look_alignment: float = dataclasses.field(default=0.0005, metadata=parameter(
        "largest offset of the hole seen from the gripper's axis to descend without moving",
        'm', 1e-5, 0.05, read_only=False,
        source='chosen: a quarter of the 2 mm insertion tolerance, as insertion_alignment'
        ).metadata)
    insertion_overtravel: float = dataclasses.field(default=0.002, metadata=parameter(
        "how far past the hole's nominal mouth a descent is commanded, to meet a lower node's "
        'face', 'm', 0.0, 0.02, read_only=False,
        source='chosen: reaches a node 2 mm low; deeper presses bend the estimate off the axis'
        ).metadata)
    face_height_std: float = dataclasses.field(default=0.0003, metadata=parameter(
        "standard deviation of a node's height felt by a gripper resting on its face",
        'm', 0.0, 0.01, read_only=False,
        source='chosen: the light press on the face, 0.3 mm below contact').metadata)
    truss_survey_file: str = dataclasses.field(default='', metadata=parameter(
        "truss survey file the map starts from where it exists and is kept in ('': none)",
        source="chosen: none; run_all.py gives the graph's <out>/truss_survey.yaml").metadata)

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


    if not settings.search_radius < settings.coarse_to_fine_region:
        raise ParameterError(
            f'supervisor.search_radius ({settings.search_radius} m) must be smaller than '
            f'supervisor.coarse_to_fine_region ({settings.coarse_to_fine_region} m): a probe '
            f'stays in the region where FINE brings the tip over the hole')


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
    if settings.look_alignment >= tolerance:
        raise ParameterError(
            f'supervisor.look_alignment ({settings.look_alignment} m) must be smaller than '
            f'gripper.insertion_position_tolerance ({tolerance} m): a hole seen that far off '
            f'would be missed')


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
