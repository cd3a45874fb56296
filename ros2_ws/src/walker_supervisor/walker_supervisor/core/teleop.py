"""Teleoperation rules, free of ROS: what an operator may jog or screw, and when.

An operator drives the walker between walks: jogs one joint, jogs the free gripper along a
straight line in its own frame, unscrews a gripper or screws it in. The supervisor owns the
step's phase, so it enforces these rules before it sends anything to the planner or the plant;
the plant keeps its own interlock (it never releases the only attached gripper). Every
function here either returns what to do or raises :class:`TeleopRefusedError` saying why,
having changed nothing.

Rules
-----
* Nothing else may be under way: no walk or step (phase IDLE or SAFE_HOLD), no other
  teleoperation.
* A jog needs exactly one gripper screwed in. With both in, the chain is closed and no joint can
  move alone; with a gripper screwing or unscrewing, the stance is changing. The attached
  gripper is the base of the jog (the roles J1..J5 count from it).
* A joint jog moves one physical joint by a relative angle: finite, not zero, at most
  ``teleop.max_joint_jog``, to a target within the joint's limits, at a peak speed within
  ``teleop.max_joint_speed`` and the joint's velocity limit.
* A tip jog moves the free gripper's contact point along a straight line, given in the
  gripper's own frame (:func:`tip_heading`), keeping the gripper vertical: finite, not zero, at
  most ``teleop.max_tip_jog`` long, at a speed within ``teleop.max_tip_speed``, from a gripper
  vertical within ``teleop.max_tilt``, along a line the arm reaches within its joint limits.
* Along any jog the free gripper stays above the truss surface (its contact point at
  ``z >= -surface_tolerance`` in the base frame, the tolerance being the hole's insertion
  tolerance), and wherever it has moved sideways by more than that tolerance it must be at least
  ``teleop.clearance`` above the surface: a gripper leaves and enters a hole straight along its
  axis, as the steps' extraction and insertion do. A gripper that a fault left below the
  surface is brought out by a jog that only rises (it never sinks on the way, sideways motion
  allowed) until it is ``teleop.clearance`` above the surface.
* A jog that settles farther from its goal than ``teleop.joint_tolerance`` (a joint jog) or
  ``supervisor.insertion_alignment`` (a tip jog) gets a correction, a joint move from where it
  settled to the jog's goal configuration, checked against the surface as the jog was.
* Unscrewing needs the gripper attached (a jammed one may always be backed out) and the *other*
  gripper verified attached; unscrewing the base makes the other gripper the base. Screwing in
  needs the gripper free or jammed; the plant decides whether it is within the insertion
  tolerance (a jam is reported back). No gripper command while a gripper is screwing or
  unscrewing.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence

import numpy as np

from walker_core.gripper_state import TURNING, GripperState
from walker_core.joint_roles import (
    GRIPPERS, PHYSICAL_JOINT_NAMES, joint_of_role, other_gripper, physical_to_roles,
    role_of_joint)
from walker_core.kinematics import KinematicsError, WalkerKinematics
from walker_core.parameter_schema import ParameterError, parameter
from walker_core.text import millimetres, unknown_choice, value_text
from walker_supervisor.core.phases import Phase

__all__ = [
    'TeleopParameters', 'TeleopRefusedError', 'Situation', 'JointJog', 'TipJog', 'Correction',
    'GripperOperation', 'TeleopRules', 'SettleDetector', 'busy_reason', 'tip_heading',
    'PATH_SAMPLES',
]

#: Points at which a jog's path is checked against the truss surface and the joint limits.
PATH_SAMPLES = 41
_NO_MOTION = 1e-9  # [rad or m] a jog shorter than this moves nothing
_SINK_SLACK = 1e-6  # [m] a path from below the surface may dip this much between two samples


class TeleopRefusedError(ValueError):
    """An operator command that is refused; nothing changed. The message says why."""


@dataclasses.dataclass(frozen=True)
class TeleopParameters:
    """Limits of the operator's jogs (section ``teleop.``)."""

    max_joint_jog: float = parameter(
        'largest angle one jog_joint command may move a joint', 'rad', 1e-3, 1.0, read_only=False,
        source='chosen: a jog adjusts, a step moves; 0.2 rad of J2 swings the gripper at most '
               '0.27 m')
    joint_speed: float = parameter(
        'peak joint speed of a jog_joint command that gives none',
        'rad/s', 1e-3, 1.5, read_only=False,
        source='chosen: a 0.2 rad jog takes 3.75 s, slow enough to watch and stop')
    max_joint_speed: float = parameter(
        'largest peak joint speed a jog_joint command may ask for',
        'rad/s', 1e-3, 1.5, read_only=False,
        source="chosen: a third of the drives' velocity limit")
    max_tip_jog: float = parameter(
        'largest distance one jog_tip command may move the free gripper',
        'm', 1e-4, 0.5, read_only=False,
        source='chosen: a few centimetres of fine positioning; moving to another node is a step')
    tip_speed: float = parameter(
        'speed of a jog_tip command that gives none', 'm/s', 1e-4, 0.1, read_only=False,
        source="chosen: planner.cartesian.fine_speed, a step's fine motion")
    max_tip_speed: float = parameter(
        'largest speed a jog_tip command may ask for', 'm/s', 1e-4, 0.1, read_only=False,
        source='chosen: half planner.cartesian.max_velocity')
    clearance: float = parameter(
        'height above the truss the free gripper needs to move sideways',
        'm', 0.0, 0.2, read_only=False,
        source='chosen: a third of gripper.approach_height; a gripper leaves a hole along its '
               'axis')
    joint_tolerance: float = parameter(
        'a joint jog that settles farther than this from its target gets a correction move',
        'rad', 1e-4, 0.1, read_only=False,
        source="chosen: the controllers' loosest in-position tolerance (J4, J5)")
    max_tilt: float = parameter(
        'largest tilt of the free gripper from vertical at which jog_tip accepts a command',
        'rad', 1e-4, 0.05, read_only=False,
        source='chosen: the setpoints jump by this much as the line starts vertical')

    def __post_init__(self) -> None:
        if self.joint_speed > self.max_joint_speed:
            raise ParameterError(
                f'teleop.joint_speed ({self.joint_speed} rad/s) must not exceed '
                f'teleop.max_joint_speed ({self.max_joint_speed} rad/s)')
        if self.tip_speed > self.max_tip_speed:
            raise ParameterError(
                f'teleop.tip_speed ({self.tip_speed} m/s) must not exceed '
                f'teleop.max_tip_speed ({self.max_tip_speed} m/s)')


@dataclasses.dataclass(frozen=True)
class Situation:
    """What the supervisor knows when a command arrives.

    Attributes
    ----------
    activity : str
        ``''`` when nothing is under way, else why no command may start now (see
        :func:`busy_reason`).
    grippers : mapping of str to str
        Reported state of each gripper, a :class:`~walker_core.gripper_state.GripperState`
        (missing: no report yet).
    gripper_nodes : mapping of str to str
        Node each gripper is attached to, screwing into or jammed at ('' when free).
    base_gripper : str
        The base now.
    positions : ndarray, shape (5,), or None
        Measured joint angles in physical order [rad]; None before the first joint states.
    """

    activity: str
    grippers: Mapping[str, str]
    gripper_nodes: Mapping[str, str]
    base_gripper: str
    positions: np.ndarray | None


@dataclasses.dataclass(frozen=True)
class JointJog:
    """An accepted joint jog.

    Attributes
    ----------
    joint_name : str
        The physical joint that moves.
    base_gripper : str
        The attached gripper, base of the motion.
    start, goal : ndarray, shape (5,)
        Joint angles J1..J5 [rad] in role order of ``base_gripper``; they differ in one joint.
    target : float
        The joint's target angle [rad].
    speed : float
        Peak joint speed [rad/s].
    """

    joint_name: str
    base_gripper: str
    start: np.ndarray
    goal: np.ndarray
    target: float
    speed: float

    def describe(self) -> str:
        """Say what the jog does, for logs and answers."""
        delta = self.target - float(self.start[role_of_joint(self.joint_name,
                                                             self.base_gripper) - 1])
        return f'jog of {self.joint_name} by {delta:+.4f} rad'


@dataclasses.dataclass(frozen=True)
class TipJog:
    """An accepted tip jog.

    Attributes
    ----------
    free_gripper, base_gripper : str
        The gripper that moves and the attached one.
    start : ndarray, shape (5,)
        Measured joint angles J1..J5 [rad] in role order of ``base_gripper``.
    start_point, goal_point : ndarray, shape (3,)
        The contact point of the free gripper [m] in the base frame, now (forward kinematics of
        ``start``) and at the end of the line.
    delta : ndarray, shape (3,)
        The displacement as asked [m], in the free gripper's frame.
    speed : float
        Speed along the line [m/s].
    goal : ndarray, shape (5,)
        Joint angles J1..J5 [rad] at the end of the line (gripper vertical, the start's branch,
        the tip yaw turned with the base yaw as the planner's lines do).
    """

    free_gripper: str
    base_gripper: str
    start: np.ndarray
    start_point: np.ndarray
    goal_point: np.ndarray
    delta: np.ndarray
    speed: float
    goal: np.ndarray

    def describe(self) -> str:
        """Say what the jog does, for logs and answers."""
        mm = millimetres(self.delta, signed=True)
        return f'tip jog of gripper {self.free_gripper} by ({mm}) mm in its frame'


@dataclasses.dataclass(frozen=True)
class Correction:
    """A joint move back to a jog's goal configuration.

    Attributes
    ----------
    base_gripper : str
        The attached gripper.
    start, goal : ndarray, shape (5,)
        Joint angles J1..J5 [rad] now and at the jog's goal, role order of ``base_gripper``.
    speed : float
        Peak joint speed [rad/s] (``teleop.joint_speed``).
    """

    base_gripper: str
    start: np.ndarray
    goal: np.ndarray
    speed: float


@dataclasses.dataclass(frozen=True)
class GripperOperation:
    """An accepted gripper command.

    Attributes
    ----------
    gripper : str
        The gripper to screw in or unscrew.
    action : str
        ``'screw_in'`` or ``'unscrew'``.
    base_after : str
        The base once the command is accepted: the other gripper when the base is unscrewed.
    expected : tuple of GripperState
        Reported states that end the command: ATTACHED for a screw-in, FREE for an unscrew.
    """

    gripper: str
    action: str
    base_after: str
    expected: tuple[str, ...]

    def describe(self) -> str:
        """Say what the command does, for logs and answers."""
        verb = 'screw-in' if self.action == 'screw_in' else 'unscrew'
        return f'{verb} of gripper {self.gripper}'


def busy_reason(walk_target: str | None, phase: Phase, operation: str) -> str:
    """Why no operator command may start now, or ``''`` when one may.

    Parameters
    ----------
    walk_target : str or None
        Target node of the walk or step goal under way, None when there is none.
    phase : Phase
        The step's phase.
    operation : str
        The teleoperation under way (its description), ``''`` when there is none.
    """
    if walk_target is not None:
        return f'a walk or step to {walk_target} is under way: cancel it first'
    if phase not in (Phase.IDLE, Phase.SAFE_HOLD):
        return f'a step is under way (phase {phase.name})'
    if operation:
        return (f'another command is under way ({operation}): wait for its answer, or call '
                f'hold to stop a jog')
    return ''


def tip_heading(kinematics: WalkerKinematics, theta_roles: Sequence[float]) -> float:
    """Heading [rad] of the free gripper's x axis about the base z axis.

    The free gripper's frame is :meth:`WalkerKinematics.forward_transform` (the frame that
    ``gripper_<g>_pose`` publishes). With the gripper vertical it is a pure rotation about z
    by ``J1 - J5 + pi``; a slightly tilted gripper is taken as vertical (its x axis projected on
    the truss plane).
    """
    rotation = kinematics.forward_transform(theta_roles)[:3, :3]
    return math.atan2(rotation[1, 0], rotation[0, 0])


def _finite(value: float, what: str, unit: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) \
            or not math.isfinite(value):
        raise TeleopRefusedError(f'{what} must be a finite number, got {value_text(value)} '
                                 f'{unit}')
    return float(value)


class TeleopRules:
    """The rules of teleoperation: checks each command and says what to execute.

    Parameters
    ----------
    parameters : TeleopParameters
        The operator's limits.
    kinematics : WalkerKinematics
        The arm, with its joint limits by role.
    velocity_limits : sequence of 5 float
        Drive velocity limits [rad/s] by role J1..J5 (``robot.drive.*.velocity_limit``).
    surface_tolerance : float
        How far below the truss surface [m] the contact point may be taken to be still on it
        (``gripper.insertion_position_tolerance``: a gripper in a hole's mouth is within it).
    """

    def __init__(self, parameters: TeleopParameters, kinematics: WalkerKinematics,
                 velocity_limits: Sequence[float], surface_tolerance: float) -> None:
        self.parameters = parameters
        self.kinematics = kinematics
        self.velocity_limits = np.asarray(velocity_limits, dtype=float)
        self.surface_tolerance = float(surface_tolerance)

    @classmethod
    def from_parameters(cls, parameters: TeleopParameters, robot) -> 'TeleopRules':
        """Build from the ``teleop.`` section and ``WalkerParameters``."""
        return cls(parameters, WalkerKinematics.from_parameters(robot),
                   robot.robot.drive.role_array('velocity_limit'),
                   robot.gripper.insertion_position_tolerance)

    # ------------------------------------------------------------------ the stance
    @staticmethod
    def check_free(situation: Situation) -> None:
        """Refuse when a walk, a step or another command is under way."""
        if situation.activity:
            raise TeleopRefusedError(situation.activity)

    @staticmethod
    def _states(situation: Situation) -> dict[str, str]:
        missing = [g for g in GRIPPERS if g not in situation.grippers]
        if missing:
            raise TeleopRefusedError('no gripper states received from the plant yet')
        changing = [g for g in GRIPPERS if situation.grippers[g] in TURNING]
        if changing:
            g, state = changing[0], situation.grippers[changing[0]]
            until = GripperState.ATTACHED if state == GripperState.SCREWING else GripperState.FREE
            raise TeleopRefusedError(f'gripper {g} is {state}: wait until it is {until}')
        return {g: situation.grippers[g] for g in GRIPPERS}

    def jog_base(self, situation: Situation) -> str:
        """Return the attached gripper, the base of a jog; refuse unless exactly one is attached.

        Raises
        ------
        TeleopRefusedError
            Something is under way, a gripper state is unknown or changing, or not exactly one
            gripper is attached.
        """
        self.check_free(situation)
        states = self._states(situation)
        attached = [g for g in GRIPPERS if states[g] == GripperState.ATTACHED]
        if len(attached) == 2:
            raise TeleopRefusedError('both grippers are screwed in: unscrew one first')
        if not attached:
            raise TeleopRefusedError('no gripper is attached: nothing holds the walker')
        if situation.positions is None:
            raise TeleopRefusedError('no joint states received from the plant yet')
        return attached[0]

    # ------------------------------------------------------------------ joint jogs
    def joint_jog(self, situation: Situation, joint_name: str, delta: float,
                  max_velocity: float) -> JointJog:
        """Check a joint jog and return it.

        Parameters
        ----------
        joint_name : str
            Physical joint name.
        delta : float
            Angle to move by [rad], relative to the measured angle.
        max_velocity : float
            Peak speed [rad/s]; 0 for ``teleop.joint_speed``.

        Raises
        ------
        TeleopRefusedError
            Naming the rule the command breaks; nothing is to be done.
        """
        p = self.parameters
        if joint_name not in PHYSICAL_JOINT_NAMES:
            raise TeleopRefusedError(f'unknown joint {joint_name!r}: the joints are '
                                     f'{", ".join(PHYSICAL_JOINT_NAMES)}')
        delta = _finite(delta, 'delta', 'rad')
        speed = self._speed(max_velocity, p.joint_speed, p.max_joint_speed,
                            'teleop.max_joint_speed', 'rad/s')
        if abs(delta) < _NO_MOTION:
            raise TeleopRefusedError('delta is 0 rad: there is nothing to move')
        if abs(delta) > p.max_joint_jog:
            raise TeleopRefusedError(
                f'delta {delta:+.4f} rad is larger than a jog may be (teleop.max_joint_jog = '
                f'{p.max_joint_jog:g} rad): jog in smaller steps')
        base = self.jog_base(situation)
        role = role_of_joint(joint_name, base) - 1
        if speed > self.velocity_limits[role]:
            raise TeleopRefusedError(
                f'max_velocity {speed:g} rad/s is above the velocity limit of {joint_name} '
                f'({self.velocity_limits[role]:g} rad/s)')
        start = physical_to_roles(situation.positions, base)
        goal = start.copy()
        goal[role] += delta
        lower, upper = self.kinematics.lower[role], self.kinematics.upper[role]
        if not lower <= goal[role] <= upper:
            raise TeleopRefusedError(
                f'{joint_name} would reach {goal[role]:.4f} rad, outside its limits '
                f'[{lower:g}, {upper:g}] rad (it is at {start[role]:.4f} rad)')
        path = np.linspace(0.0, 1.0, PATH_SAMPLES)[:, None] * (goal - start) + start
        self._check_surface(np.array([self.kinematics.forward(q)[:3] for q in path]),
                            other_gripper(base), f'moving {joint_name} by {delta:+.4f} rad')
        return JointJog(joint_name, base, start, goal, float(goal[role]), speed)

    # ------------------------------------------------------------------ tip jogs
    def tip_jog(self, situation: Situation, delta: Sequence[float], max_velocity: float
                ) -> TipJog:
        """Check a tip jog and return it.

        Parameters
        ----------
        delta : sequence of 3 float
            Displacement [m] of the free gripper's contact point in its own frame.
        max_velocity : float
            Speed along the line [m/s]; 0 for ``teleop.tip_speed``.

        Raises
        ------
        TeleopRefusedError
            Naming the rule the command breaks; nothing is to be done.
        """
        p = self.parameters
        if isinstance(delta, (str, bytes)) or len(delta) != 3:
            raise TeleopRefusedError(f'delta must have 3 values (x, y, z in m), got '
                                     f'{value_text(delta)}')
        delta = np.array([_finite(v, 'delta', 'm') for v in delta])
        speed = self._speed(max_velocity, p.tip_speed, p.max_tip_speed, 'teleop.max_tip_speed',
                            'm/s')
        length = float(np.linalg.norm(delta))
        if length < _NO_MOTION:
            raise TeleopRefusedError('delta is (0, 0, 0) m: there is nothing to move')
        if length > p.max_tip_jog:
            raise TeleopRefusedError(
                f'the jog is {length * 1e3:.1f} mm long, longer than a jog may be '
                f'(teleop.max_tip_jog = {p.max_tip_jog * 1e3:g} mm): jog in smaller steps')
        base = self.jog_base(situation)
        free = other_gripper(base)
        start = physical_to_roles(situation.positions, base)
        pose = self.kinematics.forward(start)
        tilt = float(pose[3])
        if abs(tilt) > p.max_tilt:
            raise TeleopRefusedError(
                f'gripper {free} is tilted {tilt:+.4f} rad from vertical (teleop.max_tilt = '
                f'{p.max_tilt:g} rad) and a tip jog keeps it vertical: level it first with '
                f'jog_joint {joint_of_role(4, base)} by {tilt:+.4f} rad')
        heading = tip_heading(self.kinematics, start)
        c, s = math.cos(heading), math.sin(heading)
        delta_base = np.array([c * delta[0] - s * delta[1], s * delta[0] + c * delta[1],
                               delta[2]])
        start_point = pose[:3]
        goal_point = start_point + delta_base
        path = start_point + np.linspace(0.0, 1.0, PATH_SAMPLES)[:, None] * delta_base
        self._check_surface(path, free, 'the jog')
        goal = self._check_reachable(path, start, base)
        return TipJog(free, base, start, start_point, goal_point, delta, speed, goal)

    @staticmethod
    def joint_miss(positions: np.ndarray, jog: JointJog | TipJog) -> float:
        """Return how far [rad] the farthest joint is from a jog's goal angles.

        Parameters
        ----------
        positions : ndarray, shape (5,)
            Measured joint angles in physical order [rad].
        """
        roles = physical_to_roles(np.asarray(positions, dtype=float), jog.base_gripper)
        return float(np.max(np.abs(roles - jog.goal)))

    def tip_miss(self, positions: np.ndarray, jog: TipJog) -> float:
        """Return the distance [m] of the free gripper from a tip jog's goal point.

        The forward kinematics of the measured joints (physical order [rad]): what the walker
        knows of where its gripper is.
        """
        roles = physical_to_roles(np.asarray(positions, dtype=float), jog.base_gripper)
        return float(np.linalg.norm(self.kinematics.forward(roles)[:3] - jog.goal_point))

    def correction(self, positions: np.ndarray, jog: JointJog | TipJog) -> Correction:
        """Return the joint move from where a jog settled to its goal configuration.

        A jog that settles too far from its target (a joint stuck in its friction short of it,
        a stream the controllers stopped following while the graph stalled) gets one: a
        minimum-jerk move of every joint to the jog's goal angles, which also levels the
        gripper again. Its path is checked against the truss surface as a jog's is.

        Parameters
        ----------
        positions : ndarray, shape (5,)
            Measured joint angles in physical order [rad] now.
        jog : JointJog or TipJog
            The jog whose goal was not reached.

        Raises
        ------
        TeleopRefusedError
            When the move would break the surface rule.
        """
        start = physical_to_roles(np.asarray(positions, dtype=float), jog.base_gripper)
        path = np.linspace(0.0, 1.0, PATH_SAMPLES)[:, None] * (jog.goal - start) + start
        self._check_surface(np.array([self.kinematics.forward(q)[:3] for q in path]),
                            other_gripper(jog.base_gripper), 'the correction')
        return Correction(jog.base_gripper, start, jog.goal.copy(),
                          self.parameters.joint_speed)

    def _check_reachable(self, path: np.ndarray, start: np.ndarray, base: str) -> np.ndarray:
        """Refuse a line the arm cannot follow with the gripper vertical within its limits.

        The IK branch is the start's; the tip yaw J5 turns with the base yaw J1, as the
        planner's Cartesian lines do. Returns the joint angles J1..J5 [rad] at the end.
        """
        kin = self.kinematics
        t2, t3, t4 = start[1:4]
        reach = kin.l2 * math.sin(t2) + kin.l2 * math.sin(t2 + t3) \
            + kin.l1 * math.sin(t2 + t3 + t4)
        elbow, side = ('up' if t3 >= 0 else 'down'), ('forward' if reach >= 0 else 'backward')
        reference = start.copy()
        for index, point in enumerate(path[1:], start=1):
            try:
                theta = kin.inverse([*point, 0.0, reference[4]], elbow, side,
                                    reference=reference, check_limits=False)
                theta[4] = start[4] + (theta[0] - start[0])
                kin.check_joint_limits(theta)
            except KinematicsError as error:
                where = index / (len(path) - 1)
                raise TeleopRefusedError(
                    f'the line leaves the reachable workspace {where:.0%} of the way, at '
                    f'{np.round(point, 4).tolist()} m in the base frame: {_named(error, base)}'
                ) from None
            reference = theta
        return reference

    # ------------------------------------------------------------------ gripper commands
    def gripper_operation(self, situation: Situation, gripper: str, action: str
                          ) -> GripperOperation:
        """Check a screw-in or unscrew command and return it.

        Parameters
        ----------
        gripper : str
            ``'a'`` or ``'b'``.
        action : str
            ``'screw_in'`` or ``'unscrew'``.

        Raises
        ------
        TeleopRefusedError
            Naming the rule the command breaks; nothing is to be done.
        """
        if gripper not in GRIPPERS:
            raise TeleopRefusedError(f'unknown gripper {gripper!r}: expected "a" or "b"')
        if action not in ('screw_in', 'unscrew'):
            raise TeleopRefusedError(unknown_choice('gripper action', action,
                                                    {'screw_in': 'screw_in',
                                                     'unscrew': 'unscrew'}))
        self.check_free(situation)
        states = self._states(situation)
        other = other_gripper(gripper)
        state, node = states[gripper], situation.gripper_nodes.get(gripper, '')
        if action == 'unscrew':
            if state == GripperState.JAMMED:  # not holding anything: it backs out at once
                return GripperOperation(gripper, action, situation.base_gripper,
                                        (GripperState.FREE,))
            if state != GripperState.ATTACHED:
                raise TeleopRefusedError(f'gripper {gripper} is {state}: only an attached (or '
                                         f'jammed) gripper can be unscrewed')
            if states[other] != GripperState.ATTACHED:
                raise TeleopRefusedError(
                    f'gripper {gripper} is the only gripper attached (gripper {other} is '
                    f'{states[other]}): unscrewing it would let go of the truss')
            base = other if gripper == situation.base_gripper else situation.base_gripper
            return GripperOperation(gripper, action, base, (GripperState.FREE,))
        if state == GripperState.ATTACHED:
            raise TeleopRefusedError(f'gripper {gripper} is already attached at {node}')
        base = other if states[other] == GripperState.ATTACHED else situation.base_gripper
        return GripperOperation(gripper, action, base, (GripperState.ATTACHED,))

    # ------------------------------------------------------------------ helpers
    @staticmethod
    def _speed(requested: float, default: float, largest: float, name: str, unit: str
               ) -> float:
        requested = _finite(requested, 'max_velocity', unit)
        if requested < 0.0:
            raise TeleopRefusedError(f'max_velocity must not be negative, got {requested:g} '
                                     f'{unit} (0 means the default, {default:g} {unit})')
        if requested > largest:
            raise TeleopRefusedError(f'max_velocity {requested:g} {unit} is above {name} = '
                                     f'{largest:g} {unit}')
        return requested or default

    def _check_way_out(self, points: np.ndarray, free: str, what: str) -> np.ndarray | None:
        """Refuse a path from below the surface that does not lead straight out of it.

        A gripper a fault left below the truss surface is brought out by a path that rises,
        never sinking on the way, and moves sideways by no more than it has risen (plus the
        surface tolerance) until it is ``teleop.clearance`` above the surface. Returns the
        rest of the path from there (None when it never gets there).
        """
        tolerance, clearance = self.surface_tolerance, self.parameters.clearance
        out = np.flatnonzero(points[:, 2] >= clearance)
        way = points[:(out[0] + 1 if out.size else len(points))]
        depth = f'gripper {free} is {-points[0, 2] * 1e3:.1f} mm below the truss surface'
        rule = (f'from below the surface a jog may only move it up, and sideways by no more '
                f'than it rises, until it is teleop.clearance = {clearance * 1e3:g} mm above it')
        sinks = np.flatnonzero(np.diff(way[:, 2]) < -_SINK_SLACK)
        if sinks.size:
            deepest = float(np.min(way[sinks[0] + 1:, 2]))
            raise TeleopRefusedError(f'{depth} and {what} would take it down to '
                                     f'{-deepest * 1e3:.1f} mm below it: {rule}')
        sideways = np.hypot(*(way[:, :2] - way[0, :2]).T)
        rise = way[:, 2] - way[0, 2]
        dragged = np.flatnonzero(sideways > rise + tolerance)
        if dragged.size:
            index = int(dragged[0])
            raise TeleopRefusedError(
                f'{depth} and {what} would move it {sideways[index] * 1e3:.1f} mm sideways '
                f'while it rises {rise[index] * 1e3:.1f} mm: {rule}')
        return points[out[0]:] if out.size else None

    def _check_surface(self, points: np.ndarray, free: str, what: str) -> None:
        """Refuse a path of the free gripper's contact point that breaks a surface rule.

        ``points`` are the contact point's positions along the path [m], base frame, in order.
        A path that starts below the surface is a way out (:meth:`_check_way_out`); from
        where it is ``teleop.clearance`` above the surface the ordinary rules apply.
        """
        tolerance, clearance = self.surface_tolerance, self.parameters.clearance
        if points[0, 2] < -tolerance:
            points = self._check_way_out(points, free, what)
            if points is None:
                return
        lowest = int(np.argmin(points[:, 2]))
        if points[lowest, 2] < -tolerance:
            raise TeleopRefusedError(
                f'{what} would take gripper {free} {millimetres(-points[lowest, 2])} mm below the '
                f'truss surface')
        sideways = np.hypot(*(points[:, :2] - points[0, :2]).T)
        low = (sideways > tolerance) & (points[:, 2] < clearance)
        if np.any(low):
            index = int(np.flatnonzero(low)[0])
            raise TeleopRefusedError(
                f'{what} would move gripper {free} {millimetres(sideways[index])} mm sideways '
                f'while it is {millimetres(points[index, 2])} mm above the truss surface: it must '
                f'be at least teleop.clearance = {clearance * 1e3:g} mm above it to move '
                f'sideways; lift it straight up first')


def _named(error: Exception, base: str) -> str:
    """Add the physical joint names to a kinematics message that speaks of roles J1..J5."""
    names = ', '.join(f'J{role} = {joint_of_role(role, base)}' for role in range(1, 6))
    return f'{error} (with gripper {base} as base: {names})'


class SettleDetector:
    """Tells when the joints have been still long enough after a motion.

    Parameters
    ----------
    velocity : float
        Every joint speed must stay below this [rad/s] ...
    duration : float
        ... for this long [s].
    """

    def __init__(self, velocity: float, duration: float) -> None:
        self.velocity = velocity
        self.duration = duration
        self._since: float | None = None

    def reset(self) -> None:
        """Forget the stillness seen so far."""
        self._since = None

    def update(self, now: float, velocities: Sequence[float]) -> bool:
        """Take the joint speeds [rad/s] at ``now`` [s]; True once settled."""
        if not np.all(np.abs(np.asarray(velocities, dtype=float)) < self.velocity):
            self._since = None
            return False
        if self._since is None:
            self._since = now
        return now - self._since >= self.duration
