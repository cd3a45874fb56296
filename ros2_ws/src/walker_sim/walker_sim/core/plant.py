"""The walker plant: pybullet behind ``reset()``, ``step(torques, dt)`` and ``state()``.

What it simulates (zero gravity, headless DIRECT client, explicit client id):

* the robot of :func:`walker_core.urdf.plant_urdf`: rigid bodies from the parameters, each
  flexible link split into rigid segments joined by bending springs in both planes (stiffness
  and damping from :mod:`walker_sim.core.flexibility`, applied by pybullet's per-step PD on the
  bending joints: an exact linear spring-damper evaluated every physics step), each actuated
  joint geared ``n:1`` to a rotor of inertia ``I_m`` (the reflected ``n^2 I_m`` of eqs
  (9)-(13));
* the drives of :mod:`walker_sim.core.motor`: torque limits, refusal of non-finite commands,
  Coulomb friction with stiction; hard end stops at the joint limits;
* the truss and the grippers of :mod:`walker_sim.core.grippers`: the base gripper is the fixed
  base of the body being stepped (:mod:`walker_sim.core.rooted`: one body rooted at each
  gripper, the walker carried over from one to the other when the base lets go), and the other
  gripper, once screwed in, is a rigid pybullet constraint to its node;
* the nodes' faces, entry chamfers and bores of :mod:`walker_sim.core.contact`, which a free
  gripper meets (one-sided spring-dampers applied as external forces every physics step).

All per-joint arrays are in physical joint order (``a_yaw_joint`` ... ``b_yaw_joint``), SI
units. Time advances only by :meth:`WalkerPlant.step`; the physics is deterministic.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable

import numpy as np
import pybullet

from walker_core.joint_roles import GRIPPERS, other_gripper
from walker_core.camera import CameraModel
from walker_core.kinematics import WalkerKinematics
from walker_core.parameter_schema import ParameterError
from walker_core.rotations import quaternion_from_matrix
from walker_core.truss import Truss
from walker_core.urdf import flex_joints
from walker_core.gripper_state import GripperState
from walker_sim.core.camera_truth import MountErrors
from walker_sim.core.config import SimParameters, StartConfiguration, check_against_walker
from walker_sim.core.contact import (
    ContactForce, NodeGeometry, Seat, contact_forces, where_the_screw_is)
from walker_sim.core.flexibility import FlexTuning, tune_flexibility
from walker_sim.core.grippers import (
    GripperCommandError, GripperLogic, GripperStatus, HoleAlignment,
    ScrewOutcome, hole_alignment)
from walker_sim.core.imperfections import JointSensors, NodePlacement
from walker_sim.core.motor import DriveCommand, DriveModel
from walker_sim.core.rooted import RootedBody, carry_state, load_rooted_body
from walker_sim.core.snapshot import PlantSnapshot
from walker_sim.core.frame_worker import FrameWorker, PendingFrame
from walker_sim.core.render_process import RenderProcess
from walker_sim.core.wrist_camera import CameraFrame, WristCameras

__all__ = ['PlantError', 'Pose', 'GripperReport', 'PlantState', 'WalkerPlant',
           'SOLVER_ITERATIONS', 'SOLVER_RESIDUAL']

# Largest force [N] and torque [N*m] an attachment constraint may apply:
# far above anything the drives can produce, so they never give way.
_CONSTRAINT_FORCE = 1.0e6
# Torque [N*m] a held joint's brake may apply (identification holds joints still with it).
_HOLD_TORQUE = 1.0e6
#: Constraint solver (gears, friction, the tip's attachment) iterations and residual. With
#: the base gripper as the fixed base, 30 iterations at 1 kHz keep every joint's response to a
#: torque step within 0.7 % of the converged one (friction on; benchmarks/plant_benchmark.py
#: measures it); pybullet's default of 50 costs 12 % more per step and is no closer at 1 kHz,
#: where the time step, not the solver, is the larger error.
SOLVER_ITERATIONS = 30
SOLVER_RESIDUAL = 1e-7
#: [m/s] Faster than the gripper ever moves (1.5 rad/s of joint speed at the arm's full 1.5 m
#: reach is 2.3 m/s): a gripper this far above a face is not looked at again for that long.
MAX_GRIPPER_SPEED = 3.0
# [m] Above its node's face by more than this, a gripper touches nothing
_CONTACT_REACH = 0.01
# Step durations whose number of physics steps a plant remembers (one, the control period,
# in every caller; a few in tests)
_REMEMBERED_DURATIONS = 8


class PlantError(ValueError):
    """A request the plant cannot honour (bad step, bad command); nothing changed."""


@dataclasses.dataclass(frozen=True)
class Pose:
    """A frame in the truss (world) frame.

    Attributes
    ----------
    position : ndarray, shape (3,)
        Origin [m].
    orientation : ndarray, shape (4,)
        Unit quaternion ``(x, y, z, w)``.
    """

    position: np.ndarray
    orientation: np.ndarray

    @property
    def z_axis(self) -> tuple[float, float, float]:
        """Unit z axis of the frame, in the truss frame (the gripper axis)."""
        x, y, z, w = (float(v) for v in self.orientation)
        return (2.0 * (x * z + w * y), 2.0 * (y * z - w * x), 1.0 - 2.0 * (x * x + y * y))

    def matrix(self) -> np.ndarray:
        """Homogeneous transform (4x4)."""
        transform = np.eye(4)
        transform[:3, :3] = np.reshape(pybullet.getMatrixFromQuaternion(
            self.orientation.tolist()), (3, 3))
        transform[:3, 3] = self.position
        return transform

    @classmethod
    def from_matrix(cls, transform: np.ndarray) -> 'Pose':
        """Pose of a homogeneous transform."""
        return cls(np.array(transform[:3, 3], dtype=float),
                   quaternion_from_matrix(transform[:3, :3]))


@dataclasses.dataclass(frozen=True)
class GripperReport:
    """A gripper's state and where it is relative to the nearest hole."""

    status: GripperStatus
    alignment: HoleAlignment


@dataclasses.dataclass(frozen=True)
class PlantState:
    """The plant at one instant.

    Attributes
    ----------
    time : float
        Simulated time [s] since the last reset.
    position, velocity : ndarray, shape (5,)
        Joint angles [rad] as the joint sensors read them (the true angles unless
        ``sim.imperfections`` gives the sensors an offset or noise) and true speeds [rad/s].
    acceleration : ndarray, shape (5,)
        Mean joint acceleration [rad/s^2] over the last step (velocity change over its length).
    effort : ndarray, shape (5,)
        Torque [N*m] the drives applied during the last step (after limits and refusals).
    friction : ndarray, shape (5,)
        Friction torque [N*m] on each joint at the end of the last step.
    saturated, refused : ndarray of bool, shape (5,)
        The last command was clamped at the torque limit / was non-finite and replaced by 0.
    statuses : dict
        ``'a'``/``'b'`` -> :class:`~walker_sim.core.grippers.GripperStatus`.
    poses : dict
        ``'a'``/``'b'`` -> :class:`Pose` of the gripper's contact-point frame in the truss frame.
    base : str
        The gripper the simulated body is rooted at (``'a'`` or ``'b'``): the attached one, or
        the one attached longest.
    tip : str
        The gripper that moves or moves next (:attr:`GripperLogic.tip`): the free one, and
        while both are attached the one the next step releases (not the one that screwed in
        last, which the supervisor makes its base).
    measure : callable
        Pose -> :class:`~walker_sim.core.grippers.HoleAlignment` against the nearest hole.
    """

    time: float
    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    effort: np.ndarray
    friction: np.ndarray
    saturated: np.ndarray
    refused: np.ndarray
    statuses: dict[str, GripperStatus]
    poses: dict[str, Pose]
    base: str
    tip: str
    measure: Callable[[Pose], HoleAlignment] = dataclasses.field(repr=False, compare=False)

    @functools.cached_property
    def grippers(self) -> dict[str, GripperReport]:
        """``'a'``/``'b'`` -> :class:`GripperReport` (state and hole alignment).

        Measured on first use: the node needs it at the gripper heartbeat, not every period.
        """
        return {g: GripperReport(self.statuses[g], self.measure(self.poses[g]))
                for g in GRIPPERS}

    @property
    def tip_position(self) -> np.ndarray:
        """True position [m] of the tip gripper's contact point in the other gripper's frame.

        Where the flexible robot's tip really is (links bent or not), in the frame of the
        paper's eq (1) with the other gripper as its base; compare with the forward kinematics
        of ``position``.
        """
        base = self.poses[other_gripper(self.tip)].matrix()
        tip = self.poses[self.tip].position
        return base[:3, :3].T @ (tip - base[:3, 3])


class WalkerPlant:
    """The simulated walker on its truss.

    Parameters
    ----------
    params : WalkerParameters
        The shared robot, truss, gripper and timing parameters.
    sim : SimParameters
        The plant's own settings (``sim.*``).
    flexibility : FlexTuning, optional
        Bending stiffness and damping; computed from ``params`` when omitted.

    Raises
    ------
    ParameterError
        If the settings are inconsistent (start nodes off the truss, physics rate not a multiple
        of the control rate or too low for the stiffest mode of the model, unreachable start).
    """

    def __init__(self, params, sim: SimParameters, flexibility: FlexTuning | None = None
                 ) -> None:
        check_against_walker(sim, params)
        self.params = params
        self.sim = sim
        self.flexibility = tune_flexibility(params) if flexibility is None else flexibility
        needed = self.flexibility.minimum_physics_rate()
        if sim.physics_rate < needed:
            raise ParameterError(
                f'sim.physics_rate ({sim.physics_rate:g} Hz) is too low for the stiffest mode '
                f'of the model ({self.flexibility.stiffest:.0f} rad/s): it needs at least '
                f'{needed:.0f} Hz (fewer robot.flexibility.segments_per_link also lowers it)')
        self.physics_step = 1.0 / sim.physics_rate
        self.drive = DriveModel.from_parameters(params, sim)
        self.truss = Truss.from_parameters(params)
        imperfect = sim.imperfections
        self.placement = NodePlacement(self.truss.node_names, imperfect.node_placement,
                                       imperfect.seed)
        self.sensors = JointSensors(imperfect.joint_offset, imperfect.joint_noise,
                                    imperfect.seed)
        self.kinematics = WalkerKinematics.from_parameters(params)
        self._grippers = GripperLogic.from_parameters(params)
        self.node_geometry = NodeGeometry.from_parameters(params)
        self._mouths = {name: tuple(float(v) for v in self.node_position(name))
                        for name in self.truss.node_names}
        self.cameras, self._renders = self._wrist_cameras()
        self._contacts: list[ContactForce] = []
        self._contact_enabled = True
        self._contact_skip = 0  # physics steps the free gripper cannot reach a face in
        try:
            self._build()
            self.reset()
        except Exception:
            self.close()
            raise

    # ------------------------------------------------------------------ set-up
    def _build(self) -> None:
        self._bodies: dict[str, RootedBody] = {}
        for root in GRIPPERS:
            self._bodies[root] = load_rooted_body(root, self.params, self.flexibility,
                                                  self.physics_step)
        self._active = self._bodies['a']
        self.set_solver(SOLVER_ITERATIONS, SOLVER_RESIDUAL)
        bends = flex_joints(self.params.robot.flexibility.segments_per_link)
        self._bend_stiffness = np.array([self.flexibility.stiffness_of(b.plane) for b in bends])
        self._gear_ratio = np.asarray(self.params.robot.drive.role_array('gear_ratio'),
                                      dtype=float)
        self._attachments: dict[str, int] = {}
        self._pull: dict[str, tuple[Pose, Pose]] = {}
        self._held = np.zeros(5, dtype=bool)
        self._friction_enabled = np.ones(5, dtype=bool)
        self._level_override: tuple[float | None, ...] | None = None
        self._motor_levels: tuple[float, ...] | None = None
        self._steps_of: dict[float, int] = {}  # step duration [s] -> physics steps

    def _wrist_cameras(self) -> tuple[WristCameras | None, FrameWorker | None]:
        """Return the grippers' cameras (``gripper.camera.*``) and their renderer, or Nones.

        The cameras here take the exposures; a process of their own, with cameras made alike,
        renders them (started now, so that it is ready by the first frame).
        """
        camera, imperfect = self.params.gripper.camera, self.sim.imperfections
        if not camera.enabled:
            return None, None
        make_cameras = functools.partial(
            WristCameras, CameraModel.from_parameters(camera), self.sim.camera,
            MountErrors(imperfect.camera_mount_position, imperfect.camera_mount_angle,
                        imperfect.seed),
            self.truss, self._mouths, self.node_geometry, imperfect.seed)
        renders = FrameWorker(functools.partial(RenderProcess, make_cameras))
        renders.start()
        return make_cameras(), renders

    @property
    def client(self) -> int:
        """Pybullet client of the body being stepped (the one rooted at the base gripper)."""
        return self._active.client

    @property
    def body(self) -> int:
        """Pybullet id of the body being stepped."""
        return self._active.body

    @property
    def index(self):
        """Joint and link names of the body being stepped."""
        return self._active.index

    def close(self) -> None:
        """Disconnect the physics clients (the plant cannot be used afterwards)."""
        for rooted in getattr(self, '_bodies', {}).values():
            rooted.disconnect()
        if getattr(self, '_renders', None) is not None:
            self._renders.close()  # after the render under way: its process ends
        if getattr(self, 'cameras', None) is not None:
            self.cameras.close()

    def __enter__(self) -> 'WalkerPlant':
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    # ------------------------------------------------------------------ reset
    def start_angles(self, start: StartConfiguration) -> tuple[np.ndarray, np.ndarray]:
        """Joint angles [rad] and base-gripper pose (4x4) of a start configuration.

        The base gripper sits in its node's hole, axes aligned with the truss; the other one is
        vertical above its node at ``other_height`` (elbow up, inverse kinematics of
        :mod:`walker_core.kinematics`).

        Raises
        ------
        ParameterError
            If the other node cannot be reached from the base node.
        """
        base_position = self.node_position(start.base_node)
        target = self.node_position(start.other_node) - base_position
        target[2] += start.other_height
        try:
            roles = self.kinematics.inverse([target[0], target[1], target[2], 0.0, 0.0])
        except ValueError as error:
            raise ParameterError(f'sim.start: node {start.other_node} cannot be reached from '
                                 f'{start.base_node}: {error}') from None
        physical = roles if start.base_gripper == 'a' else roles[::-1]
        base_pose = np.eye(4)
        base_pose[:3, 3] = base_position
        return np.array(physical, dtype=float), base_pose

    def reset(self, start: StartConfiguration | None = None) -> PlantState:
        """Put the robot at a start configuration (default ``sim.start``), at rest, time 0.

        Raises
        ------
        ParameterError
            If the start configuration is not reachable (nothing changes).
        """
        start = self.sim.start if start is None else start
        angles, base_pose = self.start_angles(start)
        for gripper in list(self._attachments):
            self._detach(gripper)
        self._pull.clear()
        self._contacts = []
        self._contact_skip = 0
        self._active = rooted = self._bodies[start.base_gripper]
        root_pose = Pose.from_matrix(base_pose)
        pybullet.resetBasePositionAndOrientation(rooted.body, root_pose.position.tolist(),
                                                 root_pose.orientation.tolist(),
                                                 physicsClientId=rooted.client)
        for joint in rooted.index.movable:
            pybullet.resetJointState(rooted.body, joint, 0.0, 0.0, physicsClientId=rooted.client)
        for joint, angle in zip(rooted.joints, angles, strict=True):
            pybullet.resetJointState(rooted.body, joint, float(angle), 0.0,
                                     physicsClientId=rooted.client)
        attached = {start.base_gripper: start.base_node}
        if start.other_attached:
            attached[other_gripper(start.base_gripper)] = start.other_node
        self._grippers.reset(attached, start.base_gripper)
        for gripper in attached:
            if gripper != rooted.root:
                self._attach(gripper, self._gripper_pose(gripper))
        self._time_steps = 0
        self._command = DriveCommand(np.zeros(5), np.zeros(5, bool), np.zeros(5, bool))
        self._acceleration = np.zeros(5)
        self._motor_levels = None
        self._read_joints()
        self.sensors.restart()
        self.sensors.sample()
        if self.cameras is not None:
            self._renders.discard()  # a frame of the plant before the reset is never had
            self.cameras.restart()
        return self.state()

    # ------------------------------------------------------------------ snapshot
    def snapshot(self) -> PlantSnapshot:
        """Return the plant's physical state, for a plant started again to restore.

        See :mod:`walker_sim.core.snapshot`.
        """
        rooted = self._active
        position, orientation = pybullet.getBasePositionAndOrientation(
            rooted.body, physicsClientId=rooted.client)
        states = pybullet.getJointStates(rooted.body, list(rooted.index.movable),
                                         physicsClientId=rooted.client)
        holds = {}
        for gripper, constraint in self._attachments.items():
            info = pybullet.getConstraintInfo(constraint, physicsClientId=rooted.client)
            holds[gripper] = (tuple(info[7]), tuple(info[9]))  # the child (world) frame
        return PlantSnapshot(
            time_steps=self._time_steps, root=rooted.root, base=self._grippers.base,
            tip=self._grippers.tip,
            root_position=tuple(position), root_orientation=tuple(orientation),
            positions=tuple(s[0] for s in states), velocities=tuple(s[1] for s in states),
            grippers={g: {'mode': status.mode.name, 'node': status.node, 'elapsed': elapsed}
                      for g, (status, elapsed) in self._grippers.timers().items()},
            holds=holds,
            pulls={g: ((tuple(start.position), tuple(start.orientation)),
                       (tuple(seat.position), tuple(seat.orientation)))
                   for g, (start, seat) in self._pull.items()},
            fouled_screw_ins=self._grippers.fouled_screw_ins)

    def restore(self, snapshot: PlantSnapshot) -> PlantState:
        """Put the plant in the state of ``snapshot`` (simulated time included).

        Raises
        ------
        PlantError
            If the snapshot does not fit this plant (another model, an unknown gripper or
            mode, a gripper held at no node of this truss); nothing changes.
        """
        self._check_snapshot(snapshot)
        for gripper in list(self._attachments):
            self._detach(gripper)
        self._pull.clear()
        self._contacts = []
        self._contact_skip = 0
        self._active = rooted = self._bodies[snapshot.root]
        pybullet.resetBasePositionAndOrientation(rooted.body, list(snapshot.root_position),
                                                 list(snapshot.root_orientation),
                                                 physicsClientId=rooted.client)
        for joint, angle, rate in zip(rooted.index.movable, snapshot.positions,
                                      snapshot.velocities, strict=True):
            pybullet.resetJointState(rooted.body, joint, angle, rate,
                                     physicsClientId=rooted.client)
        self._grippers.restore({g: (GripperState[s['mode']], s['node'], s['elapsed'])
                                for g, s in snapshot.grippers.items()}, snapshot.base,
                                snapshot.tip)
        self._grippers.fouled_screw_ins = snapshot.fouled_screw_ins
        for gripper, (position, orientation) in snapshot.holds.items():
            self._attach(gripper, Pose(np.array(position), np.array(orientation)))
        for gripper, (start, seat) in snapshot.pulls.items():
            self._pull[gripper] = (Pose(np.array(start[0]), np.array(start[1])),
                                   Pose(np.array(seat[0]), np.array(seat[1])))
        self._time_steps = snapshot.time_steps
        self._command = DriveCommand(np.zeros(5), np.zeros(5, bool), np.zeros(5, bool))
        self._acceleration = np.zeros(5)
        self._motor_levels = None
        self._read_joints()
        return self.state()

    def _check_snapshot(self, snapshot: PlantSnapshot) -> None:
        if (snapshot.root not in GRIPPERS or snapshot.base not in GRIPPERS
                or snapshot.tip not in (*GRIPPERS, '')):
            raise PlantError(f'snapshot: unknown root, base or tip gripper '
                             f'({snapshot.root!r}, {snapshot.base!r}, {snapshot.tip!r})')
        movable = len(self._bodies[snapshot.root].index.movable)
        if len(snapshot.positions) != movable:
            raise PlantError(f'snapshot: {len(snapshot.positions)} joint angles for a model '
                             f'of {movable} movable joints (another robot.flexibility?)')
        if set(snapshot.grippers) != set(GRIPPERS):
            raise PlantError(f'snapshot: gripper states for {sorted(snapshot.grippers)}')
        for gripper, status in snapshot.grippers.items():
            if status['mode'] not in GripperState.__members__:
                raise PlantError(f'snapshot: gripper {gripper} in an unknown mode '
                                 f'{status["mode"]!r}')
            if status['node']:
                try:
                    self.truss.index(status['node'])
                except ValueError as error:
                    raise PlantError(f'snapshot: gripper {gripper}: {error}') from None
        held = {g for g, s in snapshot.grippers.items() if s['mode'] in (
            'SCREWING', 'ATTACHED', 'UNSCREWING')}
        if snapshot.root not in held or set(snapshot.holds) != held - {snapshot.root}:
            raise PlantError(f'snapshot: the grippers held ({sorted(held)}) do not match the '
                             f'root {snapshot.root!r} and the holds {sorted(snapshot.holds)}')
        if snapshot.time_steps < 0:
            raise PlantError(f'snapshot: negative time ({snapshot.time_steps} steps)')

    # ------------------------------------------------------------------ stepping
    @property
    def time(self) -> float:
        """Simulated time [s] since the last reset."""
        return self._time_steps * self.physics_step

    def step(self, torques, dt: float) -> PlantState:
        """Apply joint torques for ``dt`` seconds and return the new state.

        Parameters
        ----------
        torques : array_like, shape (5,)
            Commanded joint torques [N*m]; clamped at the torque limits, NaN or infinite values
            replaced by 0 (reported in the state).
        dt : float
            Duration [s]: a whole number of physics steps.

        Raises
        ------
        PlantError
            If ``dt`` is not a positive whole number of physics steps or ``torques`` does not
            have five values (nothing happens).
        """
        steps = self._steps_of.get(dt) if type(dt) is float else None
        if steps is None:
            steps = self._whole_steps(dt)
        try:
            command = self.drive.command(torques)
        except ValueError as error:
            raise PlantError(str(error)) from None
        start_velocity = self._velocity
        torque_list = command.torque.tolist()
        grippers = self._grippers
        free = self._free_gripper()
        for _ in range(steps):
            self._set_friction_motors()
            rooted = self._active
            pybullet.setJointMotorControlArray(rooted.body, rooted.joints,
                                               pybullet.TORQUE_CONTROL, forces=torque_list,
                                               physicsClientId=rooted.client)
            if free is not None:
                self._touch(free)
            pybullet.stepSimulation(physicsClientId=rooted.client)
            self._time_steps += 1
            self._read_joints()
            if grippers.busy:
                self._advance_grippers()
                free = self._free_gripper()
        self.sensors.sample()
        self._command = command
        duration = steps * self.physics_step
        self._acceleration = np.array([(end - start) / duration for end, start in zip(
            self._velocity, start_velocity, strict=True)])
        return self.state()

    def _free_gripper(self) -> str | None:
        """Return the gripper that can touch a node (free or jammed, not the base), or None."""
        if not self._contact_enabled:
            return None
        tip = other_gripper(self._active.root)
        mode = self._grippers.status(tip).mode
        return tip if mode in (GripperState.FREE, GripperState.JAMMED) else None

    def _nearest_mouth(self, x: float, y: float) -> tuple[str, tuple[float, float, float]]:
        """Return the node nearest a point of the truss plane and where its mouth really is [m]."""
        truss = self.truss
        column = min(max(round((x - truss.origin[0]) / truss.spacing), 0), truss.columns - 1)
        row = min(max(round((y - truss.origin[1]) / truss.spacing), 0), truss.rows - 1)
        node = f'n{column}_{row}'
        return node, self._mouths[node]

    def _touch(self, gripper: str) -> None:
        """Apply the node's contact forces on a free gripper for the coming physics step.

        A gripper far above every face is looked at again only when it could have reached
        one at :data:`MAX_GRIPPER_SPEED`: nothing touches it meanwhile, whenever it is looked
        at, so the physics is the same.
        """
        if self._contact_skip > 0:
            self._contact_skip -= 1
            return
        rooted = self._active
        link = rooted.gripper_links[gripper]
        centre, _, _, _, position, orientation, velocity, spin = pybullet.getLinkState(
            rooted.body, link, computeLinkVelocity=True, computeForwardKinematics=True,
            physicsClientId=rooted.client)
        _, mouth = self._nearest_mouth(position[0], position[1])
        clearance = position[2] - mouth[2] - _CONTACT_REACH
        if clearance > 0.0:  # far above the face (the common case): no contact
            self._contacts = []
            self._contact_skip = int(clearance / (MAX_GRIPPER_SPEED * self.physics_step))
            return
        x, y, z, w = orientation
        z_axis = (2.0 * (x * z + w * y), 2.0 * (y * z - w * x), 1.0 - 2.0 * (x * x + y * y))
        self._contacts = contact_forces(self.node_geometry, mouth, position, z_axis, velocity,
                                        spin, centre)
        for contact in self._contacts:
            pybullet.applyExternalForce(rooted.body, link, contact.force, contact.point,
                                        pybullet.WORLD_FRAME, physicsClientId=rooted.client)

    @property
    def contacts(self) -> list[ContactForce]:
        """The node's forces on the free gripper during the last physics step (truss frame)."""
        return list(self._contacts)

    def _whole_steps(self, dt: float) -> int:
        """Physics steps in ``dt`` seconds; remembered, as a plant steps by one period."""
        if not (isinstance(dt, (int, float)) and math.isfinite(dt) and dt > 0):
            raise PlantError(f'step duration must be a positive number of seconds, got {dt!r}')
        steps = round(dt / self.physics_step)
        if steps < 1 or not math.isclose(steps * self.physics_step, dt, rel_tol=1e-9):
            raise PlantError(f'step duration {dt!r} s is not a whole number of physics steps of '
                             f'{self.physics_step:g} s')
        if type(dt) is float and len(self._steps_of) < _REMEMBERED_DURATIONS:
            self._steps_of[dt] = steps
        return steps

    def _set_friction_motors(self) -> None:
        level = self.drive.friction_level(self._velocity)
        if self._level_override is not None:
            level = tuple(own if override is None else override
                          for own, override in zip(level, self._level_override, strict=True))
        if level != self._motor_levels:
            pybullet.setJointMotorControlArray(self.body, self._active.joints,
                                               pybullet.VELOCITY_CONTROL,
                                               targetVelocities=[0.0] * 5, forces=list(level),
                                               physicsClientId=self.client)
            self._motor_levels = level

    def _read_joints(self) -> None:
        states = pybullet.getJointStates(self.body, self._active.joints,
                                         physicsClientId=self.client)
        # (position, velocity, reaction forces, applied torque) per joint, as tuples
        self._position, self._velocity, _, self._friction = zip(*states, strict=True)

    # ------------------------------------------------------------------ state
    def state(self) -> PlantState:
        """Return the plant's state now."""
        return PlantState(
            time=self.time, position=self.sensors.read(self._position),
            velocity=np.array(self._velocity),
            acceleration=self._acceleration.copy(), effort=self._command.torque.copy(),
            friction=np.array(self._friction), saturated=self._command.saturated.copy(),
            refused=self._command.refused.copy(),
            statuses=self._grippers.statuses(),
            poses={g: self._gripper_pose(g) for g in GRIPPERS}, base=self._grippers.base,
            tip=self._grippers.tip, measure=self._alignment)

    def true_joint_positions(self) -> np.ndarray:
        """Return the true joint angles [rad] now, whatever the joint sensors read."""
        return np.array(self._position)

    def node_position(self, node: str) -> np.ndarray:
        """Return where a node's hole mouth really is [m], in the truss frame.

        The model's place plus its placement error (``sim.imperfections.node_placement``).
        """
        return self.truss.position(node) + self.placement.offset(node)

    def _alignment(self, pose: Pose) -> HoleAlignment:
        return hole_alignment(pose.position, pose.z_axis, self.truss,
                              self.params.truss.hole_depth, self.placement.errors)

    def _gripper_pose(self, gripper: str) -> Pose:
        link = self._active.gripper_links[gripper]
        if link == -1:
            position, orientation = pybullet.getBasePositionAndOrientation(
                self.body, physicsClientId=self.client)
        else:
            link_state = pybullet.getLinkState(self.body, link, computeForwardKinematics=True,
                                               physicsClientId=self.client)
            position, orientation = link_state[4], link_state[5]
        return Pose(np.array(position), np.array(orientation))

    def expose_camera(self, gripper: str) -> PendingFrame:
        """Expose a gripper's wrist camera now, from the true state; render it on the side.

        The exposure (the gripper's true pose, the truth, the frame's latency and noise) is
        taken here and now; the two software renders run in the cameras' render process
        (:mod:`walker_sim.core.frame_worker`), frames in the order they are exposed, while the
        plant steps on. The handle tells when the render is done and waits for it. A reset
        discards the frames exposed before it. See :mod:`walker_sim.core.wrist_camera`.

        Raises
        ------
        PlantError
            If the grippers carry no camera (``gripper.camera.enabled: false``) or the gripper
            is not ``'a'`` or ``'b'``.
        """
        if self.cameras is None:
            raise PlantError('the grippers carry no camera (gripper.camera.enabled is false)')
        if gripper not in GRIPPERS:
            raise PlantError(f"gripper must be 'a' or 'b', got {gripper!r}")
        exposure = self.cameras.expose(gripper, self._gripper_pose(gripper).matrix(), self.time)
        return self._renders.submit(exposure)

    @property
    def render_cpu_time(self) -> float:
        """[s] CPU time the cameras' renders took so far, in their process (0 without cameras)."""
        return 0.0 if self._renders is None else self._renders.cpu_time

    def camera_frame(self, gripper: str) -> CameraFrame:
        """Render a gripper's wrist camera now, from the true state, and wait for it.

        :meth:`expose_camera` and the frame's render waited for: the same frame.

        Raises
        ------
        PlantError
            If the grippers carry no camera (``gripper.camera.enabled: false``) or the gripper
            is not ``'a'`` or ``'b'``.
        """
        return self.expose_camera(gripper).result()

    # ------------------------------------------------------------------ grippers
    def screw_in(self, gripper: str) -> ScrewOutcome:
        """Screw a gripper into the hole nearest it (see :mod:`walker_sim.core.grippers`).

        Returns
        -------
        ScrewOutcome
            Started (SCREWING: the gripper is held and drawn into the hole over
            ``gripper.screw_time``), or jammed (JAMMED, with the reason).

        Raises
        ------
        GripperCommandError
            Unknown gripper, or the gripper is not free (nothing changes).
        """
        try:
            pose = self._gripper_pose(gripper)
        except KeyError:
            raise GripperCommandError(f'unknown gripper {gripper!r}: expected "a" or "b"'
                                      ) from None
        alignment = self._alignment(pose)
        outcome = self._grippers.request_screw_in(gripper, alignment,
                                                  self._resting_on_the_face(pose))
        if outcome.success:
            self._attach(gripper, pose)
            self._pull[gripper] = (pose, self._seat_pose(pose, alignment.node))
        return outcome

    @property
    def fouled_screw_ins(self) -> int:
        """Coming screw-ins that jam whatever the alignment (an injected fault)."""
        return self._grippers.fouled_screw_ins

    def foul_thread(self, screw_ins: int) -> None:
        """Inject a fouled thread: the next ``screw_ins`` screw-ins jam (0 clears it).

        Raises
        ------
        ValueError
            A negative count (nothing changes).
        """
        if screw_ins < 0:
            raise ValueError(f'screw_ins must be 0 or more, got {screw_ins}')
        self._grippers.fouled_screw_ins = int(screw_ins)

    def unscrew(self, gripper: str) -> GripperStatus:
        """Unscrew a gripper; it lets go after ``gripper.screw_time``.

        Raises
        ------
        InterlockError
            The other gripper is not ATTACHED (nothing changes).
        GripperCommandError
            Unknown gripper, or the gripper is not attached (nothing changes).
        """
        if gripper not in GRIPPERS:
            raise GripperCommandError(f'unknown gripper {gripper!r}: expected "a" or "b"')
        return self._grippers.request_unscrew(gripper)

    def command_gripper(self, gripper: str, action: str) -> tuple[bool, str]:
        """Carry out a gripper command and say how it went, as ``gripper_command`` answers.

        Parameters
        ----------
        gripper : str
            ``'a'`` or ``'b'``.
        action : {'screw_in', 'unscrew'}
            What to do.

        Returns
        -------
        success : bool
            A screw-in that started (SCREWING) or an unscrewing that started (UNSCREWING);
            False for a screw-in that jammed at once and for any refusal (nothing changed).
        message : str
            The jam's or the refusal's reason ('' when there is none).
        """
        try:
            if action == 'screw_in':
                outcome = self.screw_in(gripper)
                return outcome.success, outcome.status.message
            if action == 'unscrew':
                self.unscrew(gripper)
                return True, ''
            raise GripperCommandError(f'unknown gripper command {action!r}: expected '
                                      f"'screw_in' or 'unscrew'")
        except GripperCommandError as error:
            return False, str(error)

    def gripper_status(self, gripper: str) -> GripperStatus:
        """State of one gripper."""
        return self._grippers.status(gripper)

    def _resting_on_the_face(self, pose: Pose) -> str:
        """Say how far a gripper resting on a node's face is from its hole ('' otherwise)."""
        node, mouth = self._nearest_mouth(float(pose.position[0]), float(pose.position[1]))
        seat, height, offset = where_the_screw_is(self.node_geometry, mouth, pose.position,
                                                  pose.z_axis)
        if seat != Seat.ON_FACE:
            return ''
        return (f'resting on the face of node {node}, {height * 1e3:.2f} mm above its mouth, '
                f"the screw's tip {offset * 1e3:.2f} mm off the hole's axis (the chamfer "
                f'catches it within {self.node_geometry.chamfer_radius * 1e3:.2f} mm)')

    def _seat_pose(self, pose: Pose, node: str) -> Pose:
        """Pose of a gripper fully screwed into ``node``: at the mouth, axis vertical."""
        rotation = pose.matrix()[:3, :3]
        z_axis = rotation[:, 2]
        axis = np.cross(z_axis, [0.0, 0.0, 1.0])
        sine, cosine = np.linalg.norm(axis), float(z_axis[2])
        align = np.eye(3)
        if sine > 1e-12:
            k = axis / sine
            skew = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
            align = np.eye(3) + sine * skew + (1.0 - cosine) * skew @ skew
        seat = np.eye(4)
        seat[:3, :3] = align @ rotation
        seat[:3, 3] = self.node_position(node)
        return Pose.from_matrix(seat)

    def _attach(self, gripper: str, pose: Pose) -> None:
        constraint = pybullet.createConstraint(
            self.body, self._active.gripper_links[gripper], -1, -1, pybullet.JOINT_FIXED,
            [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], pose.position.tolist(),
            childFrameOrientation=pose.orientation.tolist(), physicsClientId=self.client)
        pybullet.changeConstraint(constraint, maxForce=_CONSTRAINT_FORCE,
                                  physicsClientId=self.client)
        self._attachments[gripper] = constraint

    def _advance_grippers(self) -> None:
        for gripper, (start, seat) in list(self._pull.items()):
            progress = self._grippers.status(gripper).progress
            self._move_attachment(gripper, start, seat, progress)
        for status in self._grippers.advance(self.physics_step):
            if status.mode == GripperState.ATTACHED:
                start, seat = self._pull.pop(status.name)
                self._move_attachment(status.name, start, seat, 1.0)
            elif status.mode == GripperState.FREE:
                if status.name == self._active.root:
                    self._reroot(other_gripper(status.name))
                else:
                    self._detach(status.name)

    def _detach(self, gripper: str) -> None:
        """Remove a gripper's attachment constraint."""
        constraint = self._attachments.pop(gripper)
        pybullet.removeConstraint(constraint, physicsClientId=self.client)

    def _reroot(self, root: str) -> None:
        """Carry the walker over to the body rooted at ``root`` (its weld becomes the base)."""
        self._detach(root)
        target = self._bodies[root]
        self._contact_skip = 0
        carry_state(self._active, target)
        self._active = target
        self._motor_levels = None

    def _move_attachment(self, gripper: str, start: Pose, seat: Pose, progress: float) -> None:
        position = start.position + progress * (seat.position - start.position)
        orientation = pybullet.getQuaternionSlerp(start.orientation.tolist(),
                                                  seat.orientation.tolist(), progress)
        pybullet.changeConstraint(self._attachments[gripper], position.tolist(),
                                  jointChildFrameOrientation=orientation,
                                  maxForce=_CONSTRAINT_FORCE, physicsClientId=self.client)

    # ------------------------------------------------------------------ test rig
    def set_solver(self, iterations: int, residual: float) -> None:
        """Set the constraint solver's iteration limit and residual threshold.

        Holding joints with brakes (:meth:`hold_joints`) needs a better converged solver than
        the walker's own motion: the identification rig raises it.
        """
        if iterations < 1 or not residual > 0:
            raise PlantError(f'solver needs iterations >= 1 and a positive residual, got '
                             f'{iterations}, {residual}')
        for rooted in self._bodies.values():
            pybullet.setPhysicsEngineParameter(numSolverIterations=int(iterations),
                                               solverResidualThreshold=float(residual),
                                               physicsClientId=rooted.client)

    def hold_joints(self, held) -> None:
        """Hold some joints still with a brake far stronger than the drives (identification).

        Parameters
        ----------
        held : array_like of bool, shape (5,)
            True for the joints to hold.
        """
        held = np.asarray(held, dtype=bool)
        if held.shape != (5,):
            raise PlantError(f'hold_joints needs 5 flags, got shape {held.shape}')
        self._held = held.copy()
        self._update_override()

    def enable_friction(self, enabled) -> None:
        """Switch joint friction on or off per joint (a frictionless test rig).

        Parameters
        ----------
        enabled : bool or array_like of bool, shape (5,)
        """
        enabled = np.broadcast_to(np.asarray(enabled, dtype=bool), (5,))
        self._friction_enabled = enabled.copy()
        self._update_override()

    def enable_contact(self, enabled: bool) -> None:
        """Switch the nodes' contact on or off (off: a rig holding the free gripper clear)."""
        self._contact_enabled = bool(enabled)
        self._contacts = []
        self._contact_skip = 0

    def _update_override(self) -> None:
        override = tuple(_HOLD_TORQUE if held else (None if enabled else 0.0)
                         for held, enabled in zip(self._held, self._friction_enabled,
                                                  strict=True))
        self._level_override = None if all(o is None for o in override) else override
        self._motor_levels = None

    def bending(self) -> np.ndarray:
        """Angles [rad] of the bending joints, in :func:`~walker_core.urdf.flex_joints` order."""
        rooted = self._active
        states = pybullet.getJointStates(rooted.body, rooted.bends, physicsClientId=rooted.client)
        return rooted.bend_signs * np.array([s[0] for s in states])

    def energy(self) -> float:
        """Mechanical energy [J] of the robot.

        The kinetic energy of every body (rotors included) plus the energy stored in the
        bending springs.
        """
        client = self.client
        links = sorted(set(self.index.links.values()))
        total = 0.0
        for link in links:
            mass, _, inertia = pybullet.getDynamicsInfo(self.body, link,
                                                        physicsClientId=client)[:3]
            if link == -1:
                velocity, spin = pybullet.getBaseVelocity(self.body, physicsClientId=client)
                orientation = pybullet.getBasePositionAndOrientation(
                    self.body, physicsClientId=client)[1]
            else:
                link_state = pybullet.getLinkState(self.body, link, computeLinkVelocity=True,
                                                   computeForwardKinematics=True,
                                                   physicsClientId=client)
                orientation, velocity, spin = link_state[1], link_state[6], link_state[7]
            rotation = np.reshape(pybullet.getMatrixFromQuaternion(orientation), (3, 3))
            local_spin = rotation.T @ np.asarray(spin)
            total += 0.5 * mass * float(np.dot(velocity, velocity))
            total += 0.5 * float(np.dot(inertia, local_spin ** 2))
        return total + 0.5 * float(np.dot(self._bend_stiffness, self.bending() ** 2))
