"""Effort commands at the plant: newest per joint, drive watchdog, the sim-time lock-step."""

import math

import numpy as np
import pytest

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_sim.core.commands import (
    CommandError, DecisionGate, EffortCommands, LockStep, seconds_to_ns)

MS = 1_000_000  # [ns]


def answer_all(commands, stamp, effort=1.0, joints=PHYSICAL_JOINT_NAMES):
    for joint in joints:
        commands.receive(joint, effort, stamp)


def test_the_newest_command_of_each_joint_is_applied():
    commands = EffortCommands(command_timeout=0.1)
    commands.receive('vertex_joint', 2.0, 4 * MS)
    commands.receive('vertex_joint', 3.0, 6 * MS)
    commands.receive('vertex_joint', 9.0, 2 * MS)  # answers an older state: stale, ignored
    torques, expired = commands.torques(6 * MS)
    assert torques[2] == 3.0 and expired == []
    assert commands.stamp_of('vertex_joint') == 6 * MS


def test_joints_that_never_spoke_get_zero_torque():
    commands = EffortCommands(command_timeout=0.1)
    commands.receive('a_yaw_joint', 1.5, 0)
    torques, _ = commands.torques(0)
    np.testing.assert_array_equal(torques, [1.5, 0, 0, 0, 0])


def test_a_command_older_than_the_timeout_is_dropped_like_a_drive_watchdog():
    commands = EffortCommands(command_timeout=0.1)
    answer_all(commands, 0, effort=2.0)
    torques, expired = commands.torques(seconds_to_ns(0.1))
    assert np.all(torques == 2.0) and expired == []
    torques, expired = commands.torques(seconds_to_ns(0.1) + 1)
    assert np.all(torques == 0.0) and expired == list(PHYSICAL_JOINT_NAMES)


def test_unknown_joints_are_refused_by_name():
    with pytest.raises(CommandError, match="unknown joint 'elbow'"):
        EffortCommands(0.1).receive('elbow', 1.0, 0)


def test_a_non_finite_effort_still_answers_the_state():
    commands = EffortCommands(0.1)
    commands.receive('a_yaw_joint', math.nan, 2 * MS)
    assert commands.answered(2 * MS) == {'a_yaw_joint'}


def test_lock_step_waits_for_all_five_answers_to_the_current_stamp():
    commands, lockstep = EffortCommands(0.1), LockStep(timeout=1.0)
    lockstep.begin(2 * MS, wall_now=0.0)
    answer_all(commands, 0)  # answers to the previous state do not count
    assert lockstep.waiting_for(commands) == list(PHYSICAL_JOINT_NAMES)
    answer_all(commands, 2 * MS, joints=PHYSICAL_JOINT_NAMES[:4])
    assert lockstep.waiting_for(commands) == ['b_yaw_joint']
    assert not lockstep.ready(commands)
    commands.receive('b_yaw_joint', 0.0, 2 * MS)
    assert lockstep.ready(commands)
    assert lockstep.count_misses(commands) == []


def test_a_joint_that_times_out_is_not_waited_for_until_it_answers_again():
    commands, lockstep = EffortCommands(1.0), LockStep(timeout=0.5)
    lockstep.begin(0, wall_now=9.0)
    answer_all(commands, 0)
    assert lockstep.ready(commands)
    # b_yaw's controller stops answering
    lockstep.begin(2 * MS, wall_now=10.0)
    answer_all(commands, 2 * MS, joints=PHYSICAL_JOINT_NAMES[:4])
    assert not lockstep.expired(10.4) and lockstep.expired(10.5)
    assert lockstep.give_up(commands) == ['b_yaw_joint']
    assert lockstep.missed['b_yaw_joint'] == 1 and lockstep.timeouts == 1
    # next step: the four others suffice, the lost joint's period is counted as missed
    lockstep.begin(4 * MS, wall_now=10.6)
    answer_all(commands, 4 * MS, joints=PHYSICAL_JOINT_NAMES[:4])
    assert lockstep.ready(commands)
    assert lockstep.count_misses(commands) == ['b_yaw_joint']
    assert lockstep.missed['b_yaw_joint'] == 2
    # it answers a current state again: waited for from now on
    lockstep.begin(6 * MS, wall_now=10.7)
    commands.receive('b_yaw_joint', 0.0, 6 * MS)
    assert lockstep.waiting_for(commands) == list(PHYSICAL_JOINT_NAMES[:4])
    assert lockstep.lost == set()


MS = 1_000_000  # [ns]


def test_the_gate_lets_everything_through_until_the_supervisor_first_releases():
    gate = DecisionGate(timeout=0.25)
    assert gate.allows(10**12)
    gate.release(20 * MS)
    assert gate.allows(20 * MS) and not gate.allows(22 * MS)
    gate.release(40 * MS)  # its next tick decided
    assert gate.allows(40 * MS) and not gate.allows(42 * MS)


def test_a_gate_waited_at_for_its_timeout_is_dropped_until_the_next_release():
    gate = DecisionGate(timeout=0.25)
    gate.release(20 * MS)
    gate.wait(100.0)
    gate.wait(100.2)  # still the same wait: it began at 100.0
    assert not gate.expired(100.2) and gate.expired(100.25)
    gate.drop()
    assert gate.allows(10**12) and gate.timeouts == 1  # a dead supervisor stops nothing
    gate.release(60 * MS)  # it speaks again: waited for again, the wait afresh
    assert not gate.allows(62 * MS)
    gate.wait(200.0)
    assert not gate.expired(200.1)


def test_an_opened_gate_lets_everything_through_and_counts_no_timeout():
    gate = DecisionGate(timeout=0.25)
    gate.release(20 * MS)
    gate.wait(100.0)
    gate.open()  # sim.wait_for_decisions turned off while the plant waited
    assert gate.allows(10**12) and gate.timeouts == 0
    gate.release(60 * MS)  # turned on again: the next release holds again
    assert not gate.allows(62 * MS) and not gate.expired(100.3)
