"""The phase progress: from zero to one through each phase, never back.

Each test drives the sequencer through a step in ``sequencer_world``'s ideal world.
"""

import itertools

import pytest

from sequencer_world import TRUSS, World
from walker_supervisor.core.phases import Phase
from walker_supervisor.core.route import possible_steps


def _record_progress(world):
    """Return the list the world's ticks append (phase, phase progress) to."""
    seen = []
    tick = world.sequencer.tick

    def recording_tick(now, *args):
        commands = tick(now, *args)
        seen.append((world.sequencer.phase, world.sequencer.phase_progress(now)))
        return commands

    world.sequencer.tick = recording_tick
    return seen


def test_the_phase_progress_grows_from_zero_to_one_through_each_phase():
    """``StepPhase.phase_progress``: by the planned durations, and by the tip error in FINE.

    Here the screw actions take ``screw_time`` and every motion its planned 1 s, so the timed
    phases end as planned: EXTRACTION (unscrewing, then the lift planned ahead) reaches 1 as
    it ends, COARSE nearly (it ends in the coarse-to-fine region), INSERTION (the descent, the
    dwell at the mouth, the screw-in) with the screw-in. The values never decrease within a
    phase.
    """
    world = World(gripper_delay=0.5)
    seen = _record_progress(world)
    assert world.sequencer.phase_progress(0.0) == 0.0  # IDLE
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert outcome.success, outcome.message
    runs = [(phase, [v for _, v in group]) for phase, group in
            itertools.groupby(seen, key=lambda entry: entry[0])]
    assert [phase for phase, _ in runs][:4] == [Phase.EXTRACTION, Phase.COARSE, Phase.FINE,
                                                 Phase.INSERTION]
    for phase, values in runs:
        assert all(0.0 <= v <= 1.0 for v in values), (phase, values)
        assert values == sorted(values), (phase, values)
        if phase == Phase.IDLE:
            assert set(values) == {0.0}
    timed = dict(runs[:4])
    # by time: about half way at the middle tick, full at the end (within a tick or two: the
    # sequencer sees an end at the tick after it); COARSE hands over to FINE as the tip enters
    # the coarse-to-fine region, a little before its plan's end
    for phase, end in ((Phase.EXTRACTION, 0.98), (Phase.COARSE, 0.9), (Phase.INSERTION, 0.98)):
        values = timed[phase]
        assert values[0] < 0.1 and values[-1] > end, (phase, values[0], values[-1])
        assert values[len(values) // 2] == pytest.approx(0.5, abs=0.1), (phase, values)
    # FINE by the error: ideal tracking brings the tip exactly over the hole
    assert timed[Phase.FINE][-1] == 1.0


def test_a_phase_that_runs_over_its_plan_stays_at_full_progress():
    # joint 1 stops 45 mm short, outside the coarse-to-fine region: COARSE waits for the arm
    # to settle after its planned end, then hands over to a fine line
    world = World(gripper_delay=0.5, coarse_miss=0.05)
    seen = _record_progress(world)
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert outcome.success, outcome.message
    coarse = [v for phase, v in seen if phase == Phase.COARSE]
    assert coarse == sorted(coarse)
    assert coarse.count(1.0) >= 5, coarse[-8:]  # the overrun: settle_time, 10 ticks
