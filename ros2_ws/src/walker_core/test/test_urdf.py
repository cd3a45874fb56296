"""The URDF generated from the parameters: frames equal the kinematics, masses equal the file.

pybullet (the simulator that loads the URDF) is the independent reader here: poses and the
inertia it computes from the URDF are compared with :mod:`walker_core.kinematics` and
:mod:`walker_core.dynamics`.
"""

import tempfile
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import numpy as np
import pybullet
import pytest

from walker_core.dynamics import RigidModel, diagonal_inertia
from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_core.kinematics import WalkerKinematics
from walker_core.robot_parameters import load_walker_parameters
from walker_core.urdf import (
    GRIPPER_LINKS, description_urdf, flex_joints, plant_urdf, rotor_joint_name)

PARAMS = load_walker_parameters()


@pytest.fixture
def bullet():
    client = pybullet.connect(pybullet.DIRECT)
    yield client
    pybullet.disconnect(physicsClientId=client)


def load(client, text, fixed_base=True):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / 'walker.urdf'
        path.write_text(text)
        body = pybullet.loadURDF(str(path), useFixedBase=fixed_base,
                                 flags=pybullet.URDF_USE_INERTIA_FROM_FILE,
                                 physicsClientId=client)
    joints, links, movable = {}, {}, []
    for index in range(pybullet.getNumJoints(body, physicsClientId=client)):
        info = pybullet.getJointInfo(body, index, physicsClientId=client)
        joints[info[1].decode()] = index
        links[info[12].decode()] = index
        if info[2] != pybullet.JOINT_FIXED:
            movable.append(info[1].decode())
    return body, joints, links, movable


def gripper_b_transform(client, body, joints, links, angles):
    for name, angle in zip(PHYSICAL_JOINT_NAMES, angles, strict=True):
        pybullet.resetJointState(body, joints[name], angle, physicsClientId=client)
    state = pybullet.getLinkState(body, links[GRIPPER_LINKS['b']], computeForwardKinematics=True,
                                  physicsClientId=client)
    transform = np.eye(4)
    transform[:3, :3] = np.reshape(pybullet.getMatrixFromQuaternion(state[5]), (3, 3))
    transform[:3, 3] = state[4]
    return transform


@pytest.mark.parametrize('generate', [plant_urdf, description_urdf])
def test_gripper_b_frame_is_the_forward_kinematics_at_zero_bending(bullet, generate):
    body, joints, links, _ = load(bullet, generate(PARAMS))
    kinematics = WalkerKinematics.from_parameters(PARAMS)
    rng = np.random.default_rng(7)
    for _ in range(20):
        angles = rng.uniform(-np.pi, np.pi, 5)
        expected = kinematics.forward_transform(angles)
        actual = gripper_b_transform(bullet, body, joints, links, angles)
        np.testing.assert_allclose(actual, expected, atol=1e-6)


def test_the_description_moves_only_the_five_actuated_joints(bullet):
    _, _, _, movable = load(bullet, description_urdf(PARAMS))
    assert movable == list(PHYSICAL_JOINT_NAMES)


def test_the_plant_model_bends_in_both_planes_and_has_a_rotor_per_drive(bullet):
    _, joints, _, movable = load(bullet, plant_urdf(PARAMS))
    segments = PARAMS.robot.flexibility.segments_per_link
    bends = flex_joints(segments)
    assert len(bends) == 2 * 2 * (segments - 1)
    assert {b.plane for b in bends} == {'in_plane', 'out_of_plane'}
    expected = {*PHYSICAL_JOINT_NAMES, *(b.name for b in bends),
                *(rotor_joint_name(j) for j in PHYSICAL_JOINT_NAMES)}
    assert set(movable) == expected
    assert set(joints) >= expected


def test_joint_limits_and_effort_come_from_the_drives():
    root = ElementTree.fromstring(description_urdf(PARAMS))
    for role, name in enumerate(PHYSICAL_JOINT_NAMES, start=1):
        drive = PARAMS.robot.drive.for_role(role)
        limit = root.find(f"joint[@name='{name}']/limit")
        assert float(limit.get('lower')) == drive.position_min
        assert float(limit.get('upper')) == drive.position_max
        assert float(limit.get('effort')) == drive.torque_limit


def test_total_mass_is_the_parameter_files(bullet):
    body, joints, _, _ = load(bullet, description_urdf(PARAMS), fixed_base=False)
    links = [-1, *joints.values()]
    total = sum(pybullet.getDynamicsInfo(body, link, physicsClientId=bullet)[0]
                for link in links)
    mass = PARAMS.robot.mass
    expected = 2 * mass.gripper + 2 * mass.wrist + mass.vertex + 2 * mass.link
    # The only extra mass is the helper bodies between the two bending joints of a bend
    # (1% of a segment each).
    assert total == pytest.approx(expected, rel=2e-3)


def test_the_plant_inertia_agrees_with_the_rigid_model_of_the_controllers(bullet):
    """The joint inertia pybullet simulates is the diagonal of eqs (9)-(13) within 5%.

    The plant spreads each link's mass along it and gears a rotor to each joint; the paper's
    lumped model puts half a link at each end and adds n^2 I_m. Both must describe the same
    robot closely, or the controllers' feed-forward would be designed for another one.
    """
    body, joints, _, movable = load(bullet, plant_urdf(PARAMS))
    kinematics = WalkerKinematics.from_parameters(PARAMS)
    angles = kinematics.inverse([0.0, PARAMS.truss.spacing, 0.0, 0.0, 0.0])
    positions = dict.fromkeys(movable, 0.0)
    positions.update(dict(zip(PHYSICAL_JOINT_NAMES, angles, strict=True)))
    order = sorted(movable, key=joints.get)
    full = np.array(pybullet.calculateMassMatrix(body, [positions[n] for n in order],
                                                 physicsClientId=bullet))
    gear = PARAMS.robot.drive.role_array('gear_ratio')
    simulated = []
    for name, ratio in zip(PHYSICAL_JOINT_NAMES, gear, strict=True):
        column = np.zeros(len(order))
        column[order.index(name)] = 1.0
        column[order.index(rotor_joint_name(name))] = ratio
        simulated.append(column @ full @ column)
    expected = diagonal_inertia(angles, RigidModel.from_parameters(PARAMS))
    np.testing.assert_allclose(simulated, expected, rtol=0.05)


def test_urdf_is_well_formed_xml_naming_the_robot():
    for text in (plant_urdf(PARAMS), description_urdf(PARAMS)):
        root = ElementTree.fromstring(text)
        assert root.tag == 'robot' and root.get('name') == PARAMS.robot.name
        names = [link.get('name') for link in root.findall('link')]
        assert len(names) == len(set(names))
        assert {'gripper_a', 'gripper_b'} <= set(names)
