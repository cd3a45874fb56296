"""Contact between the free gripper and a node: the face, the thread's entry chamfer, the bore.

Each truss node is a face (a disc of :data:`FACE_RADIUS` around its hole, the plane of the
hole's mouth, normal +z, where the node really is: placement errors included) with a threaded
hole down its axis. The hole's mouth is an entry chamfer, a 45 degree cone from the chamfer
radius (``gripper.insertion_position_tolerance``: the chamfer is what that tolerance stands
for) down to the bore's radius (:data:`BORE_RADIUS_FRACTION` of it: the screw's clearance in
the bore), then the bore down to ``truss.hole_depth``.

The gripper meets it at two points: its **shoulder**, the contact point itself (the frame the
plant reports, which sits on the mouth when screwed in), a flat wider than the chamfer that
rests on the face whatever its offset; and its **screw's tip**, ``screw_length`` below the
shoulder along the gripper's axis (``gripper.screw_length``), which meets the face off the
hole, slides down the chamfer into the bore within it, and is kept in the bore by its wall.
So a gripper lowered off the hole rests on the face with its shoulder ``screw_length`` above
the mouth (the screw-in then jams: that is farther from the hole than the tolerance); one
lowered within the chamfer is guided into the bore and its shoulder comes to rest on the mouth.

Each contact is a stiff one-sided spring-damper on the penetration (never pulling), applied as
an external force in the physics step: pybullet's collision pipeline is not needed (the walker
has no collision shapes, and a concave node with a chamfered hole would need a triangle mesh),
and a force that is zero whenever nothing touches leaves every motion that touches nothing
bit for bit as it was. The contact is frictionless. Stiffness and damping are sized for the
plant's 1 kHz physics (docs/plant.md, "Contact with the node"): the contact's own mode
``sqrt(k / m)`` on the lightest effective mass the tip shows (the gripper's, about 2 kg) is
224 rad/s, ``omega h = 0.22`` at 1 ms, well inside the semi-implicit Euler step's stability
(``omega h < 2``), and the damping leaves it near critical (ratio 0.7).

Plain float arithmetic: the plant calls :func:`contact_forces` every physics step while a
gripper is free.
"""

from __future__ import annotations

import dataclasses
import enum
import math

__all__ = ['FACE_RADIUS', 'BORE_RADIUS_FRACTION', 'CONTACT_STIFFNESS',
           'CONTACT_DAMPING', 'NodeGeometry', 'ContactForce', 'Seat', 'contact_forces',
           'where_the_screw_is']

#: [m] Radius of a node's face around its hole: farther out a gripper passes beside the node.
FACE_RADIUS = 0.025
#: The bore's radius (the screw's clearance) as a fraction of the chamfer's radius.
BORE_RADIUS_FRACTION = 0.5
#: [N/m] Contact stiffness: 20 N (the drives' most at the tip) sinks 0.2 mm into the face.
CONTACT_STIFFNESS = 1.0e5
#: [N*s/m] Contact damping: a damping ratio of 0.7 on a 2 kg tip.
CONTACT_DAMPING = 630.0


class Seat(enum.Enum):
    """Where the screw's tip is against a node."""

    CLEAR = 'clear of the node'
    ON_FACE = 'on the face'
    IN_CHAMFER = 'in the chamfer'
    IN_BORE = 'in the bore'


@dataclasses.dataclass(frozen=True)
class NodeGeometry:
    """The shape of every node's face and hole.

    Attributes
    ----------
    chamfer_radius : float
        [m] Radius of the chamfer at the face (the insertion position tolerance).
    bore_radius : float
        [m] Radius the screw's tip can move off the axis in the bore.
    hole_depth : float
        [m] Depth of the bore below the mouth.
    screw_length : float
        [m] How far the gripper's screw reaches below its shoulder (``gripper.screw_length``).
    """

    chamfer_radius: float
    bore_radius: float
    hole_depth: float
    screw_length: float

    @classmethod
    def from_parameters(cls, params) -> 'NodeGeometry':
        """Return the node of the shared ``gripper.*`` and ``truss.*`` parameters."""
        chamfer = params.gripper.insertion_position_tolerance
        return cls(chamfer, BORE_RADIUS_FRACTION * chamfer, params.truss.hole_depth,
                   params.gripper.screw_length)

    @property
    def chamfer_depth(self) -> float:
        """[m] Depth of the 45 degree chamfer below the face."""
        return self.chamfer_radius - self.bore_radius

    def profile(self) -> tuple[tuple[float, float], ...]:
        """Return the node's surface, (radius, height above the mouth) [m], from the rim in.

        The material is below and outside it: face, chamfer, bore wall.
        """
        return ((FACE_RADIUS, 0.0), (self.chamfer_radius, 0.0),
                (self.bore_radius, -self.chamfer_depth), (self.bore_radius, -self.hole_depth))

    def inside(self, radius: float, height: float) -> bool:
        """Return True if the point (radius, height above the mouth) [m] is in the node."""
        if height >= 0.0 or radius >= FACE_RADIUS or height <= -self.hole_depth:
            return False
        return radius > max(self.bore_radius, self.chamfer_radius + height)


@dataclasses.dataclass(frozen=True)
class ContactForce:
    """A force [N] on the gripper at a point [m], both in the truss frame.

    ``depth`` [m] is how far the point has sunk into the node: the spring's energy is
    ``CONTACT_STIFFNESS * depth**2 / 2``.
    """

    force: tuple[float, float, float]
    point: tuple[float, float, float]
    depth: float


def _nearest_on_profile(profile, radius: float, height: float) -> tuple[float, float, float]:
    """Distance [m] to the nearest point of the profile, and the unit direction to it."""
    best = (math.inf, 0.0, 1.0)
    for (r0, z0), (r1, z1) in zip(profile[:-1], profile[1:], strict=True):
        dr, dz = r1 - r0, z1 - z0
        t = min(max(((radius - r0) * dr + (height - z0) * dz) / (dr * dr + dz * dz), 0.0), 1.0)
        nr, nz = r0 + t * dr - radius, z0 + t * dz - height
        distance = math.hypot(nr, nz)
        if distance < best[0]:
            best = (distance, nr / distance, nz / distance) if distance > 0.0 else (0.0, 0.0, 1.0)
    return best


def _point_contact(geometry: NodeGeometry, node, point, velocity, face_only: bool
                   ) -> ContactForce | None:
    x, y = point[0] - node[0], point[1] - node[1]
    height = point[2] - node[2]
    radius = math.hypot(x, y)
    if face_only:  # the shoulder: a flat wider than the chamfer
        if height >= 0.0 or radius >= FACE_RADIUS or height <= -geometry.hole_depth:
            return None
        depth, n_radial, n_z = -height, 0.0, 1.0
    else:
        if not geometry.inside(radius, height):
            return None
        depth, n_radial, n_z = _nearest_on_profile(geometry.profile(), radius, height)
    ux, uy = (x / radius, y / radius) if radius > 0.0 else (0.0, 0.0)
    normal = (n_radial * ux, n_radial * uy, n_z)
    approach = sum(v * n for v, n in zip(velocity, normal, strict=True))
    magnitude = CONTACT_STIFFNESS * depth - CONTACT_DAMPING * approach
    if magnitude <= 0.0:
        return None
    return ContactForce(tuple(magnitude * n for n in normal), tuple(point), depth)


def screw_tip(geometry: NodeGeometry, position, z_axis) -> tuple[float, float, float]:
    """Return the screw's tip [m]: ``screw_length`` below the contact point along the axis."""
    length = geometry.screw_length
    return tuple(p - length * a for p, a in zip(position, z_axis, strict=True))


def contact_forces(geometry: NodeGeometry, node, position, z_axis, velocity, spin,
                   centre) -> list[ContactForce]:
    """Return the node's forces on a free gripper (none when nothing touches).

    Parameters
    ----------
    geometry : NodeGeometry
    node : sequence of 3 float
        Where the nearest node's mouth really is [m] (truss frame).
    position, z_axis : sequence of 3 float
        The gripper's contact point [m] and its axis (unit).
    velocity, spin : sequence of 3 float
        Linear velocity [m/s] of the gripper link's centre of mass and its angular velocity
        [rad/s].
    centre : sequence of 3 float
        The gripper link's centre of mass [m].
    """
    if position[2] - node[2] > geometry.screw_length + 1e-3:
        return []  # the screw's tip is above the face: nothing can touch
    forces = []
    for point, face_only in ((tuple(position), True),
                             (screw_tip(geometry, position, z_axis), False)):
        arm = [p - c for p, c in zip(point, centre, strict=True)]
        point_velocity = (velocity[0] + spin[1] * arm[2] - spin[2] * arm[1],
                          velocity[1] + spin[2] * arm[0] - spin[0] * arm[2],
                          velocity[2] + spin[0] * arm[1] - spin[1] * arm[0])
        force = _point_contact(geometry, node, point, point_velocity, face_only)
        if force is not None:
            forces.append(force)
    return forces


def where_the_screw_is(geometry: NodeGeometry, node, position, z_axis
                       ) -> tuple[Seat, float, float]:
    """Where a gripper's screw tip is against a node.

    Returns
    -------
    seat : Seat
    height : float
        [m] The shoulder (contact point) above the node's mouth.
    offset : float
        [m] The screw's tip from the hole's axis.
    """
    tip = screw_tip(geometry, position, z_axis)
    offset = math.hypot(tip[0] - node[0], tip[1] - node[1])
    height = position[2] - node[2]
    tip_height = tip[2] - node[2]
    if offset >= FACE_RADIUS or tip_height > 5e-4:  # beyond the node, or above its face
        seat = Seat.CLEAR
    elif offset >= geometry.chamfer_radius:
        seat = Seat.ON_FACE
    elif tip_height > -geometry.chamfer_depth:
        seat = Seat.IN_CHAMFER
    else:
        seat = Seat.IN_BORE
    return seat, height, offset
