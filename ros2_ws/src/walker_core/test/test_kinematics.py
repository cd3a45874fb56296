"""Kinematics of paper eqs (1)-(7): round trips, singularities, limits, mirroring, Jacobian."""

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from walker_core.kinematics import (
    JointLimitError, KinematicsError, SingularConfigurationError, UnreachableError,
    WalkerKinematics, invert_transform)
from walker_core.robot_parameters import load_walker_parameters

PARAMS = load_walker_parameters()
KIN = WalkerKinematics.from_parameters(PARAMS)
FREE = WalkerKinematics(PARAMS.robot.geometry.l1, PARAMS.robot.geometry.l2)  # no limits
L1, L2 = KIN.l1, KIN.l2


def angle(lo, hi):
    return st.floats(lo, hi, allow_nan=False, allow_infinity=False)


# Joint vectors inside the limits, away from the singular stretched (th3 = 0) and folded
# (th3 = +-pi) configurations, so that the branch is well defined.
joint_vectors = st.tuples(
    angle(KIN.lower[0], KIN.upper[0]), angle(KIN.lower[1], KIN.upper[1]),
    st.one_of(angle(0.05, KIN.upper[2]), angle(KIN.lower[2], -0.05)),
    angle(KIN.lower[3], KIN.upper[3]), angle(KIN.lower[4], KIN.upper[4]),
).map(np.array)

poses = st.tuples(angle(-1.5, 1.5), angle(-1.5, 1.5), angle(-1.2, 1.2), angle(-1.5, 1.5),
                  angle(-math.pi, math.pi)).map(np.array)


def printed_eq1(theta):
    """Eq (1) typed in as printed in the paper, independently of the implementation."""
    t1, t2, t3, t4, t5 = theta
    s = L2 * math.sin(t2) + L2 * math.sin(t2 + t3) + L1 * math.sin(t2 + t3 + t4)
    return np.array([-math.sin(t1) * s, math.cos(t1) * s,
                     L1 + L2 * math.cos(t2) + L2 * math.cos(t2 + t3) + L1 * math.cos(t2 + t3 + t4),
                     math.pi - (t2 + t3 + t4), t5])


def printed_eq5_theta2(pose, theta3):
    """Eq (5) as printed: asin(r / [sqrt(X^2 + Y^2) - l1 sin(alpha)]^(1/2)) - th3/2."""
    x, y, z, alpha, _ = pose
    r = math.hypot(math.hypot(x, y) - L1 * math.sin(alpha), z - L1 * (1 - math.cos(alpha)))
    return math.asin(r / math.sqrt(math.hypot(x, y) - L1 * math.sin(alpha))) - theta3 / 2


def same_angles(a, b, tol=1e-9):
    difference = np.asarray(a) - np.asarray(b)
    return np.allclose(np.remainder(difference + math.pi, 2 * math.pi) - math.pi, 0.0, atol=tol)


def branch_of(theta):
    """(elbow, reach) branch that reproduces a joint vector."""
    reach = (L2 * math.sin(theta[1]) + L2 * math.sin(theta[1] + theta[2])
             + L1 * math.sin(theta[1] + theta[2] + theta[3]))
    return ('up' if theta[2] > 0 else 'down'), ('forward' if reach > 0 else 'backward')


@given(joint_vectors)
def test_forward_is_eq1_and_agrees_with_the_transform_chain(theta):
    pose = KIN.forward(theta)
    np.testing.assert_allclose(pose[:3], printed_eq1(theta)[:3], atol=1e-12)
    assert same_angles(pose[3:], printed_eq1(theta)[3:], tol=1e-12)
    assert -math.pi < pose[3] <= math.pi
    transform = KIN.forward_transform(theta)
    np.testing.assert_allclose(transform[:3, 3], pose[:3], atol=1e-12)
    # alpha is the tilt of the gripper axis (the tip frame's z) from vertical in the arm plane
    assert math.isclose(transform[2, 2], math.cos(pose[3]), abs_tol=1e-12)
    np.testing.assert_allclose(KIN.joint_positions(theta)[-1], pose[:3], atol=1e-12)


@settings(max_examples=400)
@given(joint_vectors)
def test_ik_of_fk_returns_the_joint_angles(theta):
    elbow, reach = branch_of(theta)
    pose = KIN.forward(theta)
    assume(math.hypot(pose[0], pose[1]) > 1e-6)  # yaw defined
    assume(abs(theta[2]) < math.pi - 0.35)  # vertex limit margin
    recovered = FREE.inverse(pose, elbow, reach, check_limits=False)
    assert same_angles(recovered, theta, tol=1e-7)
    np.testing.assert_allclose(FREE.inverse(pose, elbow, reach, reference=theta,
                                            check_limits=False), theta, atol=1e-7)


@settings(max_examples=400)
@given(poses, st.sampled_from(['up', 'down']), st.sampled_from(['forward', 'backward']))
def test_fk_of_ik_returns_the_pose_or_ik_refuses_clearly(pose, elbow, reach):
    sign = 1.0 if reach == 'forward' else -1.0
    chord = math.hypot(sign * math.hypot(pose[0], pose[1]) - L1 * math.sin(pose[3]),
                       pose[2] - L1 * (1 - math.cos(pose[3])))
    assume(abs(chord - 2 * L2) > 1e-9 and math.hypot(pose[0], pose[1]) > 1e-6)
    try:
        theta = FREE.inverse(pose, elbow, reach)
    except UnreachableError as error:
        assert chord > 2 * L2, 'a reachable pose was refused'
        assert 'out of reach' in str(error)
        return
    assert chord <= 2 * L2
    result = FREE.forward(theta)
    np.testing.assert_allclose(result[:3], pose[:3], atol=1e-9)
    assert same_angles(result[3:], pose[3:])


@pytest.mark.parametrize('elbow', ['up', 'down'])
def test_stretched_singularity_is_solved_with_both_elbows_coinciding(elbow):
    theta = np.array([0.3, 1.4, 0.0, math.pi - 1.4, 0.1])
    pose = KIN.forward(theta)
    solution = KIN.inverse(pose, elbow)
    np.testing.assert_allclose(solution, theta, atol=1e-7)
    assert len(KIN.inverse_all(pose)) >= 1
    jac = KIN.jacobian(theta)
    assert abs(np.linalg.det(jac)) < 1e-9, 'stretched links must be a singular configuration'


def test_folded_links_are_refused_as_singular():
    # The wrist on top of J2: pose with the tip straight below J2's l1 offset.
    pose = [0.0, 0.0, 0.0, 0.0, 0.0]
    with pytest.raises(SingularConfigurationError):
        KIN.inverse(pose, reference=[0, 0, 0, 0, 0])


def test_tip_on_the_yaw_axis_needs_a_reference():
    pose = [0.0, 0.0, 0.6, 0.0, 0.0]
    with pytest.raises(SingularConfigurationError, match='yaw axis'):
        KIN.inverse(pose)
    theta = FREE.inverse(pose, reference=[0.4, 0, 0, 0, 0])
    assert theta[0] == pytest.approx(0.4)
    np.testing.assert_allclose(FREE.forward(theta)[:3], pose[:3], atol=1e-12)


@pytest.mark.parametrize('pose, error, words', [
    ([0.0, 2 * L2 + 0.01, 0.0, 0.0, 0.0], UnreachableError, 'out of reach'),
    ([0.0, 5.0, 3.0, 0.0, 0.0], UnreachableError, 'out of reach'),
    ([math.nan, 0.9, 0.0, 0.0, 0.0], KinematicsError, 'finite'),
    ([0.0, math.inf, 0.0, 0.0, 0.0], KinematicsError, 'finite'),
    ([0.0, 0.9, 0.0], KinematicsError, '5 values'),
])
def test_bad_targets_are_refused_with_a_reason(pose, error, words):
    with pytest.raises(error, match=words):
        KIN.inverse(pose)


def test_unknown_branch_names_are_refused():
    with pytest.raises(KinematicsError, match='elbow'):
        KIN.inverse([0, 0.9, 0, 0, 0], elbow='sideways')
    with pytest.raises(KinematicsError, match='reach'):
        KIN.inverse([0, 0.9, 0, 0, 0], reach='left')


def test_joint_limits_are_enforced_and_named():
    # Reachable only with the vertex folded beyond its 2.8 rad limit.
    pose = KIN.forward([0.0, 1.5, 2.9, math.pi - 4.4, 0.0])
    with pytest.raises(JointLimitError, match='J3'):
        KIN.inverse(pose)
    assert KIN.inverse_all(pose) == [] or all(KIN.within_limits(t) for t in KIN.inverse_all(pose))


def test_every_branch_reaches_the_same_pose():
    pose = np.array([0.2, 0.7, -0.1, 0.0, 0.3])
    solutions = KIN.inverse_all(pose)
    assert len(solutions) >= 2
    assert {math.copysign(1, s[2]) for s in solutions} == {1.0, -1.0}, 'both elbows expected'
    for theta in solutions:
        np.testing.assert_allclose(KIN.forward(theta)[:3], pose[:3], atol=1e-9)
        assert same_angles(KIN.forward(theta)[3:], pose[3:])
        assert KIN.within_limits(theta)


def test_default_stance_is_the_symmetric_inverted_v():
    spacing = PARAMS.truss.spacing
    theta = KIN.inverse([0.0, spacing, 0.0, 0.0, 0.0])
    assert theta[2] > 0, 'elbow up: the vertex is above the truss'
    assert theta[1] == pytest.approx(theta[3]), 'both wrists pitch alike when level'
    assert KIN.joint_positions(theta)[1][2] > L1, 'the vertex is above the wrists'


@given(joint_vectors)
def test_the_chain_seen_from_the_tip_is_the_reversed_chain(theta):
    forward = KIN.forward_transform(theta)
    mirrored = KIN.forward_transform(theta[::-1])
    np.testing.assert_allclose(mirrored, invert_transform(forward), atol=1e-12)


def test_the_mirrored_base_gives_the_mirrored_answer():
    # Both grippers on neighbouring nodes; solve from gripper a, then from gripper b.
    spacing = PARAMS.truss.spacing
    theta_from_a = KIN.inverse([0.0, spacing, 0.0, 0.0, 0.25])
    # Where is gripper a's contact point seen from gripper b's frame?
    tip_frame = KIN.forward_transform(theta_from_a)
    a_in_b = invert_transform(tip_frame) @ np.array([0.0, 0.0, 0.0, 1.0])
    beta_b = theta_from_a[0]  # gripper a's yaw is J5 when b is the base
    theta_from_b = KIN.inverse([a_in_b[0], a_in_b[1], a_in_b[2], 0.0, beta_b])
    np.testing.assert_allclose(theta_from_b, theta_from_a[::-1], atol=1e-9)


@given(joint_vectors)
def test_jacobian_matches_finite_differences(theta):
    step = 1e-6
    numeric = np.column_stack([
        (KIN.forward(theta + step * e) - KIN.forward(theta - step * e)) / (2 * step)
        for e in np.eye(5)])
    np.testing.assert_allclose(KIN.jacobian(theta), numeric, atol=1e-7)


@pytest.mark.parametrize('target', [[0.1, 0.85, 0.0], [0.0, 0.9, 0.0], [0.3, 0.5, -0.2]])
def test_printed_eq5_fails_the_round_trip_and_the_correction_passes(target):
    pose = np.array([*target, 0.0, 0.0])
    theta = KIN.inverse(pose)
    np.testing.assert_allclose(KIN.forward(theta), pose, atol=1e-12)
    try:
        printed = theta.copy()
        printed[1] = printed_eq5_theta2(pose, theta[2])
    except ValueError:
        return  # the printed ratio exceeds 1: asin is undefined, a failure in itself
    printed[3] = math.pi - printed[1] - printed[2]  # eq (6) with the printed th2
    error = np.linalg.norm(KIN.forward(printed)[:3] - pose[:3])
    assert error > 0.01, f'the printed eq (5) should miss the target, missed by {error} m'


def test_malformed_construction_is_refused():
    with pytest.raises(ValueError):
        WalkerKinematics(0.7, 0.6)
    with pytest.raises(ValueError):
        WalkerKinematics(0.1, 0.6, lower=(0, 0, 0, 0, 0), upper=(0, 1, 1, 1, 1))


def _one_by_one(poses, elbow, reach, references):
    """:meth:`inverse` row by row (no limit check); NaN rows where it raises."""
    rows = []
    for i, pose in enumerate(poses):
        reference = None if references is None else references[i]
        try:
            rows.append(FREE.inverse(pose, elbow, reach, reference, check_limits=False))
        except KinematicsError:
            rows.append(np.full(5, np.nan))
    return np.array(rows)


@settings(max_examples=60)
@given(st.lists(st.one_of(poses, joint_vectors.map(FREE.forward)), min_size=1, max_size=40),
       st.sampled_from(['up', 'down']),
       st.sampled_from(['forward', 'backward']), st.booleans(),
       st.integers(0, 2 ** 32 - 1))
def test_the_vectorised_inverse_is_the_inverse_row_by_row(pose_list, elbow, reach,
                                                          with_references, seed):
    """Same angles, and NaN exactly where :meth:`inverse` refuses (out of reach, folded)."""
    poses_ = np.array(pose_list)
    references = None
    if with_references:
        references = np.random.default_rng(seed).uniform(-10.0, 10.0, poses_.shape)
    many = FREE.inverse_many(poses_, elbow, reach, references)
    single = _one_by_one(poses_, elbow, reach, references)
    np.testing.assert_array_equal(np.isnan(many), np.isnan(single))
    np.testing.assert_allclose(many, single, atol=1e-12, equal_nan=True)


def test_the_vectorised_inverse_marks_what_the_inverse_refuses_and_refuses_bad_input():
    out_of_reach, on_axis = [3.0, 0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.6, 0, 0]
    tilt = 0.5  # the wrist on J2, off the yaw axis: the links folded onto each other
    folded = [0.0, L1 * math.sin(tilt), L1 * (1.0 - math.cos(tilt)), tilt, 0.0]
    with pytest.raises(SingularConfigurationError, match='folded'):
        FREE.inverse(folded, check_limits=False)
    fine = KIN.forward([0.2, 0.4, 1.2, math.pi - 1.6, 0.1])
    many = FREE.inverse_many(np.array([fine, out_of_reach, folded, on_axis]))
    assert np.all(np.isfinite(many[0])) and np.all(np.isnan(many[1:]))
    with_axis_reference = FREE.inverse_many(np.array([on_axis]), references=np.ones((1, 5)))
    assert np.all(np.isfinite(with_axis_reference))
    assert with_axis_reference[0, 0] == 1.0  # joint 1 from the reference, as inverse() does
    for bad, words in [(np.zeros((3, 4)), 'shape'), (np.array([[np.nan] * 5]), 'finite')]:
        with pytest.raises(KinematicsError, match=words):
            FREE.inverse_many(bad)
    with pytest.raises(KinematicsError, match='elbow'):
        FREE.inverse_many(np.zeros((1, 5)), elbow='sideways')
    with pytest.raises(KinematicsError, match='reference'):
        FREE.inverse_many(np.zeros((2, 5)), references=np.zeros((1, 5)))


def test_limits_per_row_agree_with_the_check():
    rng = np.random.default_rng(7)
    thetas = rng.uniform(-4.0, 4.0, (200, 5))
    thetas[3] = np.nan
    expected = [KIN.within_limits(t) if np.all(np.isfinite(t)) else False for t in thetas]
    assert KIN.within_limits_many(thetas).tolist() == expected
    assert 0 < sum(expected) < len(expected)
    with pytest.raises(KinematicsError, match='shape'):
        KIN.within_limits_many(thetas[0])
