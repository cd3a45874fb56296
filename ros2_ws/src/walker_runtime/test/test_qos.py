"""The topics' QoS profiles: what docs/architecture.md gives each kind of topic."""

import pytest
from rclpy.qos import DurabilityPolicy, HistoryPolicy, ReliabilityPolicy

from walker_runtime.qos import (
    CLOCK_QOS, COMMAND_QOS, LATCHED_QOS, MODE_QOS, MODE_SUBSCRIPTION_QOS, SENSOR_QOS,
    latched_qos)


@pytest.mark.parametrize('profile, reliability, durability, depth', [
    (SENSOR_QOS, ReliabilityPolicy.BEST_EFFORT, DurabilityPolicy.VOLATILE, 1),
    (COMMAND_QOS, ReliabilityPolicy.RELIABLE, DurabilityPolicy.VOLATILE, 10),
    (LATCHED_QOS, ReliabilityPolicy.RELIABLE, DurabilityPolicy.TRANSIENT_LOCAL, 1),
    (MODE_QOS, ReliabilityPolicy.RELIABLE, DurabilityPolicy.TRANSIENT_LOCAL, 1),
    (MODE_SUBSCRIPTION_QOS, ReliabilityPolicy.RELIABLE, DurabilityPolicy.TRANSIENT_LOCAL, 10),
    (CLOCK_QOS, ReliabilityPolicy.RELIABLE, DurabilityPolicy.VOLATILE, 1),
])
def test_each_kind_of_topic_has_the_documented_profile(profile, reliability, durability,
                                                       depth):
    assert profile.reliability == reliability
    assert profile.durability == durability
    assert profile.history == HistoryPolicy.KEEP_LAST
    assert profile.depth == depth


def test_a_latched_history_keeps_the_depth_asked_for():
    profile = latched_qos(20)
    assert (profile.depth, profile.durability, profile.reliability) == (
        20, DurabilityPolicy.TRANSIENT_LOCAL, ReliabilityPolicy.RELIABLE)


@pytest.mark.parametrize('depth', [0, -1, 1.5, True, None])
def test_a_latched_history_of_no_message_is_refused(depth):
    with pytest.raises(ValueError, match='at least one message'):
        latched_qos(depth)


def test_the_nodes_share_the_profiles():
    """A publisher and its subscribers take one definition: they cannot drift apart."""
    from walker_control import joint_channel
    from walker_planner import planner_node, setpoints
    from walker_sim import messages
    from walker_supervisor import inputs, supervisor_node
    assert joint_channel.STATE_QOS is SENSOR_QOS is messages.SENSOR_QOS
    assert joint_channel.COMMAND_QOS is COMMAND_QOS is messages.COMMAND_QOS \
        is setpoints.COMMAND_QOS
    assert joint_channel.MODE_QOS is MODE_QOS is supervisor_node.MODE_QOS
    assert joint_channel.MODE_SUBSCRIPTION_QOS is MODE_SUBSCRIPTION_QOS \
        is planner_node.MODE_SUBSCRIPTION_QOS is inputs.MODE_SUBSCRIPTION_QOS
