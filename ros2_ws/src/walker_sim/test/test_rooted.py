"""The walker rooted at either gripper: one model, two bodies, state carried between them."""

import numpy as np
import pybullet
import pytest

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_core.urdf import flex_joints
from walker_sim.core.flexibility import tune_flexibility
from walker_core.gripper_state import GripperState
from walker_sim.core.rooted import carry_state, load_rooted_body

PERIOD = 0.002


@pytest.fixture(scope='module')
def bodies(params):
    tuning = tune_flexibility(params)
    loaded = {root: load_rooted_body(root, params, tuning, 1e-3) for root in 'ab'}
    yield loaded
    for rooted in loaded.values():
        rooted.disconnect()


def _set_physical(rooted, angles, bends, speeds=None, bend_speeds=None):
    speeds = np.zeros(5) if speeds is None else speeds
    bend_speeds = np.zeros(len(bends)) if bend_speeds is None else bend_speeds
    for joint in rooted.index.movable:
        pybullet.resetJointState(rooted.body, joint, 0.0, 0.0, physicsClientId=rooted.client)
    for joint, angle, speed in zip(rooted.joints, angles, speeds, strict=True):
        pybullet.resetJointState(rooted.body, joint, float(angle), float(speed),
                                 physicsClientId=rooted.client)
    for joint, sign, angle, speed in zip(rooted.bends, rooted.bend_signs, bends, bend_speeds,
                                         strict=True):
        pybullet.resetJointState(rooted.body, joint, float(sign * angle), float(sign * speed),
                                 physicsClientId=rooted.client)


def _parts(rooted):
    """Centre of mass, linear and angular velocity of every part but the rotors."""
    parts = []
    for name, link in rooted.index.links.items():
        if name.endswith('_rotor'):
            continue
        if link == -1:
            position = pybullet.getBasePositionAndOrientation(
                rooted.body, physicsClientId=rooted.client)[0]
            velocity, spin = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        else:
            state = pybullet.getLinkState(rooted.body, link, computeLinkVelocity=True,
                                          computeForwardKinematics=True,
                                          physicsClientId=rooted.client)
            position, velocity, spin = state[0], state[6], state[7]
        parts.append(np.concatenate([position, velocity, spin]))
    return np.array(parts)


def _match(parts, others):
    """Largest difference of each part of ``parts`` to the part of ``others`` at its place."""
    distance = np.linalg.norm(parts[:, None, :3] - others[None, :, :3], axis=2)
    nearest = others[distance.argmin(axis=1)]
    return (np.abs(parts[:, :3] - nearest[:, :3]).max(),
            np.abs(parts[:, 3:] - nearest[:, 3:]).max())


def _gripper_pose(rooted, gripper):
    link = rooted.gripper_links[gripper]
    if link == -1:
        return pybullet.getBasePositionAndOrientation(rooted.body,
                                                      physicsClientId=rooted.client)
    state = pybullet.getLinkState(rooted.body, link, computeForwardKinematics=True,
                                  physicsClientId=rooted.client)
    return state[4], state[5]


@pytest.mark.parametrize('seed', [1, 2, 3])
def test_both_bodies_put_every_part_of_the_walker_in_the_same_place(bodies, params, seed):
    rng = np.random.default_rng(seed)
    angles = rng.uniform(-1.0, 1.0, 5)
    bends = rng.uniform(-0.1, 0.1, len(flex_joints(
        params.robot.flexibility.segments_per_link)))
    source, target = bodies['a'], bodies['b']
    _set_physical(source, angles, bends)
    position, orientation = _gripper_pose(source, 'b')
    pybullet.resetBasePositionAndOrientation(target.body, position, orientation,
                                             physicsClientId=target.client)
    _set_physical(target, angles, bends)
    offset, _ = _match(_parts(source), _parts(target))
    assert offset < 1e-6
    a_source, a_target = _gripper_pose(source, 'a'), _gripper_pose(target, 'a')
    np.testing.assert_allclose(a_source[0], a_target[0], atol=1e-6)
    assert abs(np.dot(a_source[1], a_target[1])) == pytest.approx(1.0, abs=1e-9)


def _speeds_holding(rooted, gripper, rng):
    """Random joint speeds (physical: joints, then bends) that leave ``gripper`` at rest."""
    movable = list(rooted.index.movable)
    zeros = [0.0] * len(movable)
    angles = [pybullet.getJointState(rooted.body, j, physicsClientId=rooted.client)[0]
              for j in movable]
    linear, angular = pybullet.calculateJacobian(
        rooted.body, rooted.gripper_links[gripper], [0.0, 0.0, 0.0], angles, zeros, zeros,
        physicsClientId=rooted.client)
    columns = [movable.index(j) for j in (*rooted.joints, *rooted.bends)]
    jacobian = np.vstack([np.asarray(linear)[:, columns], np.asarray(angular)[:, columns]])
    _, _, rows = np.linalg.svd(jacobian)
    null_space = rows[np.linalg.matrix_rank(jacobian):].T
    speeds = null_space @ rng.normal(size=null_space.shape[1])
    signs = np.concatenate([np.ones(5), rooted.bend_signs])
    return signs * speeds


def test_a_carried_walker_keeps_every_part_where_it_was_and_as_it_was_moving(bodies):
    """At the swap the new root is screwed in (at rest); everything else keeps its motion."""
    rng = np.random.default_rng(7)
    source, target = bodies['a'], bodies['b']
    angles = np.array([0.3, 0.8, 1.4, 0.9, -0.2])
    bends = rng.uniform(-0.05, 0.05, len(source.bends))
    _set_physical(source, angles, bends)
    speeds = _speeds_holding(source, 'b', rng)
    _set_physical(source, angles, bends, speeds[:5], speeds[5:])
    moving = _parts(source)
    assert np.abs(moving[:, 3:]).max() > 0.1
    carry_state(source, target)
    offset, motion = _match(moving, _parts(target))
    assert offset < 1e-6 and motion < 1e-6


def test_the_plant_reroots_at_the_other_gripper_when_its_base_lets_go(make_plant, params):
    plant = make_plant()
    state = plant.state()
    assert state.base == 'a' and plant.gripper_status('b').mode == GripperState.ATTACHED
    before = plant.client
    resting_b = state.poses['b'].position.copy()
    plant.unscrew('a')
    previous = state.position
    for _ in range(round(params.gripper.screw_time / PERIOD) + 5):
        state = plant.step(np.zeros(5), PERIOD)
        # no jump at the instant the walker changes bodies
        assert np.abs(state.position - previous).max() < 1e-4
        previous = state.position
    assert plant.gripper_status('a').mode == GripperState.FREE and state.base == 'b'
    assert plant.client != before
    # the new base stays where it was screwed in, the freed gripper moves under a torque
    torque = np.zeros(5)
    torque[PHYSICAL_JOINT_NAMES.index('b_yaw_joint')] = 0.5 * plant.drive.torque_limit[4]
    free_a = state.poses['a'].position.copy()
    for _ in range(100):
        state = plant.step(torque, PERIOD)
    np.testing.assert_allclose(state.poses['b'].position, resting_b, atol=1e-6)
    assert np.linalg.norm(state.poses['a'].position - free_a) > 1e-3
