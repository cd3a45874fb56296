"""The planner's setpoints handed to controllers in the same process by call."""

import threading

from builtin_interfaces.msg import Time

from walker_control.joint_channel import seconds
from walker_control.setpoint_handover import SetpointHandover, stamp_seconds
from walker_core.joint_roles import PHYSICAL_JOINT_NAMES


def test_each_setpoint_reaches_its_joint_with_the_stamp_its_message_would_give():
    joints = ['vertex_joint', 'a_yaw_joint']
    handover = SetpointHandover(joints, wake=lambda: None)
    positions = [0.1 * (j + 1) for j in range(5)]
    velocities = [1.0 * (j + 1) for j in range(5)]
    accelerations = [10.0 * (j + 1) for j in range(5)]
    stamp = 7_123_456_789  # [ns]
    handover.push(stamp, positions, velocities, accelerations)
    handover.push(stamp + 2_000_000, positions, velocities, accelerations)
    taken = []
    assert handover.take_into(lambda *args: taken.append(args)) == 2
    message_seconds = seconds(Time(sec=7, nanosec=123_456_789))
    assert stamp_seconds(stamp) == message_seconds  # bit for bit, as the node reads it
    vertex, a_yaw = (PHYSICAL_JOINT_NAMES.index(joint) for joint in joints)
    assert taken[:2] == [
        (0, message_seconds, positions[vertex], velocities[vertex], accelerations[vertex]),
        (1, message_seconds, positions[a_yaw], velocities[a_yaw], accelerations[a_yaw])]
    assert [row[1] for row in taken[2:]] == [stamp_seconds(stamp + 2_000_000)] * 2
    assert handover.take_into(lambda *args: taken.append(args)) == 0


def test_a_push_from_another_thread_wakes_the_loop_and_one_from_its_own_does_not():
    woken = []
    handover = SetpointHandover(PHYSICAL_JOINT_NAMES, wake=lambda: woken.append(1))
    zeros = [0.0] * 5
    handover.take_into(lambda *args: None)  # this thread takes: the loop's
    handover.push(1, zeros, zeros, zeros)
    assert woken == []
    other = threading.Thread(target=handover.push, args=(2, zeros, zeros, zeros))
    other.start()
    other.join()
    assert woken == [1]
    assert handover.take_into(lambda *args: None) == 2
