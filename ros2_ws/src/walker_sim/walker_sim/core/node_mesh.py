"""The visible shape of a node's face and hole: a triangle mesh of the contact model's profile.

The contact model (:mod:`walker_sim.core.contact`) is a profile turned about the hole's axis:
the face out to :data:`~walker_sim.core.contact.FACE_RADIUS`, the 45 degree entry chamfer, the
bore down to the hole's depth. A camera must see that very shape, so the mesh here is the
same profile (:meth:`NodeGeometry.profile`) turned about the axis in ``segments`` steps, closed
by the bore's bottom and the face's outer wall down to the hole's depth. Its vertices are in
the node's frame (origin at the mouth, z up), each surface with its own normals so the
renderer shades the face, the chamfer and the bore as the flat and conical surfaces they are.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from walker_sim.core.contact import FACE_RADIUS, NodeGeometry

__all__ = ['NodeMesh', 'node_mesh']


@dataclasses.dataclass(frozen=True)
class NodeMesh:
    """Vertices [m], unit normals and triangles (counter-clockwise seen from outside)."""

    vertices: np.ndarray
    normals: np.ndarray
    indices: np.ndarray


def _ring(radius: float, height: float, angles: np.ndarray) -> np.ndarray:
    return np.column_stack([radius * np.cos(angles), radius * np.sin(angles),
                            np.full(len(angles), height)])


def _band(outer, inner, outer_normals, inner_normals, start: int):
    """Triangles joining two rings of ``n`` vertices (``outer`` then ``inner`` in the buffer)."""
    n = len(outer)
    triangles = []
    for i in range(n):
        j = (i + 1) % n
        a, b, c, d = start + i, start + j, start + n + j, start + n + i
        triangles += [(a, b, c), (a, c, d)]
    return (np.vstack([outer, inner]), np.vstack([outer_normals, inner_normals]), triangles)


def node_mesh(geometry: NodeGeometry, segments: int = 48) -> tuple[NodeMesh, NodeMesh]:
    """Return the meshes of a node's face, and of its hole: the chamfer and the threaded bore.

    Two meshes, as they are two materials: the light face, and the hole's dark insert (a
    black-anodised threaded insert, chosen so that a camera sees the hole's mouth as a sharp
    outline on the face, as the targets on a station are made for its cameras).

    Parameters
    ----------
    geometry : NodeGeometry
        The node's chamfer, bore and hole depth [m].
    segments : int
        Facets around the axis (48: the chamfer's rim is off a true circle by 0.2 % of its
        radius, 4 micrometres at 2 mm).
    """
    if segments < 8:
        raise ValueError(f'a node mesh needs at least 8 segments, got {segments}')
    angles = np.linspace(0.0, 2.0 * math.pi, segments, endpoint=False)
    radial = np.column_stack([np.cos(angles), np.sin(angles), np.zeros(segments)])
    up = np.tile([0.0, 0.0, 1.0], (segments, 1))
    chamfer_normal = (-radial + up) / math.sqrt(2.0)  # faces the axis and up
    depth, chamfer, bore = geometry.hole_depth, geometry.chamfer_radius, geometry.bore_radius
    face = [
        # face: the rim at FACE_RADIUS in to the chamfer
        (_ring(FACE_RADIUS, 0.0, angles), _ring(chamfer, 0.0, angles), up, up),
        # outer wall of the face: down from the rim, facing out
        (_ring(FACE_RADIUS, -depth, angles), _ring(FACE_RADIUS, 0.0, angles), radial, radial),
    ]
    hole = [
        # chamfer: 45 degrees down to the bore
        (_ring(chamfer, 0.0, angles), _ring(bore, -geometry.chamfer_depth, angles),
         chamfer_normal, chamfer_normal),
        # bore wall: down to the bottom, facing the axis
        (_ring(bore, -geometry.chamfer_depth, angles), _ring(bore, -depth, angles),
         -radial, -radial)]
    return _mesh(face), _mesh(hole, bottom=(bore, -depth, angles))


def _mesh(surfaces, bottom=None) -> NodeMesh:
    vertices, normals, indices = [], [], []
    count = 0
    for outer, inner, outer_normals, inner_normals in surfaces:
        v, n, t = _band(outer, inner, outer_normals, inner_normals, count)
        vertices.append(v)
        normals.append(n)
        indices += t
        count += len(v)
    if bottom is not None:  # a disc facing up: a fan about its centre
        radius, height, angles = bottom
        segments = len(angles)
        vertices.append(np.vstack([[0.0, 0.0, height], _ring(radius, height, angles)]))
        normals.append(np.tile([0.0, 0.0, 1.0], (segments + 1, 1)))
        indices += [(count, count + 1 + i, count + 1 + (i + 1) % segments)
                    for i in range(segments)]
    return NodeMesh(np.vstack(vertices), np.vstack(normals), np.array(indices, dtype=int))
