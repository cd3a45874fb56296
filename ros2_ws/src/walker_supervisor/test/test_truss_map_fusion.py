"""A survey fused with what the map knew: smaller uncertainty, bounded drift along a chain."""

import math

import numpy as np

from walker_core.joint_roles import physical_to_roles, roles_to_physical
from walker_core.kinematics import WalkerKinematics
from walker_core.robot_parameters import load_walker_parameters
from walker_core.truss import Truss
from walker_supervisor.core.step_geometry import BaseFrame
from walker_supervisor.core.truss_map import NodeEstimate, TrussMap, fuse

PARAMS = load_walker_parameters()
KIN = WalkerKinematics.from_parameters(PARAMS)
TRUSS = Truss.from_parameters(PARAMS)
#: a 10-step walk: each step pivots on the front node and swings the rear gripper ahead of it
CHAIN = ['n0_1', 'n1_1', 'n2_1', 'n3_1', 'n4_1', 'n4_2', 'n3_2', 'n2_2', 'n1_2', 'n0_2', 'n0_3',
         'n1_3']
#: [rad] constant calibration offsets of the five joints (physical order): 0.2 mrad each
OFFSETS = np.full(5, 2e-4)


def _is_psd(matrix):
    return np.linalg.eigvalsh((matrix + matrix.T) / 2).min() > -1e-18


def test_the_fused_estimate_is_known_better_than_either_and_lies_between_them():
    prior = NodeEstimate(np.zeros(3), np.diag([4e-6, 4e-6, 1e-6]), False)
    measured = NodeEstimate(np.array([0.002, -0.001, 0.0005]),
                            np.array([[1e-6, 2e-7, 0.0], [2e-7, 3e-6, 0.0], [0.0, 0.0, 1e-6]]),
                            True)
    fused = fuse(prior, measured)
    assert fused.surveyed
    # smaller than either in every direction
    assert _is_psd(prior.covariance - fused.covariance)
    assert _is_psd(measured.covariance - fused.covariance)
    assert np.trace(fused.covariance) < min(np.trace(prior.covariance),
                                            np.trace(measured.covariance))
    # between the two, nearer the better known along x (the measurement, 1 mm against 2 mm)
    assert 0.001 < fused.position[0] < 0.002
    # height: equally known, halfway
    assert math.isclose(fused.position[2], 0.00025, rel_tol=1e-9)


def test_a_survey_through_a_long_chain_barely_moves_a_node_known_well():
    known = NodeEstimate(np.array([0.9, 0.0, 0.0]), np.eye(3) * (1e-4) ** 2, True)
    far_off = NodeEstimate(np.array([0.903, 0.002, -0.002]), np.eye(3) * (5e-3) ** 2, True)
    fused = fuse(known, far_off)
    assert np.linalg.norm(fused.position - known.position) < 0.01 * np.linalg.norm(
        far_off.position - known.position)
    # the anchor (no uncertainty) is not moved at all; a perfect measurement is taken whole
    exact = NodeEstimate(np.zeros(3), np.zeros((3, 3)), True)
    np.testing.assert_array_equal(fuse(exact, far_off).position, exact.position)
    np.testing.assert_allclose(fuse(far_off, NodeEstimate(np.ones(3), np.zeros((3, 3)), True))
                               .position, np.ones(3))


def _walk_the_chain(prior_std: float) -> list[float]:
    """Walk CHAIN with constant joint offsets; return each new node's error [m] in the map.

    The first stance's two nodes sit at their nominal places (the map's frame is then the
    truss frame); the others are placed to 0.5 mm.
    """
    survey = TrussMap(TRUSS, prior_std=prior_std, joint_std=2e-4)
    rng = np.random.default_rng(5)
    true = {node: TRUSS.position(node) + (rng.normal(0.0, 5e-4, 3) if i > 1 else 0.0)
            for i, node in enumerate(CHAIN)}
    grippers = ('a', 'b')
    start = true[CHAIN[0]] - true[CHAIN[1]]
    frame = BaseFrame(true[CHAIN[1]], math.atan2(start[1], start[0]))
    stance = KIN.inverse([*frame.to_base(true[CHAIN[0]]), 0.0, 0.0])  # true joints, roles
    errors = []
    for k in range(len(CHAIN) - 2):
        rear, base, ahead = CHAIN[k:k + 3]
        gripper = grippers[(k + 1) % 2]
        offsets = physical_to_roles(OFFSETS, gripper)
        tip = KIN.forward(stance)[:2]
        line = true[rear] - true[base]
        true_frame = BaseFrame(true[base], math.atan2(line[1], line[0])
                               - math.atan2(tip[1], tip[0]))
        read = stance + offsets
        survey.anchor_at(base)
        if not survey.surveyed(rear):
            first = BaseFrame.from_stance(KIN, read, survey.position(base), survey.position(rear))
            survey.survey(rear, first, base, KIN, read)
        measured_frame = BaseFrame.from_stance(KIN, read, survey.position(base),
                                               survey.position(rear))
        screwed = KIN.inverse([*true_frame.to_base(true[ahead]), 0.0, 0.0])
        survey.survey(ahead, measured_frame, base, KIN, screwed + offsets)
        errors.append(float(np.linalg.norm(survey.position(ahead) - true[ahead])))
        stance = physical_to_roles(roles_to_physical(screwed, gripper), grippers[k % 2])
        stance[[0, 4]] = np.remainder(stance[[0, 4]] + math.pi, 2 * math.pi) - math.pi
    return errors


def test_the_chains_error_stays_bounded_with_constant_joint_offsets():
    fused = _walk_the_chain(prior_std=0.001)
    barely = _walk_the_chain(prior_std=0.02)  # a prior that says nothing: the survey alone
    assert len(fused) == 10
    # the survey alone drifts: the offsets add up step after step
    assert barely[-1] > 2.0 * barely[2] and barely[-1] > 0.002
    # fused with the nodes' places, the drift stops growing: the last five steps' error no
    # larger than the worst of the first five's, and within twice the prior's
    assert max(fused[5:]) <= 1.1 * max(fused[:5])
    assert max(fused) < 2.0 * 0.001
