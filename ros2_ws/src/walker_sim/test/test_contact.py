"""Contact with the node: the face holds a gripper off the hole, the chamfer guides one in."""

import numpy as np
import pytest

from walker_core.robot_parameters import load_walker_parameters
from walker_sim.core.config import StartConfiguration
from walker_sim.core.contact import (
    CONTACT_STIFFNESS, NodeGeometry, Seat, contact_forces, where_the_screw_is)
from walker_core.gripper_state import GripperState
from walker_sim.core.imperfections import NodePlacement

NODE = (1.8, 0.9, 0.0)
UP = (0.0, 0.0, 1.0)
STILL = (0.0, 0.0, 0.0)
PERIOD = 0.002
#: [m] the gripper's screw below its shoulder (``gripper.screw_length``)
SCREW_LENGTH = load_walker_parameters().gripper.screw_length


@pytest.fixture(scope='module')
def geometry(params):
    return NodeGeometry.from_parameters(params)


def forces_at(geometry, offset, height, velocity=STILL):
    position = tuple(n + d for n, d in zip(NODE, (*offset, height), strict=True))
    return contact_forces(geometry, NODE, position, UP, velocity, STILL, position)


def test_nothing_touches_a_gripper_above_the_face(geometry):
    assert forces_at(geometry, (0.004, 0.0), SCREW_LENGTH + 1e-4) == []
    # on the axis the screw is in the bore and the shoulder above the mouth: no force either
    assert forces_at(geometry, (0.0, 0.0), 0.5 * SCREW_LENGTH) == []


def test_off_the_hole_the_face_pushes_the_screw_straight_up(geometry):
    (contact,) = forces_at(geometry, (0.004, 0.0), SCREW_LENGTH - 1e-4)
    np.testing.assert_allclose(contact.force, (0.0, 0.0, CONTACT_STIFFNESS * 1e-4), atol=1e-9)
    assert contact.depth == pytest.approx(1e-4)


def test_the_chamfer_pushes_the_screw_up_and_towards_the_axis(geometry):
    radius = 0.5 * (geometry.chamfer_radius + geometry.bore_radius)
    cone = radius - geometry.chamfer_radius  # the 45 degree chamfer's height there
    (contact,) = forces_at(geometry, (radius, 0.0), SCREW_LENGTH + cone - 1e-4)
    force = np.array(contact.force)
    assert force[0] < 0.0 and force[2] > 0.0 and force[0] == pytest.approx(-force[2])


def test_the_bore_wall_keeps_the_screw_in_the_bore_and_the_shoulder_rests_on_the_mouth(
        geometry):
    wall, shoulder = sorted(forces_at(geometry, (0.0, geometry.bore_radius + 1e-4), -1e-4),
                            key=lambda c: c.point[2])
    assert wall.force[1] < 0.0 and wall.force[2] == pytest.approx(0.0, abs=1e-9)
    np.testing.assert_allclose(shoulder.force, (0.0, 0.0, CONTACT_STIFFNESS * 1e-4),
                               atol=1e-9)


def test_the_contact_never_pulls(geometry):
    # sinking less than the contact's speed times its damping ratio: leaving fast
    leaving = (0.0, 0.0, 1.0)
    assert forces_at(geometry, (0.004, 0.0), SCREW_LENGTH - 1e-5, velocity=leaving) == []


def test_where_the_screw_is_says_face_chamfer_bore(geometry):
    on_face = where_the_screw_is(geometry, NODE, (NODE[0] + 0.004, NODE[1], SCREW_LENGTH), UP)
    assert on_face[0] == Seat.ON_FACE
    assert on_face[1] == pytest.approx(SCREW_LENGTH) and on_face[2] == pytest.approx(0.004)
    in_bore = where_the_screw_is(geometry, NODE, (NODE[0], NODE[1], 0.0), UP)
    assert in_bore[0] == Seat.IN_BORE
    high = where_the_screw_is(geometry, NODE, (NODE[0], NODE[1], 0.05), UP)
    assert high[0] == Seat.CLEAR


# ---------------------------------------------------------------- on the flexible plant
def start(sim, height=0.01):
    return StartConfiguration(base_gripper='a', base_node=sim.start.base_node,
                              other_node=sim.start.other_node, other_attached=False,
                              other_height=height)


def descend(plant, sim, offset, depth, speed=0.02, rest=0.5):
    """Lower gripper b on a vertical line ``offset`` [m] off its node's (true) axis.

    A joint-space PD (friction off, so the joints come to rest where the forces say) tracks
    the inverse kinematics of the line down to ``depth`` [m] below the node's mouth.
    """
    state = plant.reset(start(sim))
    plant.enable_friction(False)
    base = plant.node_position(sim.start.base_node)
    node = plant.node_position(sim.start.other_node)
    end = node - base + np.array([offset[0], offset[1], -depth])
    top = end + np.array([0.0, 0.0, depth + 0.01])
    steps = round(np.linalg.norm(end - top) / speed / PERIOD)
    for k in range(steps + round(rest / PERIOD)):
        point = top + min(1.0, k / steps) * (end - top)
        goal = np.array(plant.kinematics.inverse([*point, 0.0, 0.0]))
        torque = 300.0 * (goal - plant.true_joint_positions()) - 20.0 * state.velocity
        state = plant.step(torque, PERIOD)
    return state, node


@pytest.mark.parametrize('offset', [(0.004, 0.0), (0.0, -0.004)])
def test_a_gripper_lowered_off_the_hole_rests_on_the_face_and_jams_saying_so(
        make_plant, sim, offset):
    plant = make_plant()
    state, node = descend(plant, sim, offset, depth=0.003)
    shoulder = state.poses['b'].position - node
    # held on the face by its screw: not through it, however hard the joints push
    assert shoulder[2] == pytest.approx(SCREW_LENGTH, abs=3e-4)
    assert plant.contacts and plant.contacts[0].force[2] > 0.0
    outcome = plant.screw_in('b')
    assert not outcome.success and outcome.status.mode == GripperState.JAMMED
    assert f'resting on the face of node {sim.start.other_node}' in outcome.status.message
    assert f'{shoulder[2] * 1e3:.2f} mm above its mouth' in outcome.status.message


@pytest.mark.parametrize('offset', [(0.0015, 0.0), (-0.0015, 0.0), (0.0, 0.0015)])
def test_a_gripper_lowered_within_the_chamfer_is_guided_into_the_hole_and_screws_in(
        make_plant, sim, geometry, offset):
    plant = make_plant()
    state, node = descend(plant, sim, offset, depth=0.003)
    shoulder = state.poses['b'].position - node
    assert np.hypot(*shoulder[:2]) <= geometry.bore_radius + 1e-4  # in the bore
    assert shoulder[2] == pytest.approx(0.0, abs=3e-4)  # resting on the mouth
    outcome = plant.screw_in('b')
    assert outcome.success, outcome.status.message
    plant.step(np.zeros(5), plant.params.gripper.screw_time + PERIOD)
    assert plant.gripper_status('b').mode == GripperState.ATTACHED


@pytest.mark.parametrize('height_error', [-0.0015, 0.0015])
def test_the_face_is_where_the_node_really_is(make_plant, sim, monkeypatch, height_error):
    node = sim.start.other_node
    placed = NodePlacement.__init__

    def one_node_off_in_height(self, names, standard_deviation, seed):
        placed(self, names, standard_deviation, seed)
        self._errors = {node: (0.0, 0.0, height_error)}

    # the true truss: one node off its place in height only
    monkeypatch.setattr(NodePlacement, '__init__', one_node_off_in_height)
    plant = make_plant()
    state, mouth = descend(plant, sim, (0.004, 0.0), depth=0.003 + max(0.0, -height_error))
    assert mouth[2] == pytest.approx(height_error)
    assert state.poses['b'].position[2] - mouth[2] == pytest.approx(SCREW_LENGTH, abs=3e-4)


def total_energy(plant):
    """Return the robot's energy and the energy stored in the contact springs [J]."""
    return plant.energy() + sum(0.5 * CONTACT_STIFFNESS * c.depth ** 2 for c in plant.contacts)


def test_a_gripper_striking_the_face_never_gains_energy(make_plant, sim):
    """Stability of the stiff contact on the flexible zero-gravity plant at 1 kHz."""
    plant = make_plant()
    state = plant.reset(start(sim, height=0.006))
    plant.enable_friction(False)
    base = plant.node_position(sim.start.base_node)
    node = plant.node_position(sim.start.other_node)
    # thrown at the face off the hole (0.08 m/s towards it, 0.3 m/s in all), then coasting
    point = node - base + np.array([0.004, 0.0, 0.006])
    goal = np.array(plant.kinematics.inverse([*(point - [0.0, 0.0, 0.03]), 0.0, 0.0]))
    while state.poses['b'].position[2] - node[2] > SCREW_LENGTH + 0.002:
        state = plant.step(2000.0 * (goal - plant.true_joint_positions()), PERIOD)
    thrown = total_energy(plant)
    assert thrown > 1e-3
    energies, heights = [], []
    for _ in range(round(1.0 / PERIOD)):
        state = plant.step(np.zeros(5), PERIOD)
        energies.append(total_energy(plant))
        if plant.contacts:
            heights.append(state.poses['b'].position[2] - node[2])
    assert heights, 'the gripper never reached the face'
    assert max(energies) <= thrown * 1.001
    assert min(heights) > SCREW_LENGTH - 1e-3  # held by the face, not through it


def test_a_motion_clear_of_every_node_is_the_same_with_and_without_contact(
        make_plant, sim):
    records = []
    for enabled in (True, False):
        plant = make_plant(start(sim, height=0.03))
        plant.enable_contact(enabled)
        torque = np.array([0.0, -3.0, -3.0, 0.0, 0.0])
        states = [plant.step(torque, PERIOD) for _ in range(200)]
        records.append(np.array([np.r_[s.position, s.velocity, s.poses['b'].position]
                                 for s in states]))
    np.testing.assert_array_equal(records[0], records[1])
