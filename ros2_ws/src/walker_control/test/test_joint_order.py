"""A controller reads its joints by name, whatever order a message lists them in."""

from walker_control.core.joint_order import JointOrder
from walker_core.joint_roles import PHYSICAL_JOINT_NAMES


def test_the_indices_follow_the_names_of_the_message():
    order = JointOrder(['vertex_joint', 'a_yaw_joint'])
    names = list(reversed(PHYSICAL_JOINT_NAMES))
    assert order.check_state(names, 5, 5) == ''
    assert [names[i] for i in order.physical] == list(PHYSICAL_JOINT_NAMES)
    assert [names[i] for i in order.own] == ['vertex_joint', 'a_yaw_joint']


def test_a_state_lacking_a_joint_or_a_velocity_is_refused_and_changes_nothing():
    order = JointOrder(['vertex_joint'])
    assert order.check_state(PHYSICAL_JOINT_NAMES, 5, 5) == ''
    before = (list(order.physical), list(order.own))
    reason = order.check_state(PHYSICAL_JOINT_NAMES[:4], 4, 4)
    assert 'lacks b_yaw_joint' in reason
    assert (order.physical, order.own) == before
    assert 'a position and a velocity per joint' in order.check_state(PHYSICAL_JOINT_NAMES, 5, 4)


def test_an_acceleration_message_without_a_joint_gives_minus_one_for_it():
    order = JointOrder(['vertex_joint', 'b_yaw_joint'])
    assert order.acceleration_indices(['b_yaw_joint', 'a_yaw_joint']) == [-1, 0]
