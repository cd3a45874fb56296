"""The plant's parameter section ``sim.*`` of the shared parameter file.

The values live in ``walker_core/config/walker.yaml`` (section ``/**``, group ``sim``), each with
its source; this module declares them (description, unit, range) and checks the rules that tie
them to the shared parameters (nodes on the truss, physics rate a multiple of the control rate).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any
from collections.abc import Mapping

from walker_core.parameter_file import ParameterFile
from walker_core.parameter_schema import ParameterError, parameter, section_from_flat
from walker_core.truss import Truss, UnknownNodeError
from walker_sim.core.camera_truth import CameraRendering
from walker_sim.core.imperfections import Imperfections

__all__ = ['CLOCK_MODES', 'StartConfiguration', 'SimParameters', 'load_sim_parameters',
           'check_against_walker', 'plant_sections']

#: ``sim_time``: the plant publishes /clock and is lock-stepped with the controllers;
#: ``real_time``: the plant steps on a wall-clock timer, like hardware.
CLOCK_MODES = ('sim_time', 'real_time')


@dataclasses.dataclass(frozen=True)
class StartConfiguration:
    """Where the robot is when the plant starts or is reset."""

    base_gripper: str = parameter(
        'gripper screwed in at start, acting as the base', choices=('a', 'b'),
        source='chosen')
    base_node: str = parameter('truss node the base gripper is screwed into at start',
                               source='chosen: one node in from the truss corner')
    other_node: str = parameter('truss node under the other gripper at start',
                                source='chosen: the neighbour one spacing along +x')
    other_attached: bool = parameter('whether the other gripper starts screwed into other_node',
                                     source='chosen: both grippers screwed in')
    other_height: float = parameter(
        'height of the other gripper above other_node when it starts free', 'm', 0.0, 0.5,
        source='chosen')

    def __post_init__(self) -> None:
        if self.base_node == self.other_node:
            raise ParameterError(f'sim.start.other_node must differ from base_node '
                                 f'({self.base_node!r})')
        if self.other_attached and self.other_height != 0.0:
            raise ParameterError(
                f'sim.start.other_height ({self.other_height} m) must be 0 when '
                f'other_attached is true: an attached gripper sits in its hole')


@dataclasses.dataclass(frozen=True)
class SimParameters:
    """Settings of the pybullet plant (``sim.*``)."""

    clock_mode: str = parameter(
        'sim_time: /clock, lock-stepped with the controllers; real_time: the wall clock',
        choices=CLOCK_MODES,
        source='chosen: the walk and the tests run in sim time')
    physics_rate: float = parameter(
        'rate of the physics steps (a multiple of the control rate)', 'Hz', 100.0, 100000.0,
        source='chosen: at least the stiffest mode in rad/s (704 by default)')
    lockstep_timeout: float = parameter(
        'sim time: wall-clock wait for the five efforts of a step',
        's', 0.001, 60.0, read_only=False,
        source='chosen: long enough for a loaded machine, short for a dead controller')
    wait_for_decisions: bool = parameter(
        'sim time: never step past the time up to which the supervisor has decided',
        read_only=False,
        source='chosen: off; run_all.py --composed-loop turns it on')
    decision_timeout: float = parameter(
        "sim time: wall-clock wait for the supervisor's release before stepping on",
        's', 0.001, 60.0, read_only=False,
        source='chosen: below control.state_timeout')
    startup_resend_period: float = parameter(
        'sim time: wall-clock period of re-sending the first state until all controllers '
        'answered', 's', 0.01, 10.0, read_only=False,
        source='chosen')
    command_timeout: float = parameter(
        'a joint whose last effort command is older than this (plant clock) gets zero torque',
        's', 0.001, 10.0, read_only=False,
        source='chosen: as a drive watchdog; friction then holds the joint')
    gripper_state_rate: float = parameter(
        'heartbeat rate of gripper_states (also sent on every change)',
        'Hz', 0.1, 1000.0, read_only=False,
        source='chosen: a liveness signal')
    clock_rate: float = parameter(
        'rate of /clock in sim-time mode (every period at or above the control rate)',
        'Hz', 1.0, 5000.0,
        source="chosen: enough for the supervisor's 50 Hz decisions; each message costs CPU")
    pose_rate: float = parameter(
        'rate of tip_pose, gripper_a_pose and gripper_b_pose (every period at or above the '
        'control rate)', 'Hz', 1.0, 5000.0, read_only=False,
        source='chosen: resolves the 80 rad/s (12.7 Hz) modes; each message costs CPU')
    stiction_velocity: float = parameter(
        'joint speed below which a joint is stuck and must break away', 'rad/s', 1e-6, 1.0,
        source='chosen')
    jam_screw_ins: int = parameter(
        'fault injection: this many coming screw-ins jam whatever the alignment',
        '', 0, 100, read_only=False,
        source='chosen: no injected fault')
    start: StartConfiguration
    imperfections: Imperfections
    camera: CameraRendering

    @classmethod
    def from_flat(cls, flat: Mapping[str, Any]) -> 'SimParameters':
        """Build and validate from flat dotted names (``sim.physics_rate``, ...)."""
        return section_from_flat(cls, flat, 'sim.')


def check_against_walker(sim: SimParameters, params) -> None:
    """Check the rules that tie ``sim.*`` to the shared parameters.

    Raises
    ------
    ParameterError
        Naming the parameter: start nodes not on the truss, or a physics rate that is not an
        integer multiple of ``timing.control_rate``.
    """
    truss = Truss.from_parameters(params)
    for name in ('base_node', 'other_node'):
        try:
            truss.index(getattr(sim.start, name))
        except UnknownNodeError as error:
            raise ParameterError(f'sim.start.{name}: {error}') from None
    ratio = sim.physics_rate / params.timing.control_rate
    if ratio < 1.0 - 1e-9 or not math.isclose(ratio, round(ratio), rel_tol=0, abs_tol=1e-9):
        raise ParameterError(
            f'sim.physics_rate ({sim.physics_rate:g} Hz) must be an integer multiple of '
            f'timing.control_rate ({params.timing.control_rate:g} Hz)')


def plant_sections(file: ParameterFile):
    """Return the plant's sections of a parameter file: the robot and ``sim.*``, checked.

    What every plant is built from (the graph's plant node, the headless loop, the tools that
    run the plant core): ``(WalkerParameters, SimParameters)``, with the rule between them
    (:func:`check_against_walker`) run, as :func:`walker_config.core.configuration.
    load_configuration` runs it.

    Raises
    ------
    ParameterError
        Naming the parameter: a value of either section, or the rule between them (start
        nodes off the truss, a physics rate that is not a multiple of the control rate).
    """
    from walker_core.robot_parameters import WalkerParameters

    walker, sim = file.section(WalkerParameters), file.section(SimParameters, 'sim.')
    check_against_walker(sim, walker)
    return walker, sim


def load_sim_parameters(path=None) -> SimParameters:
    """Load ``sim.*`` from a parameter file (default: the installed ``walker.yaml``)."""
    return ParameterFile.read(path).section(SimParameters, 'sim.')
