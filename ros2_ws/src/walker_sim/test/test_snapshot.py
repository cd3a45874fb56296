"""A plant started again restores the physical state the killed one had, never its start pose."""

import dataclasses

import numpy as np
import pytest

from walker_core.gripper_state import GripperState
from walker_sim.core.plant import PlantError
from walker_sim.core.snapshot import (
    PlantSnapshot, SnapshotError, SnapshotSchedule, read_snapshot, write_snapshot)

DT = 0.002  # [s] one control period
TORQUES = np.array([0.3, -0.2, 0.25, 0.1, -0.15])  # [N*m]


def _run(plant, seconds: float, torques=TORQUES):
    for _ in range(round(seconds / DT)):
        state = plant.step(torques, DT)
    return state


def _assert_same(restored, original, tolerance=1e-9):
    assert restored.time == pytest.approx(original.time, abs=1e-12)
    assert restored.base == original.base
    np.testing.assert_allclose(restored.position, original.position, atol=tolerance)
    np.testing.assert_allclose(restored.velocity, original.velocity, atol=tolerance)
    for gripper in 'ab':
        assert restored.statuses[gripper].mode == original.statuses[gripper].mode
        assert restored.statuses[gripper].node == original.statuses[gripper].node
        np.testing.assert_allclose(restored.poses[gripper].position,
                                   original.poses[gripper].position, atol=tolerance)


def test_a_restored_plant_has_the_state_of_the_old_one_mid_unscrew_and_moves_on_alike(
        make_plant, tmp_path):
    original = make_plant()
    state = _run(original, 0.2)
    tip = state.tip
    assert state.statuses[tip].mode == GripperState.ATTACHED
    original.unscrew(tip)
    state = _run(original, 0.1, np.zeros(5))
    assert state.statuses[tip].mode == GripperState.UNSCREWING
    write_snapshot(tmp_path / 'plant.json', original.snapshot())

    restarted = make_plant()
    assert not np.allclose(restarted.state().position, state.position)  # at its start pose
    restored = restarted.restore(read_snapshot(tmp_path / 'plant.json'))
    _assert_same(restored, state)
    assert restored.statuses[tip].progress == pytest.approx(state.statuses[tip].progress)
    # the unscrew goes on where it was; the free tip then moves as the old plant's would
    screw_time = original.params.gripper.screw_time
    later, later_restored = (_run(p, screw_time) for p in (original, restarted))
    assert later.statuses[tip].mode == GripperState.FREE
    _assert_same(later_restored, later, tolerance=1e-6)


def test_a_plant_restored_after_the_base_changed_grippers_holds_where_the_old_one_did(
        make_plant, tmp_path):
    """The walker re-rooted at its other gripper (a step taken) is restored rooted there."""
    original = make_plant()
    first = original.state()
    base, tip = first.base, first.tip
    original.unscrew(base)
    state = _run(original, original.params.gripper.screw_time + 0.1, np.zeros(5))
    assert state.base == tip and state.statuses[base].mode == GripperState.FREE
    _run(original, 0.1)
    state = original.state()
    path = tmp_path / 'plant.json'
    write_snapshot(path, original.snapshot())
    restored = make_plant().restore(read_snapshot(path))
    _assert_same(restored, state)
    assert restored.statuses[base].mode == GripperState.FREE and restored.base == tip


def test_a_snapshot_of_another_model_or_truss_is_refused_and_changes_nothing(make_plant):
    plant = make_plant()
    good = plant.snapshot()
    before = plant.state()
    bad = [dataclasses.replace(good, positions=good.positions[:-1],
                               velocities=good.velocities[:-1]),
           dataclasses.replace(good, grippers={**good.grippers, 'a': {
               **good.grippers['a'], 'node': 'n99_99'}}),
           dataclasses.replace(good, grippers={**good.grippers, 'a': {
               **good.grippers['a'], 'mode': 'LOOSE'}}),
           dataclasses.replace(good, holds={})]
    for snapshot in bad:
        with pytest.raises(PlantError, match='snapshot'):
            plant.restore(snapshot)
    _assert_same(plant.state(), before)


def test_a_missing_snapshot_reads_as_none_and_a_garbled_one_is_refused(tmp_path):
    assert read_snapshot(tmp_path / 'none.json') is None
    (tmp_path / 'bad.json').write_text('{"version": 1, "root"')
    with pytest.raises(SnapshotError, match='not JSON'):
        read_snapshot(tmp_path / 'bad.json')
    with pytest.raises(SnapshotError, match='lacks'):
        PlantSnapshot.from_dict({'version': 1, 'root': 'a'})


def test_the_snapshot_is_written_at_its_period_and_at_once_on_a_gripper_change():
    schedule = SnapshotSchedule(period=0.1)
    assert schedule.due(0.0, 'attached')
    assert not schedule.due(0.05, 'attached')
    assert schedule.due(0.06, 'unscrewing')  # a gripper change does not wait
    assert not schedule.due(0.1, 'unscrewing')
    assert schedule.due(0.16, 'unscrewing')
    with pytest.raises(ValueError, match='period'):
        SnapshotSchedule(period=0.0)
