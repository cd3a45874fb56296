"""The walker's robot, truss and gripper parameters, shared by every node.

One YAML file (``config/walker.yaml``, section ``/**``) holds them; this module turns it into
frozen, validated dataclasses. Units are SI (m, kg, s, rad, N*m; REP 103).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from walker_core.camera import CameraParameters
from walker_core.parameter_file import ParameterFile, default_parameter_file
from walker_core.parameter_schema import ParameterError, parameter, section_from_flat

__all__ = [
    'Geometry', 'Masses', 'Drive', 'Drives', 'Flexibility', 'RobotParameters',
    'TrussParameters', 'GripperParameters', 'TimingParameters', 'WalkerParameters',
    'JOINT_KINDS_BY_ROLE',
    'default_parameter_file', 'load_walker_parameters',
]

#: Kind of drive at each joint role J1..J5 (the same motors serve mirrored roles).
JOINT_KINDS_BY_ROLE = ('yaw', 'pitch', 'vertex', 'pitch', 'yaw')


@dataclasses.dataclass(frozen=True)
class Geometry:
    """Link lengths of paper eq (1)."""

    l1: float = parameter(
        'wrist offset: pitch axis to gripper contact point', 'm', 0.01, 2.0,
        source='chosen: 1/3 of a 0.45 m full-size wrist; short next to l2, as Figure 1 draws it')
    l2: float = parameter(
        'length of each of the two flexible links', 'm', 0.05, 5.0,
        source='chosen: 1/3 of a 1.8 m full-size link; an inverted V of 83 deg at J3 on the 0.9 '
               'm truss')

    def __post_init__(self) -> None:
        if self.l1 >= self.l2:
            raise ParameterError(
                f'robot.geometry.l1 ({self.l1} m) must be shorter than l2 ({self.l2} m)')


@dataclasses.dataclass(frozen=True)
class Masses:
    """Masses of the bodies; the rigid model lumps them at J3, J4 and the tip (eqs (9)-(13))."""

    gripper: float = parameter(
        'gripper with its screw drive and yaw motor, at each end', 'kg', 0.01, 100.0,
        source='chosen: the tip mass dominates, as paper section 5 assumes')
    wrist: float = parameter('wrist pitch drive housing, at each end', 'kg', 0.0, 100.0,
                             source='chosen: pitch motor and housing')
    vertex: float = parameter('vertex drive housing', 'kg', 0.0, 100.0,
                              source='chosen: "much less than at the tip" (paper section 5)')
    link: float = parameter(
        'each flexible link, uniformly distributed', 'kg', 0.01, 100.0,
        source='chosen: a light carbon-fibre tube, "light-weight" (paper section 2)')

    @property
    def lumped(self) -> tuple[float, float, float]:
        """Point masses (m3, m4, m5) at the vertex J3, the tip wrist J4 and the tip, in kg.

        Each link's mass is split half to each of its ends; the mass at the base end does not
        move with J1-J5 and drops out of the inertia terms.
        """
        m3 = self.vertex + self.link
        m4 = self.wrist + 0.5 * self.link
        m5 = self.gripper
        return m3, m4, m5


@dataclasses.dataclass(frozen=True)
class Drive:
    """One kind of joint drive (harmonic-drive gear motor) and its joint's limits."""

    gear_ratio: float = parameter(
        'harmonic drive reduction n_i', '', 1.0, 1000.0,
        source='chosen: a common harmonic-drive ratio (paper: harmonic drives)')
    torque_limit: float = parameter(
        'maximum joint torque', 'N*m', 0.01, 1000.0,
        source='chosen: yaw accelerates the 5 kg tip cluster at 0.9 m at about 3 rad/s^2; pitch '
               'carries the most')
    friction_torque: float = parameter(
        'Coulomb friction torque at the joint', 'N*m', 0.0, 1000.0,
        source='paper section 3: friction above 10 % of the maximum torque (15 %)')
    stiction_torque: float = parameter('static friction (breakaway) torque', 'N*m', 0.0, 1000.0,
                                       source='chosen: breakaway 20 % above the Coulomb level')
    velocity_limit: float = parameter('maximum joint speed', 'rad/s', 0.01, 100.0,
                                      source='chosen: motor speed over the gear ratio')
    position_min: float = parameter(
        'lower joint limit', 'rad', -10.0, 10.0,
        source='chosen: a 180 deg sweep fits from either side (yaw); the links cannot fold '
               '(vertex)')
    position_max: float = parameter('upper joint limit', 'rad', -10.0, 10.0,
                                    source='chosen: symmetric with position_min')

    def __post_init__(self) -> None:
        if self.friction_torque <= 0.10 * self.torque_limit:
            raise ParameterError(
                f'friction_torque ({self.friction_torque} N*m) must exceed 10% of torque_limit '
                f'({self.torque_limit} N*m): the paper measured friction above 10%')
        if not self.friction_torque <= self.stiction_torque < self.torque_limit:
            raise ParameterError(
                f'need friction_torque <= stiction_torque < torque_limit, got '
                f'{self.friction_torque}, {self.stiction_torque}, {self.torque_limit} N*m')
        if self.position_min >= self.position_max:
            raise ParameterError(f'position_min ({self.position_min} rad) must be below '
                                 f'position_max ({self.position_max} rad)')


@dataclasses.dataclass(frozen=True)
class Drives:
    """The three kinds of drive: yaw (J1, J5), pitch (J2, J4) and vertex (J3)."""

    motor_inertia: float = parameter('rotor inertia I_m of every joint motor', 'kg*m^2', 0.0, 1.0,
                                     source='chosen: a small DC servo rotor; I_m of eqs (9)-(13)')
    yaw: Drive
    pitch: Drive
    vertex: Drive

    def for_role(self, role: int) -> Drive:
        """Drive of joint role ``role`` (1..5)."""
        return getattr(self, JOINT_KINDS_BY_ROLE[role - 1])

    def role_array(self, attribute: str) -> np.ndarray:
        """Array over roles J1..J5 of one attribute, e.g. ``'torque_limit'``."""
        return np.array([getattr(self.for_role(i), attribute) for i in range(1, 6)])


@dataclasses.dataclass(frozen=True)
class Flexibility:
    """Structural modes of the flexible links, as seen at the joints (paper section 3).

    The mode seen at a joint is the lowest structural mode of its bending plane that rings at
    it with the joints held (by the servos, or stuck at rest): see
    :mod:`walker_sim.core.flexibility`.
    """

    joint1_mode: float = parameter(
        'lowest out-of-plane structural mode with the joints held, seen at joint 1',
        'rad/s', 1.0, 1000.0,
        source='paper section 3: the mode seen at joint 1')
    joints23_mode: float = parameter(
        'lowest in-plane structural mode with the joints held, seen at joints 2 and 3',
        'rad/s', 1.0, 1000.0,
        source='paper section 3: the modes seen at joints 2 and 3')
    damping_ratio: float = parameter(
        'structural damping ratio of the modes', '', 0.0, 1.0,
        source='chosen: 2-5 % is usual for a composite arm with harmonic drives; the paper gives '
               'none')
    segments_per_link: int = parameter(
        'rigid segments each flexible link is split into', '', 2, 20,
        source="chosen: each link's first bending mode in each plane; more need faster physics")

    def __post_init__(self) -> None:
        if self.joint1_mode >= self.joints23_mode:
            raise ParameterError('the joint-1 mode must be lower than the joints-2/3 mode '
                                 f'({self.joint1_mode} >= {self.joints23_mode} rad/s)')


@dataclasses.dataclass(frozen=True)
class RobotParameters:
    """The robot: geometry, masses, drives and flexibility."""

    name: str = parameter('robot name, also the ROS namespace of its topics',
                          source="chosen: the default ROS namespace of the robot's interfaces")
    geometry: Geometry
    mass: Masses
    drive: Drives
    flexibility: Flexibility

    def __post_init__(self) -> None:
        if not self.name.isidentifier():
            raise ParameterError(
                f'robot.name {self.name!r} must be a valid ROS name token (letters, digits, _)')


@dataclasses.dataclass(frozen=True)
class TrussParameters:
    """A flat truss face: nodes on a rectangular grid, each with a threaded hole (axis +z)."""

    spacing: float = parameter('distance between neighbouring nodes', 'm', 0.05, 10.0,
                               source='chosen: 1/3-scale node spacing, reachable (below 2 l2)')
    columns: int = parameter('number of nodes along x', '', 1, 100,
                             source='chosen: several nodes in both directions')
    rows: int = parameter('number of nodes along y', '', 1, 100,
                          source='chosen: several nodes in both directions')
    origin_x: float = parameter('x of node n0_0 in the truss (world) frame', 'm', -100.0, 100.0,
                                source='chosen: node n0_0 at the world origin')
    origin_y: float = parameter('y of node n0_0 in the truss (world) frame', 'm', -100.0, 100.0,
                                source='chosen: node n0_0 at the world origin')
    hole_depth: float = parameter('depth of the threaded hole', 'm', 0.001, 1.0,
                                  source='chosen: thread engagement of the screw gripper')

    def __post_init__(self) -> None:
        if self.columns * self.rows < 2:
            raise ParameterError('the truss needs at least two nodes to stand on')


@dataclasses.dataclass(frozen=True)
class GripperParameters:
    """Screw-in attachment of a gripper to a node."""

    insertion_position_tolerance: float = parameter(
        'largest tip distance from the hole axis at which a screw-in succeeds', 'm', 1e-5, 0.1,
        source='chosen: a thread entry chamfer; the paper needs the tip "precisely located at '
               'the top of hole"')
    insertion_axis_tolerance: float = parameter(
        'largest angle between gripper and hole axes at which a screw-in succeeds',
        'rad', 1e-4, 0.5,
        source='chosen: 2 deg of axis misalignment')
    approach_height: float = parameter(
        'height above the hole where insertion starts and extraction ends', 'm', 0.001, 0.5,
        source='chosen: insertion starts 30 mm above the hole')
    screw_time: float = parameter('time to screw in or unscrew', 's', 0.0, 60.0, source='chosen')
    camera: CameraParameters
    # last, with its value also here: sections built field by field keep working without it
    screw_length: float = dataclasses.field(default=0.003, metadata=parameter(
        "how far the screw's tip reaches below the gripper's shoulder (its contact point)", 'm',
        0.0, 0.05, source='chosen: a few threads; a gripper beside the hole rests this high on '
                          'the face').metadata)


@dataclasses.dataclass(frozen=True)
class TimingParameters:
    """Rates every node agrees on."""

    control_rate: float = parameter(
        'rate of joint states, effort commands and setpoints', 'Hz', 10.0, 5000.0,
        source='chosen: a 2 ms period, about 40 samples per cycle of the fastest (80 rad/s) mode')
    realtime_priority: int = parameter(
        "SCHED_FIFO priority of the control loop's processes on the wall clock (0: default)",
        '', 0, 99,
        source="chosen: opt-in; run_all.py --realtime asks for 50 (ros2_control's priority)")
    decision_priority: int = parameter(
        'SCHED_FIFO priority of the supervisor and the planner on the wall clock (0: default)',
        '', 0, 99,
        source="chosen: below the loop's, above every ordinary process; asked for only with "
               'realtime_priority')

    @property
    def decision_scheduling_priority(self) -> int:
        """Priority the supervisor and the planner ask for: 0 when the loop asks for none.

        A loop left to the default scheduler is never outranked by the processes it serves.
        """
        return self.decision_priority if self.realtime_priority else 0

    def __post_init__(self) -> None:
        if self.realtime_priority and self.decision_priority >= self.realtime_priority:
            raise ParameterError(
                f'timing.decision_priority ({self.decision_priority}) must be below '
                f'timing.realtime_priority ({self.realtime_priority}): a plan being computed '
                'would otherwise delay the control loop (0 leaves the scheduling alone)')


@dataclasses.dataclass(frozen=True)
class WalkerParameters:
    """Everything in the ``/**`` section that every node shares."""

    robot: RobotParameters
    truss: TrussParameters
    gripper: GripperParameters
    timing: TimingParameters

    def __post_init__(self) -> None:
        reach = 2.0 * self.robot.geometry.l2
        if self.truss.spacing >= reach:
            raise ParameterError(
                f'truss.spacing ({self.truss.spacing} m) must be shorter than the reach '
                f'2*l2 = {reach} m, or no step is possible')

    @classmethod
    def from_flat(cls, flat: Mapping[str, Any]) -> 'WalkerParameters':
        """Build and validate from flat dotted names (``robot.geometry.l2``, ...)."""
        return section_from_flat(cls, flat)


def load_walker_parameters(path: str | Path | None = None) -> WalkerParameters:
    """Load and validate the shared parameters from a ``ros__parameters`` YAML file.

    Parameters
    ----------
    path : str or Path, optional
        Parameter file; the default is the package's ``config/walker.yaml``.

    Raises
    ------
    ParameterError
        Naming the missing or invalid parameter.
    """
    return ParameterFile.read(path).section(WalkerParameters)
