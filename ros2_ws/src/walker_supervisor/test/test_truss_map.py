"""The truss map: nodes surveyed from the joints, their uncertainty, nominal until surveyed."""

import numpy as np
import pytest

from walker_core.kinematics import WalkerKinematics
from walker_core.robot_parameters import load_walker_parameters
from walker_core.truss import Truss
from walker_supervisor.core.step_geometry import BaseFrame
from walker_supervisor.core.truss_map import (
    SURVEY_FORMAT, NodeEstimate, SurveyFileError, TrussMap, fuse, fuse_height, survey_covariance)

PARAMS = load_walker_parameters()
KIN = WalkerKinematics.from_parameters(PARAMS)
TRUSS = Truss.from_parameters(PARAMS)
FRAME = BaseFrame(TRUSS.position('n1_1'), 0.3)
#: [m] where n2_1 really is: off its nominal place by more than the insertion tolerance
DISPLACED = TRUSS.position('n2_1') + np.array([0.0025, -0.0018, 0.0007])


def _joints_at(point_truss):
    """Joint angles [rad] (role order, base in n1_1) with the tip at a truss-frame point."""
    return KIN.inverse([*FRAME.to_base(point_truss), 0.0, 0.0])


def test_a_displaced_node_is_surveyed_where_it_is_within_the_reading_noise():
    std = 2e-5  # [rad] the default campaign's encoder noise
    survey = TrussMap(TRUSS, prior_std=0.0015, joint_std=std)
    survey.anchor_at('n1_1')
    rng = np.random.default_rng(3)
    theta = _joints_at(DISPLACED) + rng.normal(0.0, std, 5)
    estimate = survey.survey('n2_1', FRAME, 'n1_1', KIN, theta)
    assert estimate.surveyed and survey.surveyed('n2_1')
    error = estimate.position - DISPLACED
    # the nominal place is 3 mm off; the survey is within 4 standard deviations of the truth
    assert np.linalg.norm(TRUSS.position('n2_1') - DISPLACED) > 0.003
    assert error @ np.linalg.solve(estimate.covariance, error) < 4.0 ** 2 * 3
    assert np.linalg.norm(error) < 1e-4
    np.testing.assert_allclose(survey.position('n2_1'), estimate.position)


def test_the_survey_covariance_is_the_joint_noise_through_the_jacobian():
    std = np.array([2e-4, 1e-4, 3e-4, 1e-4, 5e-4])
    theta = _joints_at(DISPLACED)
    formula = survey_covariance(KIN, theta, FRAME.heading, std)
    rng = np.random.default_rng(11)
    samples = np.array([FRAME.to_truss(KIN.forward(theta + rng.normal(0.0, std))[:3])
                        for _ in range(4000)])
    monte_carlo = np.cov(samples.T)
    assert np.linalg.norm(monte_carlo - formula) < 0.08 * np.linalg.norm(formula)
    # the joint noise moves the tip by a fraction of a millimetre at this reach
    assert 1e-4 < np.sqrt(np.trace(formula)) < 1e-3


def test_a_survey_adds_the_base_nodes_uncertainty():
    survey = TrussMap(TRUSS, prior_std=0.001, joint_std=2e-4)
    theta = _joints_at(DISPLACED)
    from_anchor = TrussMap(TRUSS, prior_std=0.001, joint_std=2e-4)
    from_anchor.anchor_at('n1_1')
    anchored = from_anchor.measure('n2_1', FRAME, 'n1_1', KIN, theta).covariance
    unanchored = survey.measure('n2_1', FRAME, 'n1_1', KIN, theta).covariance
    np.testing.assert_allclose(unanchored - anchored, np.eye(3) * 0.001 ** 2, atol=1e-15)


def test_a_node_never_surveyed_is_nominal_with_the_prior_and_the_anchor_is_exact():
    survey = TrussMap(TRUSS, prior_std=0.0015, joint_std=2e-4)
    estimate = survey.estimate('n3_2')
    assert not estimate.surveyed
    np.testing.assert_array_equal(estimate.position, TRUSS.position('n3_2'))
    np.testing.assert_allclose(estimate.covariance, np.eye(3) * 0.0015 ** 2)
    assert estimate.horizontal_std == pytest.approx(0.0015)
    survey.anchor_at('n1_1')
    survey.anchor_at('n2_1')  # the frame is anchored once
    assert survey.anchor == 'n1_1' and survey.surveyed_nodes == ['n1_1']
    np.testing.assert_array_equal(survey.estimate('n1_1').covariance, np.zeros((3, 3)))
    # a survey of the anchor leaves it where it defines the frame
    survey.survey('n1_1', BaseFrame(TRUSS.position('n2_1'), 0.0), 'n2_1', KIN,
                  _joints_at(DISPLACED))
    np.testing.assert_array_equal(survey.position('n1_1'), TRUSS.position('n1_1'))


def test_a_survey_file_round_trips_and_a_bad_one_changes_nothing():
    survey = TrussMap(TRUSS, prior_std=0.0015, joint_std=2e-4)
    survey.anchor_at('n1_1')
    survey.survey('n2_1', FRAME, 'n1_1', KIN, _joints_at(DISPLACED))
    content = survey.to_dict()
    assert content['format'] == SURVEY_FORMAT and content['anchor'] == 'n1_1'
    loaded = TrussMap.from_dict(TRUSS, 0.0015, 2e-4, content)
    assert loaded.surveyed_nodes == ['n1_1', 'n2_1']
    np.testing.assert_allclose(loaded.position('n2_1'), survey.position('n2_1'))
    np.testing.assert_allclose(loaded.estimate('n2_1').covariance,
                               survey.estimate('n2_1').covariance)
    bad = {**content, 'nodes': {**content['nodes'], 'n9_9': content['nodes']['n2_1']}}
    with pytest.raises(SurveyFileError, match='n9_9'):
        loaded.load(bad)
    with pytest.raises(SurveyFileError, match='format'):
        loaded.load({'nodes': {}})
    assert loaded.surveyed_nodes == ['n1_1', 'n2_1']


def test_a_survey_file_written_is_read_back_and_a_broken_one_is_named(tmp_path):
    from walker_supervisor.core.survey_file import read_survey, write_survey

    survey = TrussMap(TRUSS, prior_std=0.0015, joint_std=2e-4)
    survey.anchor_at('n1_1')
    survey.survey('n2_1', FRAME, 'n1_1', KIN, _joints_at(DISPLACED))
    path = write_survey(tmp_path / 'truss_survey.yaml', survey)
    loaded = TrussMap.from_dict(TRUSS, 0.0015, 2e-4, read_survey(path))
    np.testing.assert_allclose(loaded.position('n2_1'), survey.position('n2_1'))
    broken = tmp_path / 'broken.yaml'
    broken.write_text('format: [unclosed')
    with pytest.raises(SurveyFileError, match='broken.yaml'):
        read_survey(broken)
    with pytest.raises(SurveyFileError, match='missing.yaml'):
        read_survey(tmp_path / 'missing.yaml')


def test_every_node_has_a_frame_at_its_estimate_marked_surveyed_or_nominal():
    survey = TrussMap(TRUSS, prior_std=0.0015, joint_std=2e-4)
    survey.anchor_at('n1_1')
    survey.survey('n2_1', FRAME, 'n1_1', KIN, _joints_at(DISPLACED))
    frames = {name: (position, surveyed) for name, position, surveyed in survey.frames()}
    assert len(frames) == len(TRUSS.node_names)
    np.testing.assert_allclose(frames['node_2_1'][0], survey.position('n2_1'))
    assert frames['node_2_1'][1] and frames['node_1_1'][1] and not frames['node_3_2'][1]
    # a node not surveyed where the map predicts it: from n2_1, displaced with it
    np.testing.assert_allclose(frames['node_3_2'][0], survey.position('n3_2'))
    np.testing.assert_allclose(frames['node_3_2'][0] - TRUSS.position('n3_2'),
                               survey.position('n2_1') - TRUSS.position('n2_1'))


def _rotated_truss(angle: float) -> dict[str, np.ndarray]:
    """Where every node really is: the truss turned by ``angle`` [rad] about n1_1."""
    pivot = TRUSS.position('n1_1')
    c, s = np.cos(angle), np.sin(angle)
    turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return {n: pivot + turn @ (TRUSS.position(n) - pivot) for n in TRUSS.node_names}


def test_a_node_not_surveyed_is_predicted_from_its_surveyed_neighbour():
    """The chain's error: a truss turned by 5 mrad is 9 mm off its drawing two bays out.

    Predicted from its surveyed neighbour, the node is off only by what the turn does over one
    bay, within three of the prediction's standard deviations; the drawing is not.
    """
    prior = 0.002
    survey = TrussMap(TRUSS, prior_std=prior, joint_std=2e-4)
    survey.anchor_at('n1_1')
    true = _rotated_truss(0.005)
    surveyed = survey.survey('n2_1', FRAME, 'n1_1', KIN, _joints_at(true['n2_1']))
    predicted = survey.estimate('n3_1')
    assert not predicted.surveyed
    np.testing.assert_allclose(predicted.position, surveyed.position
                               + TRUSS.position('n3_1') - TRUSS.position('n2_1'))
    np.testing.assert_allclose(predicted.covariance,
                               surveyed.covariance + np.eye(3) * prior ** 2, atol=1e-15)
    off_drawing = np.linalg.norm(TRUSS.position('n3_1') - true['n3_1'])
    off_prediction = np.linalg.norm(predicted.position - true['n3_1'])
    assert off_drawing > 3.0 * predicted.horizontal_std > off_prediction
    # the uncertainty grows with the distance from what was surveyed
    assert survey.estimate('n4_1').horizontal_std > predicted.horizontal_std > prior
    # a map with nothing surveyed has every node on its drawing, with the prior
    np.testing.assert_array_equal(TrussMap(TRUSS, prior, 2e-4).position('n3_1'),
                                  TRUSS.position('n3_1'))


def test_a_survey_is_fused_with_the_drawing_not_with_the_prediction():
    """The prediction is taken through the same base node as the survey: not a second reading."""
    survey = TrussMap(TRUSS, prior_std=0.002, joint_std=2e-4)
    survey.anchor_at('n1_1')
    true = _rotated_truss(0.005)
    frame = BaseFrame(TRUSS.position('n1_1'), 0.0)
    survey.survey('n2_1', frame, 'n1_1', KIN,
                  KIN.inverse([*frame.to_base(true['n2_1']), 0.0, 0.0]))
    theta = KIN.inverse([*BaseFrame(survey.position('n2_1'), 0.0).to_base(true['n3_1']),
                         0.0, 0.0])
    base = BaseFrame(survey.position('n2_1'), 0.0)
    measured = survey.measure('n3_1', base, 'n2_1', KIN, theta)
    estimate = survey.survey('n3_1', base, 'n2_1', KIN, theta)
    expected = fuse(survey.nominal('n3_1'), measured)
    np.testing.assert_allclose(estimate.position, expected.position, atol=1e-12)
    np.testing.assert_allclose(estimate.covariance, expected.covariance, atol=1e-15)


def test_a_height_alone_moves_the_height_and_what_is_correlated_with_it():
    prior = NodeEstimate(np.array([1.0, 2.0, 0.0]), np.diag([4e-6, 4e-6, 4e-6]), False)
    felt = fuse_height(prior, -0.002, 4e-6)
    # equally known: halfway, half the variance; x and y untouched when uncorrelated
    assert felt.position[2] == pytest.approx(-0.001)
    assert felt.covariance[2, 2] == pytest.approx(2e-6)
    np.testing.assert_array_equal(felt.position[:2], prior.position[:2])
    np.testing.assert_allclose(felt.covariance[:2, :2], prior.covariance[:2, :2])
    assert not felt.surveyed
    # x correlated with z moves with it, by the regression of x on z
    correlated = NodeEstimate(prior.position, np.array([[4e-6, 0.0, 2e-6], [0.0, 4e-6, 0.0],
                                                        [2e-6, 0.0, 4e-6]]), True)
    moved = fuse_height(correlated, -0.002, 4e-6)
    assert moved.position[0] == pytest.approx(1.0 - 0.0005)
    assert np.linalg.eigvalsh(moved.covariance).min() > 0.0 and moved.surveyed


def test_a_felt_height_is_kept_until_a_survey_takes_its_place():
    survey = TrussMap(TRUSS, prior_std=0.002, joint_std=2e-4)
    survey.anchor_at('n1_1')
    screw = 0.003  # [m] the gripper rests this far above the mouth beside the hole
    low = DISPLACED - np.array([0.0, 0.0, 0.002])  # the node 2.7 mm under its drawing
    resting = low + np.array([0.004, 0.0, screw])
    version = survey.version
    felt = survey.measure_height('n2_1', FRAME, 'n1_1', KIN, _joints_at(resting), screw, 3e-4)
    assert survey.version > version and not survey.surveyed('n2_1')
    assert felt.position[2] == pytest.approx(low[2], abs=2e-4)
    np.testing.assert_allclose(felt.position[:2], TRUSS.position('n2_1')[:2])
    # felt again from the same base: the new reading replaces the old, not added to it
    again = survey.measure_height('n2_1', FRAME, 'n1_1', KIN, _joints_at(resting), screw, 3e-4)
    np.testing.assert_allclose(again.covariance, felt.covariance)
    # the survey at the screw-in takes its place (the same joints measure the height)
    screwed = survey.survey('n2_1', FRAME, 'n1_1', KIN, _joints_at(low))
    expected = fuse(survey.nominal('n2_1'), survey.measure('n2_1', FRAME, 'n1_1', KIN,
                                                           _joints_at(low)))
    np.testing.assert_allclose(screwed.position, expected.position, atol=1e-12)
    # the anchor is not moved; bad input is refused and changes nothing
    np.testing.assert_array_equal(
        survey.measure_height('n1_1', BaseFrame(TRUSS.position('n2_1'), 0.0), 'n2_1', KIN,
                              _joints_at(resting), screw, 3e-4).position,
        TRUSS.position('n1_1'))
    version = survey.version
    with pytest.raises(ValueError, match='contact_std'):
        survey.measure_height('n3_1', FRAME, 'n1_1', KIN, _joints_at(resting), screw, -1.0)
    with pytest.raises(ValueError, match='base node'):
        survey.measure_height('n1_1', FRAME, 'n1_1', KIN, _joints_at(resting), screw, 3e-4)
    assert survey.version == version


def test_a_hole_located_by_the_camera_is_the_estimate_until_a_height_felt_or_a_survey():
    survey = TrussMap(TRUSS, prior_std=0.002, joint_std=2e-4)
    survey.anchor_at('n1_1')
    theta = _joints_at(DISPLACED + np.array([0.0, 0.0, 0.03]))  # looking from above it
    located = FRAME.to_base(DISPLACED)
    before = survey.estimate('n2_1')
    seen = survey.sight('n2_1', FRAME, 'n1_1', KIN, theta, located, np.eye(3) * 1e-10)
    np.testing.assert_allclose(seen.position, DISPLACED, atol=1e-12)
    # the camera sees the hole against the gripper, which the joints place
    joints = survey_covariance(KIN, theta, FRAME.heading, np.full(5, 2e-4))
    np.testing.assert_allclose(seen.covariance, joints + 1e-10 * np.eye(3), rtol=1e-6,
                               atol=1e-15)
    np.testing.assert_allclose(survey.estimate('n2_1', seen=False).position, before.position)
    version = survey.version
    survey.measure_height('n2_1', FRAME, 'n1_1', KIN, _joints_at(DISPLACED), 0.0, 3e-4)
    assert survey.version > version
    assert abs(survey.position('n2_1')[0] - DISPLACED[0]) > 1e-3, 'the felt height replaces it'
    survey.sight('n2_1', FRAME, 'n1_1', KIN, theta, located, np.eye(3) * 1e-10)
    survey.survey('n2_1', FRAME, 'n1_1', KIN, _joints_at(DISPLACED))
    assert survey.estimate('n2_1').surveyed
    np.testing.assert_allclose(survey.estimate('n2_1').position,
                               survey.estimate('n2_1', seen=False).position)
    with pytest.raises(ValueError, match='base node'):
        survey.sight('n1_1', FRAME, 'n1_1', KIN, theta, located, np.eye(3))
