"""Diagonal inertia of eqs (9)-(13) against an independent numerical mass matrix."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from walker_core.dynamics import (
    RigidModel, diagonal_inertia, mass_matrix_numerical, role_inertia)
from walker_core.robot_parameters import load_walker_parameters

PARAMS = load_walker_parameters()
MODEL = RigidModel.from_parameters(PARAMS)
L1, L2 = MODEL.l1, MODEL.l2
M3, M4, M5 = MODEL.m3, MODEL.m4, MODEL.m5
MOTOR = MODEL.reflected_motor_inertia

joint_vectors = st.lists(st.floats(-3.0, 3.0), min_size=5, max_size=5).map(np.array)


def printed_eq10(theta):
    """Eq (10) as printed in the paper."""
    _, t2, t3, t4, _ = theta
    return (MOTOR[1] + 2 * M4 * L2 ** 2 * (1 + math.cos(t3))
            + M5 * (2 * L2 ** 2 * (1 + math.cos(t3)) + L1 ** 2
                    + 2 * L1 * L2 * math.sqrt(2 * (1 + math.cos(t3))) * math.cos(t2 + t3 + t4)))


def printed_eq11(theta):
    """Eq (11) as printed in the paper."""
    t4 = theta[3]
    return MOTOR[2] + M5 * (L1 ** 2 + L2 ** 2) + 2 * M5 * L1 * L2 * math.cos(t4)


def printed_eq9(theta, l3):
    """Eq (9) as printed, with its undefined length l3 given a value."""
    _, t2, t3, t4, _ = theta
    return (MOTOR[0] + M3 * (L2 * math.sin(t2)) ** 2
            + M4 * (L2 * math.sin(t2) + L2 * math.sin(t2 + t3)) ** 2
            + M5 * (L2 * math.sin(t2) + l3 * math.sin(t2 + t3) + L1 * math.sin(t2 + t3 + t4)) ** 2)


@given(joint_vectors)
def test_diagonal_terms_equal_the_numerical_mass_matrix(theta):
    numeric = mass_matrix_numerical(theta, MODEL)
    np.testing.assert_allclose(diagonal_inertia(theta, MODEL), np.diag(numeric),
                               rtol=1e-6, atol=1e-8)


@given(joint_vectors, st.sampled_from([1, 2, 3, 4, 5]))
def test_one_role_term_equals_the_numerical_mass_matrix(theta, role):
    numeric = mass_matrix_numerical(theta, MODEL)
    assert role_inertia(list(theta), MODEL, role) == pytest.approx(
        numeric[role - 1, role - 1], rel=1e-6, abs=1e-8)


@pytest.mark.parametrize('role', [0, 6])
def test_a_role_outside_1_to_5_is_refused(role):
    with pytest.raises(ValueError, match='role'):
        role_inertia([0.0] * 5, MODEL, role)


@given(joint_vectors)
def test_mass_matrix_is_symmetric_positive_definite(theta):
    matrix = mass_matrix_numerical(theta, MODEL)
    np.testing.assert_allclose(matrix, matrix.T, atol=1e-8)
    assert np.all(np.linalg.eigvalsh(matrix) > 0)


def test_printed_eq10_and_eq11_disagree_with_the_mass_matrix():
    theta = np.array([0.0, 0.7, 1.2, 0.5, 0.0])
    numeric = np.diag(mass_matrix_numerical(theta, MODEL))
    assert abs(printed_eq10(theta) - numeric[1]) > 0.05 * numeric[1]
    assert abs(printed_eq11(theta) - numeric[2]) == pytest.approx(M4 * L2 ** 2, rel=1e-6), \
        'eq (11) misses exactly the m4 l2^2 term'


@pytest.mark.parametrize('l3', [L1, 0.5 * L2, 2 * L2])
def test_printed_eq9_is_right_only_with_l3_equal_to_l2(l3):
    theta = np.array([0.0, 0.7, 1.2, 0.5, 0.0])
    numeric = np.diag(mass_matrix_numerical(theta, MODEL))
    assert printed_eq9(theta, L2) == pytest.approx(numeric[0], rel=1e-6)
    assert printed_eq9(theta, l3) != pytest.approx(numeric[0], rel=1e-3)


def test_wrist_and_yaw_terms_are_as_printed():
    theta = np.array([0.4, 0.7, 1.2, 0.5, 0.3])
    inertia = diagonal_inertia(theta, MODEL)
    assert inertia[3] == pytest.approx(MOTOR[3] + M5 * L1 ** 2)  # eq (12)
    assert inertia[4] == pytest.approx(MOTOR[4])  # eq (13)


def test_yaw_inertia_grows_with_reach():
    near = diagonal_inertia([0, 0.3, 2.2, 0.64, 0], MODEL)[0]
    far = diagonal_inertia([0, 0.85, 1.0, 1.29, 0], MODEL)[0]
    assert far > near > MOTOR[0]
