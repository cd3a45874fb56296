"""The walker as URDF, generated from the parameters (the one description of its bodies).

Two views of the same model come out of one builder, so they cannot drift apart:

* :func:`plant_urdf`, what the pybullet plant loads: each flexible link is split into
  ``robot.flexibility.segments_per_link`` rigid segments joined by passive bending joints, one
  in the arm plane (``*_in_plane_joint``, about the pitch axis direction) and one out of it
  (``*_out_of_plane_joint``); each actuated joint has a *rotor* link on its parent side that
  carries the motor's rotor inertia ``I_m`` (the plant gears it to its joint at ``n_i:1``, which
  is how the reflected inertia ``n_i^2 I_m`` of eqs (9)-(13) enters a simulator that has no
  joint armature);
* :func:`description_urdf`, what the plant publishes on ``robot_description`` for
  robot_state_publisher, RViz or Foxglove: the same links, masses and frames, with the passive
  bending joints fixed (the links drawn straight) and no rotors, so that the five actuated
  joints of ``joint_states`` are all it moves.

Frames and axes follow :mod:`walker_core.kinematics` exactly: the root link ``gripper_a`` has
its origin at gripper a's contact point with z along the gripper axis away from the truss; the
chain is ``Rz(th1) Tz(l1) Rx(-th2) Tz(l2) Rx(-th3) Tz(l2) Rx(-th4) Tz(l1) Rz(th5) Ry(pi)``, so
at zero bending the frame of ``gripper_b`` is ``WalkerKinematics.forward_transform`` of the
physical joint angles (gripper a as base). Physical joint angles equal role angles with gripper
a as base.

Masses follow the lumped model of :mod:`walker_core.dynamics` where it places them: each
gripper's mass at its contact point, each wrist's at its pitch axis, the vertex drive's at the
vertex axis (half on each link, so the model is the same seen from either gripper); each link's
mass is spread uniformly along it. Rotational inertias of those bodies are small (solid spheres
of the visual radii below); the visual sizes are cosmetic.
"""

from __future__ import annotations

import dataclasses
import math
from xml.sax.saxutils import quoteattr

import numpy as np

from walker_core.camera import mount_rpy, mount_transform, optical_frame_name
from walker_core.joint_roles import PHYSICAL_JOINT_NAMES

__all__ = [
    'GRIPPER_LINKS', 'ACTUATED_AXES', 'FlexJoint', 'flex_joints', 'rotor_joint_name',
    'rotor_link_name', 'plant_urdf', 'description_urdf', 'robot_urdf',
]

#: Link whose frame is each gripper's contact point (z along the gripper axis, away from truss).
GRIPPER_LINKS = {'a': 'gripper_a', 'b': 'gripper_b'}

#: Axis of each actuated joint in its own frame (see the chain in the module docstring).
ACTUATED_AXES = {
    'a_yaw_joint': (0.0, 0.0, 1.0), 'a_pitch_joint': (-1.0, 0.0, 0.0),
    'vertex_joint': (-1.0, 0.0, 0.0), 'b_pitch_joint': (-1.0, 0.0, 0.0),
    'b_yaw_joint': (0.0, 0.0, -1.0),
}

# Cosmetic sizes [m] (visuals, and the radii of the small rotational inertias).
_GRIPPER_RADIUS = 0.035
_GRIPPER_HEIGHT = 0.07
_SCREW_RADIUS = 0.008
_WRIST_RADIUS = 0.03
_LINK_RADIUS = 0.015
_DUMMY_RADIUS = 0.01
# Mass [kg] of the massless helpers: the body between the two bending joints of a bend, as a
# fraction of a segment, and the rotor (its mass belongs to the housing masses).
_BEND_BODY_MASS_FRACTION = 0.01
_ROTOR_MASS = 1e-3
# Range [rad] of a passive bending joint: a link bent further than this is broken.
_BEND_LIMIT = 0.5

_COLORS = {'gripper': (0.85, 0.55, 0.1, 1.0), 'wrist': (0.25, 0.25, 0.3, 1.0),
           'link': (0.75, 0.78, 0.82, 1.0), 'screw': (0.5, 0.5, 0.5, 1.0)}


@dataclasses.dataclass(frozen=True)
class FlexJoint:
    """One passive bending joint of a flexible link.

    Attributes
    ----------
    name : str
        Joint name in the plant URDF.
    link : str
        ``'a'`` (between ``a_pitch_joint`` and ``vertex_joint``) or ``'b'``.
    index : int
        Bend number 1..segments_per_link-1 from the link's gripper-a end.
    plane : str
        ``'in_plane'`` (bending in the arm plane, seen at joints 2-3) or ``'out_of_plane'``
        (bending out of it, seen in yaw at joint 1).
    """

    name: str
    link: str
    index: int
    plane: str


def flex_joints(segments_per_link: int) -> list[FlexJoint]:
    """Every passive bending joint of the plant model, in URDF order."""
    joints = []
    for link in ('a', 'b'):
        for index in range(1, segments_per_link):
            for plane in ('in_plane', 'out_of_plane'):
                joints.append(FlexJoint(f'link_{link}_bend{index}_{plane}_joint', link, index,
                                        plane))
    return joints


def rotor_link_name(joint_name: str) -> str:
    """Name of the rotor link of an actuated joint."""
    return joint_name.replace('_joint', '_rotor')


def rotor_joint_name(joint_name: str) -> str:
    """Name of the joint on which the rotor of an actuated joint spins."""
    return joint_name.replace('_joint', '_rotor_joint')


def _fmt(values) -> str:
    return ' '.join(f'{float(v):.9g}' for v in values)


@dataclasses.dataclass
class _Inertial:
    """Mass, centre of mass and inertia tensor about the centre of mass, in the link frame."""

    mass: float = 0.0
    com: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(3))
    inertia: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((3, 3)))

    def add(self, mass: float, com, inertia) -> None:
        """Add a body (mass [kg], centre [m], inertia about its own centre [kg*m^2])."""
        com = np.asarray(com, dtype=float)
        total = self.mass + mass
        new_com = (self.mass * self.com + mass * com) / total

        def shifted(m, c, inertia_c):
            d = c - new_com
            return inertia_c + m * (np.dot(d, d) * np.eye(3) - np.outer(d, d))

        self.inertia = (shifted(self.mass, self.com, self.inertia)
                        + shifted(mass, com, np.asarray(inertia, dtype=float)))
        self.mass, self.com = total, new_com

    def xml(self) -> str:
        i = self.inertia
        return (f'<inertial><origin xyz="{_fmt(self.com)}" rpy="0 0 0"/>'
                f'<mass value="{self.mass:.9g}"/>'
                f'<inertia ixx="{i[0, 0]:.9g}" ixy="{i[0, 1]:.9g}" ixz="{i[0, 2]:.9g}" '
                f'iyy="{i[1, 1]:.9g}" iyz="{i[1, 2]:.9g}" izz="{i[2, 2]:.9g}"/></inertial>')


def _sphere_inertia(mass: float, radius: float) -> np.ndarray:
    return 0.4 * mass * radius ** 2 * np.eye(3)


def _rod_inertia(mass: float, length: float, radius: float) -> np.ndarray:
    """Solid cylinder along z about its centre."""
    transverse = mass * (3.0 * radius ** 2 + length ** 2) / 12.0
    return np.diag([transverse, transverse, 0.5 * mass * radius ** 2])


def _visual(shape: str, origin=(0.0, 0.0, 0.0), color: str = 'link') -> str:
    return (f'<visual><origin xyz="{_fmt(origin)}" rpy="0 0 0"/><geometry>{shape}</geometry>'
            f'<material name="walker_{color}"><color rgba="{_fmt(_COLORS[color])}"/></material>'
            f'</visual>')


def _cylinder(radius: float, length: float) -> str:
    return f'<cylinder radius="{radius:.9g}" length="{length:.9g}"/>'


def _sphere(radius: float) -> str:
    return f'<sphere radius="{radius:.9g}"/>'


class _Builder:
    def __init__(self, name: str) -> None:
        self.parts = ['<?xml version="1.0"?>',
                      f'<robot name={quoteattr(name)}>']

    def link(self, name: str, inertial: _Inertial | None, visuals: list[str]) -> None:
        body = inertial.xml() if inertial is not None and inertial.mass > 0 else ''
        self.parts.append(f'<link name={quoteattr(name)}>{body}{"".join(visuals)}</link>')

    def joint(self, name: str, kind: str, parent: str, child: str, xyz=(0.0, 0.0, 0.0),
              rpy=(0.0, 0.0, 0.0), axis=None, limits: tuple[float, float, float, float] | None
              = None) -> None:
        text = (f'<joint name={quoteattr(name)} type="{kind}"><parent link={quoteattr(parent)}/>'
                f'<child link={quoteattr(child)}/><origin xyz="{_fmt(xyz)}" rpy="{_fmt(rpy)}"/>')
        if axis is not None:
            text += f'<axis xyz="{_fmt(axis)}"/>'
        if limits is not None:
            lower, upper, effort, velocity = limits
            text += (f'<limit lower="{lower:.9g}" upper="{upper:.9g}" effort="{effort:.9g}" '
                     f'velocity="{velocity:.9g}"/>')
        self.parts.append(text + '</joint>')

    def text(self) -> str:
        return '\n'.join([*self.parts, '</robot>', ''])


def robot_urdf(params, *, flexible: bool = True, rotors: bool = True,
               out_of_plane_first: bool = False) -> str:
    """Generate the walker's URDF from :class:`walker_core.robot_parameters.WalkerParameters`.

    Parameters
    ----------
    params : WalkerParameters
        The shared parameters (geometry, masses, drives, flexibility).
    flexible : bool
        True: passive bending joints are revolute (the plant model); False: they are fixed.
    rotors : bool
        Add a rotor link (inertia ``I_m`` about the joint axis) beside each actuated joint.
    out_of_plane_first : bool
        Order of the two bending joints of a bend, from the root: in-plane first (False) or
        out-of-plane first. The body the plant roots at gripper b is this URDF read from the
        other end; with the order reversed it bends exactly as the body rooted at a (two
        rotations about different axes do not commute).

    Returns
    -------
    str
        The URDF document.
    """
    robot = params.robot
    l1, l2 = robot.geometry.l1, robot.geometry.l2
    mass = robot.mass
    segments = robot.flexibility.segments_per_link
    segment_length = l2 / segments
    segment_mass = mass.link / segments
    build = _Builder(robot.name)

    def actuated(name: str, parent: str, child: str, xyz, rpy=(0.0, 0.0, 0.0)) -> None:
        role = PHYSICAL_JOINT_NAMES.index(name) + 1
        drive = robot.drive.for_role(role)
        axis = ACTUATED_AXES[name]
        build.joint(name, 'revolute', parent, child, xyz, rpy, axis,
                    (drive.position_min, drive.position_max, drive.torque_limit,
                     drive.velocity_limit))
        if rotors:
            rotor = _Inertial()
            inertia = 0.5 * robot.drive.motor_inertia * np.ones(3)
            inertia[int(np.argmax(np.abs(axis)))] = robot.drive.motor_inertia
            rotor.add(_ROTOR_MASS, (0.0, 0.0, 0.0), np.diag(inertia))
            build.link(rotor_link_name(name), rotor, [])
            build.joint(rotor_joint_name(name), 'continuous', parent, rotor_link_name(name),
                        xyz, rpy, axis)

    gripper_visuals = [
        _visual(_cylinder(_GRIPPER_RADIUS, _GRIPPER_HEIGHT), (0.0, 0.0, 0.5 * _GRIPPER_HEIGHT),
                'gripper'),
        _visual(_cylinder(_SCREW_RADIUS, params.truss.hole_depth),
                (0.0, 0.0, -0.5 * params.truss.hole_depth), 'screw'),
    ]
    post = l1 - _GRIPPER_HEIGHT
    gripper_a = _Inertial()
    gripper_a.add(mass.gripper, (0.0, 0.0, 0.0), _sphere_inertia(mass.gripper, _GRIPPER_RADIUS))
    build.link('gripper_a', gripper_a, gripper_visuals)

    wrist_a = _Inertial()
    wrist_a.add(mass.wrist, (0.0, 0.0, l1), _sphere_inertia(mass.wrist, _WRIST_RADIUS))
    build.link('a_wrist', wrist_a, [
        _visual(_sphere(_WRIST_RADIUS), (0.0, 0.0, l1), 'wrist'),
        _visual(_cylinder(_LINK_RADIUS, post), (0.0, 0.0, _GRIPPER_HEIGHT + 0.5 * post),
                'wrist')])
    actuated('a_yaw_joint', 'gripper_a', 'a_wrist', (0.0, 0.0, 0.0))

    parent, origin = 'a_wrist', (0.0, 0.0, l1)
    for side in ('a', 'b'):
        for k in range(segments):
            name = f'link_{side}_{k}'
            body = _Inertial()
            body.add(segment_mass, (0.0, 0.0, 0.5 * segment_length),
                     _rod_inertia(segment_mass, segment_length, _LINK_RADIUS))
            if side == 'a' and k == segments - 1:
                body.add(0.5 * mass.vertex, (0.0, 0.0, segment_length), np.zeros((3, 3)))
            if side == 'b' and k == 0:
                body.add(0.5 * mass.vertex, (0.0, 0.0, 0.0), np.zeros((3, 3)))
            visuals = [_visual(_cylinder(_LINK_RADIUS, segment_length),
                               (0.0, 0.0, 0.5 * segment_length))]
            if side == 'b' and k == 0:
                visuals.append(_visual(_sphere(_WRIST_RADIUS), color='wrist'))
            if k == 0:
                build.link(name, body, visuals)
                actuated('a_pitch_joint' if side == 'a' else 'vertex_joint', parent, name,
                         origin)
            else:
                bend = f'link_{side}_bend{k}'
                helper = _Inertial()
                helper_mass = _BEND_BODY_MASS_FRACTION * segment_mass
                helper.add(helper_mass, (0.0, 0.0, 0.0),
                           _sphere_inertia(helper_mass, _DUMMY_RADIUS))
                build.link(bend, helper, [])
                build.link(name, body, visuals)
                kind = 'revolute' if flexible else 'fixed'
                limits = (-_BEND_LIMIT, _BEND_LIMIT, 1e6, 1e3) if flexible else None
                planes = [('in_plane', (-1.0, 0.0, 0.0)), ('out_of_plane', (0.0, 1.0, 0.0))]
                if out_of_plane_first:
                    planes.reverse()
                (first, first_axis), (second, second_axis) = planes
                build.joint(f'{bend}_{first}_joint', kind, parent, bend, origin,
                            axis=first_axis if flexible else None, limits=limits)
                build.joint(f'{bend}_{second}_joint', kind, bend, name,
                            axis=second_axis if flexible else None, limits=limits)
            parent, origin = name, (0.0, 0.0, segment_length)

    wrist_b = _Inertial()
    wrist_b.add(mass.wrist, (0.0, 0.0, 0.0), _sphere_inertia(mass.wrist, _WRIST_RADIUS))
    build.link('b_wrist', wrist_b, [
        _visual(_sphere(_WRIST_RADIUS), color='wrist'),
        _visual(_cylinder(_LINK_RADIUS, post), (0.0, 0.0, 0.5 * post), 'wrist')])
    actuated('b_pitch_joint', parent, 'b_wrist', origin)

    gripper_b = _Inertial()
    gripper_b.add(mass.gripper, (0.0, 0.0, 0.0), _sphere_inertia(mass.gripper, _GRIPPER_RADIUS))
    build.link('gripper_b', gripper_b, gripper_visuals)
    actuated('b_yaw_joint', 'b_wrist', 'gripper_b', (0.0, 0.0, l1), (0.0, math.pi, 0.0))
    return build.text()


def plant_urdf(params, *, out_of_plane_first: bool = False) -> str:
    """URDF the pybullet plant loads: bending joints revolute, rotor links present.

    ``out_of_plane_first``: see :func:`robot_urdf` (the body rooted at gripper b).
    """
    return robot_urdf(params, flexible=True, rotors=True, out_of_plane_first=out_of_plane_first)


def description_urdf(params) -> str:
    """URDF for ``robot_description``: bending joints fixed, no rotors (five moving joints).

    With wrist cameras (``gripper.camera.enabled``), each gripper ``g`` carries a frame
    ``camera_<g>_optical`` on a fixed joint at the camera's nominal mount (REP 104), which TF
    then carries.
    """
    urdf = robot_urdf(params, flexible=False, rotors=False)
    camera = params.gripper.camera
    if not camera.enabled:
        return urdf
    mount = mount_transform(camera.mount_position, camera.aim_distance)
    build = _Builder(params.robot.name)
    for gripper, link in GRIPPER_LINKS.items():
        frame = optical_frame_name(gripper)
        build.link(frame, None, [])
        build.joint(f'camera_{gripper}_joint', 'fixed', link, frame, mount[:3, 3],
                    mount_rpy(mount))
    cameras = '\n'.join(build.parts[2:])  # after the builder's own header
    return urdf.replace('</robot>', cameras + '\n</robot>')
