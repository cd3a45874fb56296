"""Stiffness and damping of the flexible links, computed from the parameters.

The paper (section 3) gives the structural modes the joint controllers face: about 18 rad/s at
joint 1 and about 80 rad/s at joints 2 and 3. The plant's links are rigid segments joined by
passive bending joints (:mod:`walker_core.urdf`); here the bending springs are sized so that the
model has those modes.

What "the mode seen at joint i" means here
------------------------------------------
The lowest structural mode that rings at joint i when the joints are held by their servos (all
five held, gripper a attached, gripper b free, at the default stance: gripper b one truss
spacing from gripper a, both vertical, elbow up), in joint i's bending plane: for joint 1 the
lowest out-of-plane mode of the held arm, for joints 2 and 3 the lowest in-plane one. "Rings at
joint i" means that the mode's reaction torque at joint i's brake (``M_ib phi_k``, ``M`` the
mass matrix, ``b`` the bending coordinates, ``phi_k`` the mass-normalised mode shape) is not
negligible: it is what a joint torque sensor or the motor current shows. It is the vibration
the paper's Figure 6 shows near the target, where the joints are held.

Why this definition: the filters of section 3 must keep these modes out of the loops, and they
are the modes that ring at rest, when the joints are held by their servos or stuck in their
stiction, which is most of the time near a target. A definition by the collocated resonance of
a free joint (joint i free, the others held) gives a link soft enough to lock a bend in: with
joint 1's free-joint resonance at 18 rad/s the held arm's lowest out-of-plane mode is 5.9 rad/s,
and at the end of a coarse motion the joint sticks while the link is bent and the spring torque
is below the breakaway friction, so the bend never decays (the tip 20 mm from where the joint
angles put it, for a 2 mm insertion tolerance).

With joint i free (the others held) the same springs give higher, *free-joint* (collocated)
resonances: the first resonance of joint i's own response, torque at joint i to motion of joint
i, whose residue ``phi_ik^2`` is not negligible. They are reported as
``FlexTuning.free_joint`` so the controller design can check its filters against them too; a
joint under feedback sees something between the held and the free figure.
:mod:`walker_sim.core.identification` measures both on the simulated plant.

Bending in the arm plane (about the pitch axes) is what joints 2-3 see; bending out of it (seen
in yaw) is what joint 1 sees; at the default stance the two planes decouple, so one stiffness
per plane sets each target. Joints 2 and 3 see the same held-arm in-plane modes; the in-plane
stiffness is chosen so that the geometric mean of what they see is the target (both see the
same lowest mode, so each is the target).

Damping is stiffness-proportional per plane, ``c = 2 zeta k / omega_target``: the target mode
gets the damping ratio ``robot.flexibility.damping_ratio``, higher modes more.

The modes depend on the configuration; the ones computed and measured here are those of the
default stance.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
from collections.abc import Iterator

import numpy as np
import pybullet
import scipy.linalg

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_core.kinematics import WalkerKinematics
from walker_core.urdf import flex_joints, plant_urdf, rotor_joint_name
from walker_sim.core.bullet import direct_client, index_body, load_urdf_text

__all__ = ['LinearModel', 'FlexTuning', 'default_stance', 'linear_model', 'tune_flexibility',
           'first_visible_mode', 'IDENTIFIED_JOINTS', 'JOINT_PLANES', 'VISIBLE_RESIDUE']

#: The joints whose modes the paper gives, with gripper a as base: J1, J2, J3.
IDENTIFIED_JOINTS = ('a_yaw_joint', 'a_pitch_joint', 'vertex_joint')
#: The bending plane each joint's axis sees at the stance: the yaw joints turn the arm plane
#: (out-of-plane bending), the pitch and vertex joints act in it.
JOINT_PLANES = {'a_yaw_joint': 'out_of_plane', 'a_pitch_joint': 'in_plane',
                'vertex_joint': 'in_plane', 'b_pitch_joint': 'in_plane',
                'b_yaw_joint': 'out_of_plane'}

_RIGID_MODE = 1e-3  # [rad/s] below this a mode is a rigid-body motion
#: Fraction of the largest residue above which a mode counts as seen at a joint.
VISIBLE_RESIDUE = 0.01
_MAX_ITERATIONS = 20
_RELATIVE_TOLERANCE = 1e-10


def default_stance(params) -> np.ndarray:
    """Joint angles [rad] of the default stance: gripper b one truss spacing from gripper a.

    Both grippers vertical (alpha = 0), elbow up, by the closed-form inverse kinematics of
    :mod:`walker_core.kinematics`; gripper a is the base.
    """
    kinematics = WalkerKinematics.from_parameters(params)
    return kinematics.inverse([0.0, params.truss.spacing, 0.0, 0.0, 0.0])


@dataclasses.dataclass(frozen=True)
class LinearModel:
    """The walker linearised about a stance, gripper a fixed, rotors folded into their joints.

    Attributes
    ----------
    names : tuple of str
        Degrees of freedom: the five actuated joints, then the bending joints.
    mass : ndarray
        Joint-space inertia matrix [kg*m^2] over ``names``; each actuated joint includes its
        geared rotor (``n^2 I_m`` on the diagonal, exactly as the plant simulates it).
    planes : dict
        Bending joint name -> ``'in_plane'`` or ``'out_of_plane'``.
    stance : ndarray, shape (5,)
        Actuated joint angles [rad] of the stance.
    """

    names: tuple[str, ...]
    mass: np.ndarray
    planes: dict[str, str]
    stance: np.ndarray

    def modes(self, free: tuple[str, ...], in_plane: float, out_of_plane: float
              ) -> tuple[np.ndarray, np.ndarray, list[str]]:
        """Natural frequencies and mass-normalised mode shapes with some joints free.

        Parameters
        ----------
        free : tuple of str
            Actuated joints left free; the others are held still.
        in_plane, out_of_plane : float
            Bending stiffness [N*m/rad] of the two planes.

        Returns
        -------
        frequencies : ndarray
            Natural frequencies [rad/s], ascending (rigid-body modes are 0).
        shapes : ndarray
            Mass-normalised mode shapes, one column per mode, over ``dofs``.
        dofs : list of str
            The degrees of freedom of the shapes: ``free`` then the bending joints.
        """
        dofs = [*free, *self.planes]
        index = [self.names.index(name) for name in dofs]
        mass = self.mass[np.ix_(index, index)]
        stiffness = np.diag([0.0 if name in free else
                             (in_plane if self.planes[name] == 'in_plane' else out_of_plane)
                             for name in dofs])
        eigenvalues, shapes = scipy.linalg.eigh(stiffness, mass)
        return np.sqrt(np.clip(eigenvalues, 0.0, None)), shapes, dofs

    def held_modes(self, in_plane: float, out_of_plane: float
                   ) -> tuple[np.ndarray, list[str], np.ndarray]:
        """Modes of the arm with all five joints held, and the torque each puts on the brakes.

        Parameters
        ----------
        in_plane, out_of_plane : float
            Bending stiffness [N*m/rad] of the two planes.

        Returns
        -------
        frequencies : ndarray
            Natural frequencies [rad/s], ascending.
        planes : list of str
            The bending plane of each mode (the plane whose bending joints carry most of its
            kinetic energy; at the stance each mode lies wholly in one plane).
        coupling : ndarray, shape (5, modes)
            ``M_ib phi_k`` [kg*m^2 * 1/sqrt(kg*m^2)]: the reaction torque at held joint i per
            unit modal acceleration of mode k.
        """
        frequencies, shapes, dofs = self.modes((), in_plane, out_of_plane)
        bends = [self.names.index(name) for name in dofs]
        in_rows = np.array([self.planes[name] == 'in_plane' for name in dofs])
        energy = shapes * (self.mass[np.ix_(bends, bends)] @ shapes)
        planes = ['in_plane' if energy[in_rows, k].sum() >= energy[~in_rows, k].sum()
                  else 'out_of_plane' for k in range(len(frequencies))]
        coupling = self.mass[np.ix_(range(len(PHYSICAL_JOINT_NAMES)), bends)] @ shapes
        return frequencies, planes, coupling

    def held_joint_modes(self, joint: str, in_plane: float, out_of_plane: float
                         ) -> tuple[np.ndarray, np.ndarray]:
        """Held-arm modes in ``joint``'s bending plane and their residues at its brake.

        Returns
        -------
        frequencies : ndarray
            Natural frequencies [rad/s] of the modes in the joint's plane, ascending.
        residues : ndarray
            ``(M_ib phi_k)^2`` [kg*m^2] of each: how strongly the mode loads the joint.
        """
        frequencies, planes, coupling = self.held_modes(in_plane, out_of_plane)
        row = PHYSICAL_JOINT_NAMES.index(joint)
        mine = np.array([plane == JOINT_PLANES[joint] for plane in planes])
        return frequencies[mine], coupling[row, mine] ** 2

    def held_joint_mode(self, joint: str, in_plane: float, out_of_plane: float) -> float:
        """Return the mode seen at ``joint`` [rad/s]: held arm, its plane (module docstring)."""
        return first_visible_mode(*self.held_joint_modes(joint, in_plane, out_of_plane))

    def free_joint_modes(self, joint: str, in_plane: float, out_of_plane: float
                         ) -> tuple[np.ndarray, np.ndarray]:
        """Flexible modes of joint ``joint``'s own response, that joint free, the others held.

        Returns
        -------
        frequencies : ndarray
            Natural frequencies [rad/s] of the flexible modes, ascending.
        residues : ndarray
            Residue ``phi^2`` [1/(kg*m^2)] of each mode in the joint's accelerance.
        """
        frequencies, shapes, _ = self.modes((joint,), in_plane, out_of_plane)
        flexible = frequencies > _RIGID_MODE
        return frequencies[flexible], shapes[0, flexible] ** 2

    def free_joint_mode(self, joint: str, in_plane: float, out_of_plane: float) -> float:
        """Return the free-joint (collocated) resonance [rad/s] of ``joint``."""
        return first_visible_mode(*self.free_joint_modes(joint, in_plane, out_of_plane))


def first_visible_mode(frequencies, residues) -> float:
    """Lowest mode whose residue is at least :data:`VISIBLE_RESIDUE` of the largest one.

    Raises
    ------
    ValueError
        If there is no mode, or none with a residue above zero.
    """
    frequencies = np.asarray(frequencies, dtype=float)
    residues = np.asarray(residues, dtype=float)
    if len(frequencies) == 0 or not residues.max() > 0.0:
        raise ValueError('no mode is seen: every residue is zero')
    visible = residues >= VISIBLE_RESIDUE * residues.max()
    return float(frequencies[visible].min())


@dataclasses.dataclass(frozen=True)
class PosedPlant:
    """The plant's URDF loaded in a headless pybullet client, posed at a stance.

    Attributes
    ----------
    client, body : int
        The pybullet client and the body in it.
    index : object
        The body's joints and links by name (:func:`~walker_sim.core.bullet.index_body`).
    positions : numpy.ndarray
        [rad] Every movable joint's position (the stance's joints; rotors and bends at 0).
    dof_of : dict
        Joint name -> its index in ``positions``.
    """

    client: int
    body: int
    index: object
    positions: np.ndarray
    dof_of: dict

    def reduced(self, names, gear: np.ndarray) -> np.ndarray:
        """Return ``T`` with ``qdot_full = T qdot_reduced`` for the reduced coordinates ``names``.

        A rotor turns ``gear`` [-] times its joint (role order of
        :data:`~walker_core.joint_roles.PHYSICAL_JOINT_NAMES`); a bend is its own coordinate.
        """
        transform = np.zeros((len(self.positions), len(names)))
        for column, name in enumerate(names):
            transform[self.dof_of[name], column] = 1.0
            if name in PHYSICAL_JOINT_NAMES:
                transform[self.dof_of[rotor_joint_name(name)], column] = \
                    gear[PHYSICAL_JOINT_NAMES.index(name)]
        return transform


@contextlib.contextmanager
def posed_plant(params, stance) -> Iterator[PosedPlant]:
    """Load the URDF the plant loads in a throwaway headless client, posed at ``stance`` [rad]."""
    with direct_client() as client:
        body = load_urdf_text(client, plant_urdf(params), fixed_base=True)
        index = index_body(client, body)
        name_of = {joint: name for name, joint in index.joints.items()}
        dof_of = {name_of[joint]: dof for dof, joint in enumerate(index.movable)}
        positions = np.zeros(len(index.movable))
        for name, angle in zip(PHYSICAL_JOINT_NAMES, stance, strict=True):
            positions[dof_of[name]] = angle
        yield PosedPlant(client, body, index, positions, dof_of)


def linear_model(params, stance=None) -> LinearModel:
    """Linearise the plant model about a stance (default: :func:`default_stance`).

    The inertia comes from pybullet's own ``calculateMassMatrix`` of the URDF the plant loads,
    in a throwaway headless client, so it is the inertia the plant simulates.
    """
    stance = default_stance(params) if stance is None else np.asarray(stance, dtype=float)
    gear = params.robot.drive.role_array('gear_ratio')
    bends = flex_joints(params.robot.flexibility.segments_per_link)
    with posed_plant(params, stance) as plant:
        full = np.array(pybullet.calculateMassMatrix(plant.body, plant.positions.tolist(),
                                                     physicsClientId=plant.client))
    names = (*PHYSICAL_JOINT_NAMES, *(bend.name for bend in bends))
    # Reduced coordinates: the rotor turns n times its joint, so qdot_full = T qdot_reduced.
    transform = plant.reduced(names, gear)
    mass = transform.T @ full @ transform
    return LinearModel(names=names, mass=0.5 * (mass + mass.T),
                       planes={bend.name: bend.plane for bend in bends}, stance=stance)


@dataclasses.dataclass(frozen=True)
class FlexTuning:
    """Bending stiffness and damping of the links, and the modes they give.

    Attributes
    ----------
    in_plane_stiffness, out_of_plane_stiffness : float
        Stiffness of each bending joint [N*m/rad] in the arm plane and out of it.
    in_plane_damping, out_of_plane_damping : float
        Damping of each bending joint [N*m*s/rad].
    predicted : dict
        Joint name -> predicted mode seen at that joint [rad/s] (J1-J3, default stance): the
        lowest held-arm mode of its plane (module docstring).
    free_joint : dict
        Joint name -> predicted free-joint (collocated) resonance [rad/s] (J1-J3): joint i
        free, the others held. Higher than ``predicted``; what the filter of a joint whose
        own loop is soft faces.
    held : tuple of float
        Lowest natural frequencies [rad/s] with all five joints held, both planes.
    stiffest : float
        Highest natural frequency [rad/s] of the model (all joints free or all held), which
        bounds the physics step.
    stance : tuple of float
        The stance [rad] of the figures above.
    """

    in_plane_stiffness: float
    out_of_plane_stiffness: float
    in_plane_damping: float
    out_of_plane_damping: float
    predicted: dict[str, float]
    free_joint: dict[str, float]
    held: tuple[float, ...]
    stiffest: float
    stance: tuple[float, ...]

    def minimum_physics_rate(self) -> float:
        """Lowest physics rate [Hz] that integrates the stiffest mode with margin.

        Semi-implicit Euler, which pybullet uses, is stable for ``omega * h < 2``; we ask for
        ``omega * h <= 1``.
        """
        return self.stiffest

    def stiffness_of(self, plane: str) -> float:
        """Stiffness [N*m/rad] of a bending joint of the given plane."""
        return self.in_plane_stiffness if plane == 'in_plane' else self.out_of_plane_stiffness

    def damping_of(self, plane: str) -> float:
        """Damping [N*m*s/rad] of a bending joint of the given plane."""
        return self.in_plane_damping if plane == 'in_plane' else self.out_of_plane_damping


def tune_flexibility(params, model: LinearModel | None = None) -> FlexTuning:
    """Size the bending springs so the held arm has the paper's modes at the default stance.

    Parameters
    ----------
    params : WalkerParameters
        ``robot.flexibility.joint1_mode``, ``joints23_mode`` and ``damping_ratio`` are the
        targets.
    model : LinearModel, optional
        The linearised model (default: :func:`linear_model` of ``params``).

    Returns
    -------
    FlexTuning
        Stiffness and damping per plane, the predicted modes seen at J1-J3 (held arm) and the
        free-joint resonances.

    Notes
    -----
    Each plane's modes scale with the square root of its stiffness; the planes decouple at the
    stance, so the fixed-point iteration (one stiffness per plane rescaled by its target ratio
    squared) converges in a step or two. It is kept general for stances where they do not.
    """
    model = linear_model(params) if model is None else model
    flexibility = params.robot.flexibility
    yaw_joint, pitch_joint, vertex_joint = IDENTIFIED_JOINTS
    in_plane, out_of_plane = 1.0, 1.0
    for _ in range(_MAX_ITERATIONS):
        yaw = model.held_joint_mode(yaw_joint, in_plane, out_of_plane)
        pitch = model.held_joint_mode(pitch_joint, in_plane, out_of_plane)
        vertex = model.held_joint_mode(vertex_joint, in_plane, out_of_plane)
        new_out = out_of_plane * (flexibility.joint1_mode / yaw) ** 2
        new_in = in_plane * flexibility.joints23_mode ** 2 / (pitch * vertex)
        converged = (math.isclose(new_out, out_of_plane, rel_tol=_RELATIVE_TOLERANCE)
                     and math.isclose(new_in, in_plane, rel_tol=_RELATIVE_TOLERANCE))
        in_plane, out_of_plane = new_in, new_out
        if converged:
            break
    predicted = {joint: model.held_joint_mode(joint, in_plane, out_of_plane)
                 for joint in IDENTIFIED_JOINTS}
    free_joint = {joint: model.free_joint_mode(joint, in_plane, out_of_plane)
                  for joint in IDENTIFIED_JOINTS}
    held, _, _ = model.modes((), in_plane, out_of_plane)
    free, _, _ = model.modes(PHYSICAL_JOINT_NAMES, in_plane, out_of_plane)
    zeta = flexibility.damping_ratio
    return FlexTuning(
        in_plane_stiffness=in_plane, out_of_plane_stiffness=out_of_plane,
        in_plane_damping=2.0 * zeta * in_plane / flexibility.joints23_mode,
        out_of_plane_damping=2.0 * zeta * out_of_plane / flexibility.joint1_mode,
        predicted=predicted, free_joint=free_joint, held=tuple(float(w) for w in held[:4]),
        stiffest=float(max(held.max(), free.max())),
        stance=tuple(float(a) for a in model.stance))
