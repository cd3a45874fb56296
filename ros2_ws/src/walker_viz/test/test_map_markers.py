"""The truss map's markers: each node surveyed or nominal by colour, its uncertainty to scale."""

import math
from types import SimpleNamespace

import numpy as np
import pytest

from walker_core.rotations import rotation_from_quaternion
from walker_viz.core.map_markers import (
    MIN_ELLIPSOID_DIAMETER, NOMINAL_COLOR, SURVEYED_COLOR, truss_map_markers,
    uncertainty_ellipsoid)


def _rotation(yaw: float, pitch: float) -> np.ndarray:
    cz, sz, cy, sy = math.cos(yaw), math.sin(yaw), math.cos(pitch), math.sin(pitch)
    return np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]]) @ \
        np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])


@pytest.mark.parametrize('sigmas', [1.0, 2.0])
@pytest.mark.parametrize('stds, yaw, pitch', [
    ((0.002, 0.0015, 0.001), 0.0, 0.0),
    ((0.0003, 0.0012, 0.0008), 0.7, -0.4),
    ((0.001, 0.001, 0.0002), 2.5, 1.1),
])
def test_the_ellipsoid_is_the_surface_at_sigmas_standard_deviations(stds, yaw, pitch, sigmas):
    rotation = _rotation(yaw, pitch)
    covariance = rotation @ np.diag(np.square(stds)) @ rotation.T
    diameters, orientation = uncertainty_ellipsoid(covariance, sigmas)
    axes = rotation_from_quaternion(orientation)
    assert np.linalg.det(axes) == pytest.approx(1.0)  # a rotation, as a marker's pose needs
    # a unit sphere scaled by the half diameters along the marker's axes, turned by its pose:
    # the points at Mahalanobis distance `sigmas` from the estimate
    shape = axes @ np.diag((np.asarray(diameters) / 2.0) ** 2) @ axes.T
    np.testing.assert_allclose(shape, sigmas ** 2 * covariance, atol=1e-12)
    assert sorted(diameters) == pytest.approx(sorted(2.0 * sigmas * np.asarray(stds)))


def test_a_node_without_uncertainty_is_still_drawn():
    diameters, orientation = uncertainty_ellipsoid(np.zeros((3, 3)))
    assert diameters == (MIN_ELLIPSOID_DIAMETER,) * 3
    assert np.linalg.norm(orientation) == pytest.approx(1.0)


@pytest.mark.parametrize('covariance, sigmas', [
    (np.zeros((2, 2)), 2.0), (np.full((3, 3), np.nan), 2.0), (np.eye(3), 0.0)])
def test_a_bad_covariance_or_sigma_count_is_refused(covariance, sigmas):
    with pytest.raises(ValueError):
        uncertainty_ellipsoid(covariance, sigmas)


def test_each_node_has_a_disc_coloured_by_its_status_and_an_ellipsoid_at_its_estimate():
    estimates = [
        ('n0_0', SimpleNamespace(position=np.zeros(3), covariance=np.zeros((3, 3)),
                                 surveyed=True)),
        ('n1_0', SimpleNamespace(position=np.array([0.301, 0.002, -0.001]),
                                 covariance=np.eye(3) * 1e-6, surveyed=True)),
        ('n2_0', SimpleNamespace(position=np.array([0.6, 0.0, 0.0]),
                                 covariance=np.eye(3) * 4e-6, surveyed=False)),
    ]
    markers = truss_map_markers(estimates)
    discs = [m for m in markers if m.namespace == 'truss_map_status']
    ellipsoids = [m for m in markers if m.namespace == 'truss_map_uncertainty']
    assert [m.text for m in discs] == [m.text for m in ellipsoids] == ['n0_0', 'n1_0', 'n2_0']
    assert [m.marker_id for m in discs] == [0, 1, 2]  # a map latched again replaces each
    assert [m.color for m in discs] == [SURVEYED_COLOR, SURVEYED_COLOR, NOMINAL_COLOR]
    assert SURVEYED_COLOR[:3] != NOMINAL_COLOR[:3]
    for (_, estimate), disc, ellipsoid in zip(estimates, discs, ellipsoids, strict=True):
        np.testing.assert_allclose(disc.points[0], estimate.position)
        np.testing.assert_allclose(ellipsoid.points[0], estimate.position)
        assert ellipsoid.kind == 'sphere' and ellipsoid.color[:3] == disc.color[:3]
    # 2 standard deviations: a nominal node of 2 mm std is drawn 8 mm across
    assert ellipsoids[2].scale == pytest.approx((0.008,) * 3)
