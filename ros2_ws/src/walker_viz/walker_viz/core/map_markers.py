"""The truss map drawn for people: where the walker believes each node is, and how well.

The supervisor's truss map (``walker_supervisor.core.truss_map.TrussMap``) keeps, per node, an
estimated position [m] in the truss frame, its covariance [m^2] and whether the joints have
surveyed it (or it anchors the frame) or it is still at its nominal place. This module draws
it, in plain data (:class:`~walker_viz.core.markers.MarkerSpec`), for the node that owns the
map to convert and latch on ``truss_map_markers``:

* ``truss_map_status``: a flat disc at each node's estimate, wider than the truss's node
  sphere so that it shows around it, coloured :data:`SURVEYED_COLOR` (surveyed, or the anchor)
  or :data:`NOMINAL_COLOR` (nominal, never surveyed), the node's name as its text;
* ``truss_map_uncertainty``: the node's uncertainty ellipsoid at its estimate, the surface at
  :data:`UNCERTAINTY_SIGMAS` standard deviations (Mahalanobis distance 2: its semi-axes are
  twice the square roots of the covariance's eigenvalues, along its eigenvectors), in the
  status's colour, translucent. It is drawn to scale: millimetres, inside the truss's node
  sphere; hide the ``truss_nodes`` namespace, or zoom in, to see it.

The input is any sequence of ``(node, estimate)`` with ``estimate.position``,
``estimate.covariance`` and ``estimate.surveyed`` (the map's ``NodeEstimate``), so this module
does not depend on the supervisor.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np

from walker_core.rotations import quaternion_from_matrix
from walker_viz.core.markers import MarkerSpec

__all__ = ['MAP_NAMESPACES', 'UNCERTAINTY_SIGMAS', 'SURVEYED_COLOR', 'NOMINAL_COLOR',
           'MIN_ELLIPSOID_DIAMETER', 'uncertainty_ellipsoid', 'truss_map_markers']

#: Marker namespaces of the truss map.
MAP_NAMESPACES = ('truss_map_status', 'truss_map_uncertainty')
#: Standard deviations at which the uncertainty ellipsoid's surface is drawn.
UNCERTAINTY_SIGMAS = 2.0
#: [m] smallest diameter drawn along an ellipsoid's axis (the anchor has no uncertainty).
MIN_ELLIPSOID_DIAMETER = 1e-4
#: r, g, b, a of a surveyed node (green).
SURVEYED_COLOR = (0.15, 0.75, 0.3, 0.9)
#: r, g, b, a of a node at its nominal place, never surveyed (amber).
NOMINAL_COLOR = (0.95, 0.6, 0.1, 0.9)
_ELLIPSOID_ALPHA = 0.45
# Cosmetic sizes [m]: the disc shows as a ring around the truss's 30 mm node sphere.
_STATUS_DIAMETER = 0.04
_STATUS_HEIGHT = 0.002


def uncertainty_ellipsoid(covariance: np.ndarray, sigmas: float = UNCERTAINTY_SIGMAS
                          ) -> tuple[tuple[float, float, float], tuple[float, ...]]:
    """Return an uncertainty ellipsoid's diameters [m] along its axes and its orientation.

    Parameters
    ----------
    covariance : array_like, shape (3, 3)
        Position covariance [m^2] in the truss frame (symmetric, positive semi-definite).
    sigmas : float
        Standard deviations at which the surface is drawn (> 0).

    Returns
    -------
    diameters : tuple of 3 float
        ``2 * sigmas * sqrt(eigenvalue)`` [m] along each eigenvector, at least
        :data:`MIN_ELLIPSOID_DIAMETER`.
    orientation : tuple of 4 float
        Quaternion ``(x, y, z, w)`` turning the truss frame's axes onto the eigenvectors (a
        right-handed frame).

    Raises
    ------
    ValueError
        A covariance that is not a finite 3x3 matrix, or ``sigmas`` not positive.
    """
    covariance = np.asarray(covariance, dtype=float)
    if covariance.shape != (3, 3) or not np.all(np.isfinite(covariance)):
        raise ValueError(f'a covariance must be a finite 3x3 matrix [m^2], got {covariance!r}')
    if not sigmas > 0.0:
        raise ValueError(f'sigmas must be > 0, got {sigmas}')
    values, vectors = np.linalg.eigh((covariance + covariance.T) / 2.0)
    if np.linalg.det(vectors) < 0.0:
        vectors[:, 2] = -vectors[:, 2]  # a rotation, not a reflection
    diameters = 2.0 * sigmas * np.sqrt(np.clip(values, 0.0, None))
    diameters = np.maximum(diameters, MIN_ELLIPSOID_DIAMETER)
    return (tuple(float(d) for d in diameters),
            tuple(float(q) for q in quaternion_from_matrix(vectors)))


def truss_map_markers(estimates: Iterable[tuple[str, Any]],
                      sigmas: float = UNCERTAINTY_SIGMAS) -> list[MarkerSpec]:
    """Draw the truss map: a status disc and an uncertainty ellipsoid per node.

    Parameters
    ----------
    estimates : iterable of (str, estimate)
        Every node of the map, in the truss's order, with its estimate (``position`` [m],
        ``covariance`` [m^2], ``surveyed``).
    sigmas : float
        Standard deviations at which the ellipsoids are drawn.

    Returns
    -------
    list of MarkerSpec
        The discs (``truss_map_status``) and the ellipsoids (``truss_map_uncertainty``), the
        node's index in ``estimates`` as each marker's id, so a map latched again replaces
        every marker of the last.
    """
    markers = []
    for index, (node, estimate) in enumerate(estimates):
        position = np.asarray(estimate.position, dtype=float).reshape(1, 3)
        color = SURVEYED_COLOR if estimate.surveyed else NOMINAL_COLOR
        markers.append(MarkerSpec('truss_map_status', index, 'cylinder', position,
                                  (_STATUS_DIAMETER, _STATUS_DIAMETER, _STATUS_HEIGHT),
                                  color, node))
        diameters, orientation = uncertainty_ellipsoid(estimate.covariance, sigmas)
        markers.append(MarkerSpec('truss_map_uncertainty', index, 'sphere', position,
                                  diameters, (*color[:3], _ELLIPSOID_ALPHA), node,
                                  orientation))
    return markers
