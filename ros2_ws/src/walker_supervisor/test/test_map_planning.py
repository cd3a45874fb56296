"""Steps planned on the truss map: from the measured tip, to the map's estimate."""

import numpy as np
import pytest

from walker_core.kinematics import WalkerKinematics
from walker_core.robot_parameters import load_walker_parameters
from walker_core.truss import Truss
from walker_supervisor.core.map_planning import MapPlanning
from walker_supervisor.core.route import PlannedStep, step_sweep
from walker_supervisor.core.step_geometry import BaseFrame, plan_step_targets
from runner_world import SETTINGS

PARAMS = load_walker_parameters()
KIN = WalkerKinematics.from_parameters(PARAMS)
TRUSS = Truss.from_parameters(PARAMS)
HEIGHT = PARAMS.gripper.approach_height
STEP = PlannedStep('a', 'n1_1', 'n2_1', 'n1_2', step_sweep(TRUSS, 'n1_1', 'n2_1', 'n1_2'))
#: [m] the from node n2_1 off its nominal place, along the base-to-node line (truss x)
OFF = np.array([0.0028, 0.0, 0.0006])


def _stance(heading: float, from_point) -> np.ndarray:
    """Joint angles [rad] (role order, base a in n1_1) with gripper b at a truss-frame point."""
    frame = BaseFrame(TRUSS.position('n1_1'), heading)
    return KIN.inverse([*frame.to_base(from_point), 0.0, 0.0])


def _planning() -> MapPlanning:
    return MapPlanning(KIN, TRUSS, SETTINGS, PARAMS.gripper.insertion_position_tolerance,
                       HEIGHT, PARAMS.gripper.screw_length)


def test_the_extraction_line_rises_from_the_measured_tip_not_the_nominal_node():
    theta = _stance(0.2, TRUSS.position('n2_1') + OFF)
    frame = BaseFrame.from_stance(KIN, theta, TRUSS.position('n1_1'), TRUSS.position('n2_1'))
    targets = plan_step_targets(KIN, frame, STEP, TRUSS.position('n2_1'),
                                TRUSS.position('n1_2'), theta, HEIGHT)
    tip = KIN.forward(theta)[:3]
    np.testing.assert_allclose(targets.point_above_from, tip + [0.0, 0.0, HEIGHT], atol=1e-12)
    np.testing.assert_allclose(KIN.forward(targets.above_from)[:3], targets.point_above_from,
                               atol=1e-9)
    # the nominal node is millimetres off that line: the planner refused a lift to it
    assert np.linalg.norm(frame.to_base(TRUSS.position('n2_1'))[:2] - tip[:2]) > 0.0005


def test_the_first_stance_anchors_the_map_and_surveys_the_other_node():
    planning = _planning()
    theta = _stance(0.0, TRUSS.position('n2_1') + OFF)
    targets = planning.targets(STEP, theta)
    survey = planning.map
    assert survey.anchor == 'n1_1' and survey.surveyed('n2_1')
    # the heading is the nominal direction's: the surveyed node lies on it, at the measured
    # distance and height (fused with its 2 mm prior, the joints' 0.2 mm survey moves it
    # nearly all the way from the nominal place)
    measured = survey.position('n2_1')
    tip = KIN.forward(theta)[:3]
    assert np.linalg.norm(measured - TRUSS.position('n1_1')) == pytest.approx(
        np.linalg.norm(tip), abs=0.05 * np.linalg.norm(OFF))
    assert measured[2] == pytest.approx(OFF[2], abs=0.05 * OFF[2])
    np.testing.assert_allclose(targets.frame.to_truss(targets.point_to), TRUSS.position('n1_2'),
                               atol=1e-12)


def test_a_surveyed_target_is_aimed_at_where_the_survey_put_it():
    planning = _planning()
    theta = _stance(0.0, TRUSS.position('n2_1'))
    planning.targets(STEP, theta)  # the first stance
    surveyed = TRUSS.position('n1_2') + np.array([0.0021, -0.0017, -0.0004])
    planning.map.load({**planning.map.to_dict(), 'nodes': {
        **planning.map.to_dict()['nodes'],
        'n1_2': {'position': surveyed.tolist(), 'covariance': np.eye(3).tolist()}}})
    targets = planning.targets(STEP, theta)
    np.testing.assert_allclose(targets.frame.to_truss(targets.point_to), surveyed, atol=1e-12)
    np.testing.assert_allclose(KIN.forward(targets.at_to)[:3], targets.point_to, atol=1e-9)


def test_a_screw_in_surveys_the_node_and_the_next_stance_surveys_it_again():
    planning = _planning()
    theta = _stance(0.0, TRUSS.position('n2_1'))
    targets = planning.targets(STEP, theta)
    hole = TRUSS.position('n1_2') + np.array([0.0012, 0.0009, 0.0])
    at_hole = KIN.inverse([*targets.frame.to_base(hole), 0.0, KIN.forward(targets.at_to)[4]],
                          reference=targets.at_to)
    planning.screwed_in(STEP, targets, at_hole)
    # 1.5 mm off its nominal place, the node is surveyed where the hole is: the joints' 0.2 mm
    # outweigh the 2 mm prior
    screwed = planning.map.position('n1_2')
    assert np.linalg.norm(screwed - hole) < 0.05 * np.linalg.norm(hole - TRUSS.position('n1_2'))
    # the next step pivots on b, in n1_2; its stance is the same joints in b's role order
    following = PlannedStep('b', 'n1_2', 'n1_1', 'n0_2',
                            step_sweep(TRUSS, 'n1_2', 'n1_1', 'n0_2'))
    relaxed = at_hole + np.array([0.0004, 0.0, 0.0, 0.0, 0.0])  # joint 1 slid in relaxing
    next_targets = planning.targets(following, relaxed[::-1])
    moved = planning.map.position('n1_2')
    relaxed_point = targets.frame.to_truss(KIN.forward(relaxed)[:3])
    # the relaxed reading replaces the screw-in's (the same joints' offsets: not two readings)
    assert np.linalg.norm(moved - relaxed_point) < 0.05 * np.linalg.norm(relaxed_point - hole)
    np.testing.assert_allclose(planning.map.estimate('n1_2').covariance,
                               planning.map.measure('n1_2', targets.frame, 'n1_1', KIN,
                                                    relaxed).covariance, rtol=0.05)
    # the new base frame sits on the node as surveyed, and its extraction on the tip in n1_1
    # (to within the few hundredths of a millimetre the prior moved the base's estimate)
    np.testing.assert_allclose(next_targets.frame.origin, moved)
    np.testing.assert_allclose(next_targets.frame.to_truss(
        next_targets.point_above_from - [0.0, 0.0, HEIGHT]), TRUSS.position('n1_1'), atol=1e-4)


def test_the_search_follows_the_targets_uncertainty_and_zero_radius_turns_it_off():
    planning = _planning()
    search = planning.search(STEP)
    assert search is not None and len(search.pattern) > 1
    std = planning.map.estimate(STEP.to_node).horizontal_std
    assert std >= SETTINGS.node_prior_std  # known relative to its neighbour only
    assert search.pattern.covered == pytest.approx(
        min(SETTINGS.search_sigmas * std, SETTINGS.search_radius - search.pattern.reach))
    import dataclasses
    planning.set_settings(dataclasses.replace(SETTINGS, search_radius=0.0))
    assert planning.search(STEP) is None


def test_a_target_known_worse_gets_a_wider_search_up_to_the_radius_and_no_farther():
    """Farther along the chain the estimate is known worse: the search covers more of it."""
    import dataclasses
    planning = _planning()
    planning.targets(STEP, _stance(0.0, TRUSS.position('n2_1') + OFF))
    near = planning.search(STEP).pattern
    # the same step with every node known 1.5 times worse: the extent follows the estimate
    wider = dataclasses.replace(SETTINGS, node_prior_std=1.5 * SETTINGS.node_prior_std)
    planning.set_settings(wider)
    far = planning.search(STEP).pattern
    assert far.covered == pytest.approx(min(1.5 * near.covered,
                                            SETTINGS.search_radius - far.reach))
    assert len(far) > len(near)
    # an estimate known to centimetres: bounded by search_radius, every probe within it
    planning.set_settings(dataclasses.replace(SETTINGS, node_prior_std=0.015))
    capped = planning.search(STEP).pattern
    assert capped.covered == pytest.approx(SETTINGS.search_radius - capped.reach)
    assert np.linalg.norm(capped.offsets, axis=1).max() <= SETTINGS.search_radius + 1e-12


def test_a_jam_on_the_targets_face_sets_its_height_for_the_steps_after_it():
    """A gripper resting on the face beside the hole stands a screw's length above the mouth."""
    planning = _planning()
    targets = planning.targets(STEP, _stance(0.0, TRUSS.position('n2_1') + OFF))
    low = 0.0025  # [m] the target node sits this far under its estimate (more than overtravel)
    before = planning.map.estimate(STEP.to_node)
    resting = targets.point_to + np.array([0.004, 0.0, PARAMS.gripper.screw_length - low])
    theta = KIN.inverse([*resting, 0.0, targets.at_to[4]], reference=targets.at_to)
    planning.felt_face(STEP, targets.frame, theta)
    after = planning.map.estimate(STEP.to_node)
    assert after.position[2] == pytest.approx(before.position[2] - low, abs=0.1 * low)
    assert after.covariance[2, 2] < 0.1 * before.covariance[2, 2]
    np.testing.assert_allclose(after.position[:2], before.position[:2], atol=1e-9)
    assert not after.surveyed
    # a later step to the node plans its descent at the height felt
    again = planning.targets(STEP, _stance(0.0, TRUSS.position('n2_1') + OFF))
    assert again.point_to[2] == pytest.approx(targets.point_to[2] - low, abs=0.1 * low)


def test_the_coarse_motion_keeps_its_starts_radius_and_height_and_fine_takes_the_rest():
    """The node-to-node motion circles the base axis: it ends at the target's bearing."""
    theta = _stance(0.0, TRUSS.position('n2_1') + OFF)
    frame = BaseFrame.from_stance(KIN, theta, TRUSS.position('n1_1'), TRUSS.position('n2_1'))
    targets = plan_step_targets(KIN, frame, STEP, TRUSS.position('n2_1'),
                                TRUSS.position('n1_2'), theta, HEIGHT)
    joints, point = targets.coarse_goal
    start = targets.point_above_from
    assert np.hypot(*point[:2]) == pytest.approx(np.hypot(*start[:2]), abs=1e-12)
    assert point[2] == pytest.approx(start[2], abs=1e-12)
    bearing = np.arctan2(point[1], point[0]) - np.arctan2(*targets.point_above_to[1::-1])
    assert abs(np.remainder(bearing + np.pi, 2 * np.pi) - np.pi) < 1e-12
    np.testing.assert_allclose(KIN.forward(joints)[:3], point, atol=1e-9)
    # within the fine region of the point above the hole: FINE takes it there
    assert np.linalg.norm(point - targets.point_above_to) < 0.005
    # on the nominal truss the coarse motion ends on the point above the hole itself
    nominal = plan_step_targets(KIN, frame, STEP, TRUSS.position('n2_1'),
                                TRUSS.position('n1_2'), _stance(0.0, TRUSS.position('n2_1')),
                                HEIGHT)
    assert nominal.coarse_to is None
    np.testing.assert_array_equal(nominal.coarse_goal[1], nominal.point_above_to)


@pytest.mark.parametrize('side', [1.0, -1.0])
def test_a_half_turn_to_a_node_off_its_bearing_ends_its_coarse_motion_opposite_its_start(side):
    # a straight step (a half turn about n1_1), the target 1.5 mm across the line either way:
    # its bearing is a hair short of or past 180 deg, the coarse motion's is 180 deg exactly
    step = PlannedStep('a', 'n1_1', 'n2_1', 'n0_1', step_sweep(TRUSS, 'n1_1', 'n2_1', 'n0_1'))
    planning = _planning()
    theta = _stance(0.0, TRUSS.position('n2_1'))
    planning.targets(step, theta)
    displaced = TRUSS.position('n0_1') + np.array([0.0, side * 0.0015, 0.0])
    planning.map.load({**planning.map.to_dict(), 'nodes': {
        **planning.map.to_dict()['nodes'],
        'n0_1': {'position': displaced.tolist(), 'covariance': (np.eye(3) * 1e-8).tolist()}}})
    targets = planning.targets(step, theta)
    joints, point = targets.coarse_goal
    start = targets.point_above_from
    np.testing.assert_allclose(point, [-start[0], -start[1], start[2]], atol=1e-12)
    np.testing.assert_allclose(KIN.forward(joints)[:3], point, atol=1e-9)
    # the base yaw turns by the route's half turn, the way it chose
    assert joints[0] - theta[0] == pytest.approx(step.sweep, abs=1e-6)
    # FINE is left the millimetres to the target
    assert 0.001 < np.linalg.norm(targets.point_above_to - point) < 0.003


def test_a_probe_goes_to_its_offset_and_to_the_height_felt_since_the_step_began():
    from walker_supervisor.core.step_geometry import probe_targets

    planning = _planning()
    targets = planning.targets(STEP, _stance(0.0, TRUSS.position('n2_1') + OFF))
    offset, low = np.array([0.0026, -0.0015]), -0.003  # [m]
    probe = probe_targets(KIN, targets, offset, low)
    moved = probe.frame.to_truss(probe.point_to) - targets.frame.to_truss(targets.point_to)
    np.testing.assert_allclose(moved, [*offset, low], atol=1e-12)
    np.testing.assert_allclose(probe.point_above_to - targets.point_above_to,
                               probe.point_to - targets.point_to, atol=1e-12)
    # the joints go there: the descent of the probe ends on the felt mouth
    np.testing.assert_allclose(KIN.forward(probe.at_to)[:3], probe.point_to, atol=1e-9)
    np.testing.assert_allclose(KIN.forward(probe.above_to)[:3], probe.point_above_to,
                               atol=1e-9)
