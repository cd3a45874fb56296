"""Cartesian paths mapped to joint space through the inverse kinematics of walker_core."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from walker_core.kinematics import WalkerKinematics
from walker_planner.core.cartesian import Branch, CartesianInJointSpace, branch_of
from walker_planner.core.errors import WorkspaceError
from walker_planner.core.profiles import MinJerkProfile
from walker_planner.core.segments import CartesianSegment

# Tip points within reach (the wrist at most 1.08 m from J2, less than 2 l2 = 1.2 m) and far
# enough from the yaw axis that J3 stays within its limit on any segment between two of them.
points = st.tuples(st.floats(0.35, 1.05), st.floats(-0.8, 0.8), st.floats(0.0, 0.25)).map(
    lambda p: (-p[0] * math.sin(p[1]), p[0] * math.cos(p[1]), p[2]))


@pytest.fixture(scope='module')
def kinematics(robot):
    return WalkerKinematics.from_parameters(robot)


def mapped(kinematics, start, goal, duration=2.0, yaw_offset=0.0):
    segment = CartesianSegment('test_line', start, goal, MinJerkProfile(duration))
    joints = kinematics.inverse([*start, 0.0, 0.0])
    joints[4] = joints[0] + yaw_offset
    return segment, CartesianInJointSpace(segment, kinematics, branch_of(kinematics, joints),
                                          joints)


@settings(max_examples=25, deadline=None)
@given(points, points)
def test_the_joint_trajectory_puts_the_tip_on_the_path(kinematics, start, goal):
    if np.linalg.norm(np.subtract(goal, start)) < 1e-3:
        return
    segment, joint = mapped(kinematics, start, goal)
    t = np.linspace(0.0, segment.duration, 41)
    q = joint.sample(t).position
    tips = np.array([kinematics.forward(row) for row in q])
    np.testing.assert_allclose(tips[:, :3], segment.sample(t).position, atol=1e-9)
    np.testing.assert_allclose(tips[:, 3], 0.0, atol=1e-9)  # gripper vertical throughout
    np.testing.assert_allclose(q[:, 4] - q[:, 0], q[0, 4] - q[0, 0], atol=1e-12)


@settings(max_examples=25, deadline=None)
@given(points, points)
def test_joint_rates_map_to_the_tip_rates_through_the_jacobian(kinematics, start, goal):
    if np.linalg.norm(np.subtract(goal, start)) < 1e-3:
        return
    segment, joint = mapped(kinematics, start, goal, yaw_offset=0.2)
    t = np.linspace(0.0, segment.duration, 17)[1:-1]
    q = joint.sample(t)
    tip = segment.sample(t)
    for k in range(len(t)):
        jacobian = kinematics.jacobian(q.position[k])
        np.testing.assert_allclose((jacobian @ q.velocity[k])[:3], tip.velocity[k], atol=1e-9)
        assert (jacobian @ q.velocity[k])[3] == pytest.approx(0.0, abs=1e-9)
    step = 1e-6
    ahead, behind = joint.sample(t + step), joint.sample(t - step)
    np.testing.assert_allclose(q.acceleration, (ahead.velocity - behind.velocity) / (2 * step),
                               atol=1e-5)


def test_a_path_out_of_reach_is_refused_with_the_time_and_place(kinematics):
    with pytest.raises(WorkspaceError, match=r'leaves the workspace at t = .* s.*out of reach'):
        mapped(kinematics, [0.0, 0.9, 0.03], [0.0, 1.5, 0.03])


def test_a_path_that_breaks_a_joint_limit_is_refused_naming_the_joint(kinematics):
    # straight through the yaw axis side: J3 folds beyond its limit near the base
    with pytest.raises(WorkspaceError, match=r'J3 = .* outside its limits'):
        mapped(kinematics, [0.0, 0.9, 0.03], [0.0, 0.05, 0.03])


def test_the_start_branch_is_kept(kinematics):
    free = WalkerKinematics(kinematics.l1, kinematics.l2)  # elbow down breaks J2's limit
    joints = free.inverse([0.0, 0.8, 0.05, 0.0, 0.0], elbow='down')
    branch = branch_of(free, joints)
    assert branch == Branch('down', 'forward', 0.0)
    segment = CartesianSegment('test_line', [0, 0.8, 0.05], [0.1, 0.8, 0.05], MinJerkProfile(1))
    q = CartesianInJointSpace(segment, free, branch, joints).sample(
        np.linspace(0, 1, 11)).position
    assert np.all(q[:, 2] < 0.0)
    tips = np.array([free.forward(row)[:3] for row in q])
    np.testing.assert_allclose(tips, segment.sample(np.linspace(0, 1, 11)).position, atol=1e-9)


def test_a_half_turn_keeps_j1_continuous(kinematics):
    # an arc sampled in pieces through the -y axis, where atan2 wraps
    start = np.array([0.3, -0.85, 0.03])
    goal = np.array([-0.3, -0.85, 0.03])
    joints = kinematics.inverse([*start, 0.0, 0.0], reference=[3.0, 0, 0, 0, 3.0])
    joints[4] = joints[0]
    segment = CartesianSegment('test_line', start, goal, MinJerkProfile(1.0))
    q = CartesianInJointSpace(segment, kinematics, branch_of(kinematics, joints),
                              joints).sample(np.linspace(0, 1, 101)).position
    assert np.max(np.abs(np.diff(q[:, 0]))) < 0.05
    assert q[0, 0] > math.pi > q[-1, 0]  # through pi, not wrapped to -pi


@settings(max_examples=25, deadline=None)
@given(points, points, st.floats(-0.5, 0.5))
def test_the_path_is_mapped_at_once_as_it_is_sample_by_sample(kinematics, start, goal, offset):
    """All samples through one array pass: the joints the sample-by-sample IK gives."""
    if np.linalg.norm(np.subtract(goal, start)) < 1e-3:
        return
    segment, joint = mapped(kinematics, start, goal, yaw_offset=offset)
    t = np.linspace(0.0, segment.duration, 301)
    tip = segment.sample(t).position
    one_by_one = joint._positions_one_by_one(t, tip, np.interp(t, joint._grid,
                                                               joint._yaw_reference))

    def not_sample_by_sample(*_):
        raise AssertionError('a path within the workspace fell back to sample by sample')
    joint._positions_one_by_one = not_sample_by_sample
    np.testing.assert_allclose(joint.sample(t).position, one_by_one, atol=1e-12)


@pytest.mark.parametrize('elbow, reach', [('down', 'forward'), ('up', 'backward'),
                                          ('down', 'backward')])
def test_the_other_branches_are_mapped_at_once_as_sample_by_sample(kinematics, elbow, reach):
    free = WalkerKinematics(kinematics.l1, kinematics.l2)  # no limits: every branch
    start, goal = np.array([0.1, 0.7, 0.05]), np.array([-0.2, 0.75, 0.1])
    joints = free.inverse([*start, 0.0, 0.3], elbow=elbow, reach=reach, check_limits=False)
    segment = CartesianSegment('test_line', start, goal, MinJerkProfile(1.0))
    joint = CartesianInJointSpace(segment, free, branch_of(free, joints), joints)
    assert joint.branch.elbow == elbow and joint.branch.reach == reach
    t = np.linspace(0.0, 1.0, 101)
    tip = segment.sample(t).position
    one_by_one = joint._positions_one_by_one(t, tip, np.interp(t, joint._grid,
                                                               joint._yaw_reference))
    np.testing.assert_allclose(joint.sample(t).position, one_by_one, atol=1e-12)
    np.testing.assert_allclose([free.forward(q)[:3] for q in joint.sample(t).position], tip,
                               atol=1e-9)
