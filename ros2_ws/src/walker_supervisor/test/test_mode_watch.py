"""A controller in a mode nobody commanded: corrected at once, reported, held if it persists."""

import pytest

from runner_world import SETTINGS, World
from walker_supervisor.core.commands import SetControlMode
from walker_supervisor.core.controller_watch import (
    MODE_REPORT_GRACE, TELL_MODE_AGAIN_PERIOD, ControllerReport, ControllerWatch)
from walker_supervisor.core.health import Level
from walker_supervisor.core.phases import Phase


def _watch(mode='hold', base='a', at=0.0):
    watch = ControllerWatch()
    watch.commanded(SetControlMode(mode, base), at)
    return watch


def test_a_mode_nobody_commanded_is_named_and_the_commanded_mode_sent_again():
    watch = _watch('hold')
    late = MODE_REPORT_GRACE + 0.01
    rogue = ControllerReport(late, False, False, 'coarse', 1)
    assert watch.disagreement('a_yaw_joint', rogue) == \
        'in mode COARSE, commanded HOLD by this supervisor'
    assert 'COARSE' in watch.trouble(rogue, False, 'a_yaw_joint')
    out = watch.unexpected_modes({'a_yaw_joint': rogue}, late, 10.0)
    assert out[-1] == SetControlMode('hold', 'a') and 'a_yaw_joint' in out[0].message
    # not again within the period, and again after it; the mismatch is timed from its start
    assert watch.unexpected_modes({'a_yaw_joint': rogue}, late, 10.1) == []
    rogue = ControllerReport(1.0, False, False, 'coarse', 1)
    again = watch.unexpected_modes({'a_yaw_joint': rogue}, 1.0, 10.0 + TELL_MODE_AGAIN_PERIOD)
    assert again[-1] == SetControlMode('hold', 'a')
    assert watch.mismatch_lasted(11.0, 1.0) and not watch.mismatch_lasted(10.9, 1.0)
    # a report that agrees ends it
    watch.unexpected_modes({'a_yaw_joint': ControllerReport(2.0, False, True, 'hold', 1)},
                           2.0, 11.5)
    assert watch.mismatch_since is None


def test_a_new_mode_commanded_ends_the_disagreement_with_the_old_one():
    """Resumed in FINE after controllers lingered in FINE under a HOLD: no hold for that."""
    watch = _watch('hold')
    lingering = ControllerReport(MODE_REPORT_GRACE + 0.01, False, False, 'fine', 2)
    watch.unexpected_modes({'a_pitch_joint': lingering}, 1.0, 10.0)
    assert watch.mismatch_since == 10.0
    watch.commanded(SetControlMode('hold', 'a'), 1.0)  # a correction: the clock runs on
    assert watch.mismatch_lasted(11.0, 1.0)
    watch.commanded(SetControlMode('fine', 'a'), 1.2)  # the resume, before 1 s had passed
    assert not watch.mismatch_lasted(11.4, 1.0)
    # reports from within the grace after the command cannot tell: still no hold
    early = ControllerReport(1.25, False, False, 'hold', 2)
    assert watch.unexpected_modes({'a_pitch_joint': early}, 1.25, 11.5) == []
    assert not watch.mismatch_lasted(11.5, 1.0)


@pytest.mark.parametrize('report', [
    ControllerReport(0.05, False, False, 'coarse', 1),   # just after the command: not yet
    ControllerReport(1.0, True, True, 'hold', 1),        # stale inputs: holding for that
    ControllerReport(1.0, False, True, 'hold', 1),       # a fallback to HOLD, not a mismatch
    ControllerReport(1.0, False, False),                 # a report that tells no mode
])
def test_what_is_no_disagreement(report):
    assert not _watch('coarse').disagreement('a_yaw_joint', report)
    assert ControllerWatch().disagreement('a_yaw_joint', report) is None  # nothing commanded


def test_a_controller_following_the_other_base_disagrees():
    watch = _watch('hold', 'a')
    assert watch.disagreement('a_yaw_joint', ControllerReport(1.0, False, True, 'hold', 5)) == \
        'in role J5, J1 with base a commanded by this supervisor'


def test_idle_a_controller_moved_to_coarse_is_put_back_at_once_and_reported():
    world = World()
    world.period()
    assert world.runner.controllers.mode == 'hold', 'idle, the controllers hold'
    world.run_until(lambda: world.now > 1.0)
    commands = len(world.of(SetControlMode))
    world.mode = 'coarse'  # another publisher's command, in the supervisor's name
    world.run_until(lambda: world.mode == 'hold', limit=1.0)
    assert world.of(SetControlMode)[commands:] == [SetControlMode('hold', 'a')]
    assert any('COARSE' in n and 'no command of this supervisor' in n for n in world.notices)
    assert any('COARSE' in s.message for s in world.runner.health.status(world.now))
    world.period()  # reported while it lasted, then OK
    assert all(s.level == Level.OK for s in world.runner.health.status(world.now))
    world.run_until(lambda: world.now > 4.0)
    assert Phase.SAFE_HOLD not in world.phases


def test_while_it_lasts_it_is_on_the_diagnostics_and_then_the_walker_holds():
    world = World()
    world.run_until(lambda: world.now > 1.0)
    world.rogue = 'coarse'  # the other publisher keeps writing
    world.run_until(lambda: world.now > 1.0 + 2 * MODE_REPORT_GRACE)
    troubled = [s for s in world.runner.health.status(world.now) if s.level == Level.WARN]
    assert troubled and all('COARSE' in s.message for s in troubled)
    assert Phase.SAFE_HOLD not in world.phases
    world.run_until(lambda: Phase.SAFE_HOLD in world.phases,
                    limit=SETTINGS.mode_mismatch_hold_time + 1.0)
    assert 'did not command' in world.runner.sequencer.reason
