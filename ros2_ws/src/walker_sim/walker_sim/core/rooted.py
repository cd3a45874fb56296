"""The walker as a pybullet body rooted at its base gripper, one body per possible base.

A gripper screwed into the truss is welded to it. Pybullet can model that weld in two ways:
as a fixed constraint on a free-floating body, or by making the welded gripper the body's
fixed base. The constraint is solved by pybullet's iterative solver together with the gears
and the friction motors, and on this model it converges slowly: with 50 iterations at 2 kHz,
joint 1's response to a torque step differs from the converged one by up to 7 % (friction on).
A fixed base has no such error (0.35 % with the same settings) and costs less per step.

So the plant loads the walker twice, each body in its own headless client: one rooted at
gripper a, one at gripper b. Only the body rooted at the base gripper is stepped. When that
gripper lets go (the other one is screwed in then: the interlock sees to it), its state is
carried over to the body rooted at the other gripper (:func:`carry_state`).

The model is symmetric by construction (gripper, wrist ``l1``, link ``l2``, link ``l2``, wrist
``l1``, gripper; one set of masses and role-symmetric drives), so the body rooted at b is the
same URDF read from the other end: its ``a_yaw_joint`` is the physical ``b_yaw_joint``, its
``gripper_a`` the physical gripper b, and so on; only the two bending joints of each bend come
in the other order (out of the plane first), since read backwards the bend's two rotations are
applied in reverse. Joint angles keep their sign under this mirror (the role convention of
:mod:`walker_core.kinematics`), in-plane bending angles too, and out-of-plane bending angles
change sign (their axis, y, is the one the gripper's ``Ry(pi)`` leaves in place). One thing
differs between the two bodies: each rotor sits on the side of its joint nearer the root, so
the few terms of the rotor's own inertia ``I_m`` (not the reflected ``n^2 I_m``) that depend on
which link carries the stator move with the base.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pybullet

from walker_core.joint_roles import GRIPPERS, PHYSICAL_JOINT_NAMES, other_gripper
from walker_core.urdf import (
    GRIPPER_LINKS, FlexJoint, flex_joints, plant_urdf, rotor_joint_name)
from walker_sim.core.bullet import BodyIndex, free_dynamics, index_body, load_urdf_text

__all__ = ['RootedBody', 'load_rooted_body', 'carry_state']

# Largest force [N] and torque [N*m] the gear constraints may apply: far above anything the
# drives can produce, so they never give way.
_GEAR_FORCE = 1.0e6
# Largest spring torque [N*m] of a bending joint (pybullet's PD needs a bound).
_BEND_TORQUE = 1.0e6


@dataclasses.dataclass(frozen=True)
class RootedBody:
    """One loaded walker body, its fixed base at gripper ``root``, and the physical names.

    Attributes
    ----------
    root : str
        The gripper (``'a'`` or ``'b'``) that is the body's fixed base.
    client, body : int
        Pybullet client and body ids.
    index : BodyIndex
        The body's own joint and link names.
    joints, rotors : tuple of int
        Body joint index of each physical joint and of its rotor, physical order.
    bends : tuple of int
        Body joint index of each physical bending joint, :func:`flex_joints` order.
    bend_signs : ndarray, shape (n_bends,)
        Physical bending angle = sign * the body's angle.
    gripper_links : dict
        Physical gripper -> body link index (-1 for the root).
    """

    root: str
    client: int
    body: int
    index: BodyIndex
    joints: tuple[int, ...]
    rotors: tuple[int, ...]
    bends: tuple[int, ...]
    bend_signs: np.ndarray
    gripper_links: dict[str, int]

    def disconnect(self) -> None:
        """Disconnect the body's client (the body cannot be used afterwards)."""
        if pybullet.isConnected(self.client):
            pybullet.disconnect(physicsClientId=self.client)


def _mirror_bend(bend: FlexJoint, segments: int) -> FlexJoint:
    """Return the bending joint of the body rooted at b that is the physical ``bend``."""
    link = other_gripper(bend.link)
    index = segments - bend.index
    return FlexJoint(f'link_{link}_bend{index}_{bend.plane}_joint', link, index, bend.plane)


def load_rooted_body(root: str, params, flexibility, physics_step: float) -> RootedBody:
    """Load the walker in a new headless client, fixed base at gripper ``root``.

    Parameters
    ----------
    root : str
        ``'a'`` or ``'b'``.
    params : WalkerParameters
        For the gear ratios and the number of segments per link.
    flexibility : FlexTuning
        Bending stiffness and damping per plane.
    physics_step : float
        Physics step [s].
    """
    client = pybullet.connect(pybullet.DIRECT)
    try:
        pybullet.setGravity(0.0, 0.0, 0.0, physicsClientId=client)
        pybullet.setPhysicsEngineParameter(fixedTimeStep=physics_step, numSubSteps=1,
                                           physicsClientId=client)
        mirrored = root == 'b'
        body = load_urdf_text(client, plant_urdf(params, out_of_plane_first=mirrored),
                              fixed_base=True)
        index = index_body(client, body)
        free_dynamics(client, body, index)
        names = PHYSICAL_JOINT_NAMES[::-1] if mirrored else PHYSICAL_JOINT_NAMES
        segments = params.robot.flexibility.segments_per_link
        physical_bends = flex_joints(segments)
        own_bends = ([_mirror_bend(bend, segments) for bend in physical_bends] if mirrored
                     else physical_bends)
        bend_signs = np.array([-1.0 if mirrored and bend.plane == 'out_of_plane' else 1.0
                               for bend in physical_bends])
        rooted = RootedBody(
            root=root, client=client, body=body, index=index,
            joints=tuple(index.joints[name] for name in names),
            rotors=tuple(index.joints[rotor_joint_name(name)] for name in names),
            bends=tuple(index.joints[bend.name] for bend in own_bends), bend_signs=bend_signs,
            gripper_links={g: index.links[GRIPPER_LINKS[other_gripper(g) if mirrored else g]]
                           for g in GRIPPERS})
        if own_bends:
            pybullet.setJointMotorControlArray(
                body, list(rooted.bends), pybullet.PD_CONTROL,
                targetPositions=[0.0] * len(own_bends), targetVelocities=[0.0] * len(own_bends),
                positionGains=[flexibility.stiffness_of(b.plane) for b in own_bends],
                velocityGains=[flexibility.damping_of(b.plane) for b in own_bends],
                forces=[_BEND_TORQUE] * len(own_bends), physicsClientId=client)
        gears = params.robot.drive.role_array('gear_ratio')
        for joint, rotor, ratio in zip(rooted.joints, rooted.rotors, gears, strict=True):
            gear = pybullet.createConstraint(body, rotor, body, joint, pybullet.JOINT_GEAR,
                                             [0.0, 0.0, 1.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0],
                                             physicsClientId=client)
            pybullet.changeConstraint(gear, gearRatio=-float(ratio), maxForce=_GEAR_FORCE,
                                      erp=0.0, physicsClientId=client)
        return rooted
    except Exception:
        pybullet.disconnect(physicsClientId=client)
        raise


def _joint_states(rooted: RootedBody, joints) -> tuple[np.ndarray, np.ndarray]:
    states = pybullet.getJointStates(rooted.body, list(joints), physicsClientId=rooted.client)
    return np.array([s[0] for s in states]), np.array([s[1] for s in states])


def carry_state(source: RootedBody, target: RootedBody) -> None:
    """Put ``target`` in the state of ``source``: the same walker, now rooted elsewhere.

    The target's root gripper is placed where the source has it and is at rest (it is
    screwed in); every joint, rotor and bending joint takes the source's angle and speed in
    physical terms. Constraints are not carried: the caller owns the attachments.
    """
    if source.gripper_links[target.root] == -1:
        position, orientation = pybullet.getBasePositionAndOrientation(
            source.body, physicsClientId=source.client)
    else:
        link = pybullet.getLinkState(source.body, source.gripper_links[target.root],
                                     computeForwardKinematics=True,
                                     physicsClientId=source.client)
        position, orientation = link[4], link[5]
    pybullet.resetBasePositionAndOrientation(target.body, position, orientation,
                                             physicsClientId=target.client)
    pairs = [(source.joints, target.joints, np.ones(len(source.joints))),
             (source.rotors, target.rotors, np.ones(len(source.rotors))),
             (source.bends, target.bends, source.bend_signs * target.bend_signs)]
    for from_joints, to_joints, signs in pairs:
        if not from_joints:
            continue
        angles, speeds = _joint_states(source, from_joints)
        for joint, angle, speed in zip(to_joints, signs * angles, signs * speeds, strict=True):
            pybullet.resetJointState(target.body, joint, float(angle), float(speed),
                                     physicsClientId=target.client)
