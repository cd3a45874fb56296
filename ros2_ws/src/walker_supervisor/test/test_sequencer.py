"""The step-phase state machine, driven by a simulated world with ideal joint tracking."""

import dataclasses
import itertools
import math

import numpy as np
import pytest

from walker_core.kinematics import KinematicsError, WalkerKinematics
from walker_core.parameter_schema import ParameterError
from walker_core.robot_parameters import load_walker_parameters
from walker_core.truss import Truss
from walker_supervisor.core.route import PlannedStep, Stance, plan_route, possible_steps
from walker_supervisor.core.sequencer import (
    MAX_FINE_LINES, STANCE_MARGIN, CancelTrajectory, GripperRequest, Notice, Phase,
    PrepareTrajectory, SequencerError, SetControlMode, StepSequencer, SupervisorParameters,
    TrajectoryRequest)
from walker_supervisor.core.step_geometry import (
    BaseFrame, measure_step_targets, plan_step_targets)

PARAMS = load_walker_parameters()
KIN = WalkerKinematics.from_parameters(PARAMS)
TRUSS = Truss.from_parameters(PARAMS)
SUPERVISOR = SupervisorParameters(coarse_to_fine_region=0.03, insertion_alignment=0.001,
                                  settle_velocity=0.02, settle_time=0.1, phase_timeout=5.0,
                                  max_insertion_attempts=3, watchdog_timeout=1.0,
                                  coarse_start_tolerance=0.02, relaxation_wait=0.3,
                                  mouth_settle_time=0.1, descent_region=0.002,
                                  descent_axis_tolerance=0.005, descent_arrival_time=0.02,
                                  sweep_lead=0.0)
DT = 0.01
START = Stance('a', 'n1_1', 'n2_1')


class World:
    """Executes the sequencer's commands: ideal tracking, scripted gripper results."""

    def __init__(self, stance=START, jams=0, refuse_unscrew=False,
                 stall_trajectories=False, coarse_miss=0.0, gripper_delay=0.0,
                 gripper_never=False, lift_lag=None, jam_seen_first=False, stale_states=0.0,
                 descent_miss=0.0, mouth_lines_miss=False, coarse_plan_delay=0.0,
                 descent_runaway=(0.0, 0)):
        self.stance = stance
        # [s] the coarse motion asked ahead is planned this late (inf: its plan is refused)
        self.coarse_plan_delay = coarse_plan_delay
        self.plans_due = []  # (time, purpose) of plans asked ahead and not answered yet
        self.requested = []  # (time, request) of every trajectory request
        # (joint, lag [rad], time [s]): after the extraction line's stream ends, that joint is
        # still ``lag`` short of the line's end, and catches up only ``time`` later
        self.lift_lag = lift_lag
        self.lagging = None
        self.jam_seen_first = jam_seen_first  # the jammed state arrives before the answer
        # [s] a screw-in's first state change reaches the sequencer this late (a starved
        # process in real time): until then it still sees the previous attempt's state
        self.stale_states = stale_states
        self.late_answers = []
        self.sequencer = StepSequencer(SUPERVISOR, KIN, stance.base_gripper)
        self.now = 0.0
        base, other = TRUSS.position(stance.base_node), TRUSS.position(stance.other_node)
        frame_guess = KIN.inverse([0.0, TRUSS.spacing, 0.0, 0.0, 0.0])
        self.theta = frame_guess
        self.grippers = {'a': 'attached', 'b': 'attached'}
        self.frame = BaseFrame.from_stance(KIN, self.theta, base, other)
        self.jams, self.refuse_unscrew, self.stall = jams, refuse_unscrew, stall_trajectories
        self.coarse_miss = coarse_miss  # [rad] J1 stops this short of the coarse goal
        self.descent_miss = descent_miss  # [rad] J1 stops this short of the descent's end
        self.mouth_lines_miss = mouth_lines_miss  # lines at the mouth stop as short
        # ([rad], n): in the first n descents J1 runs this far off as the gripper goes down
        self.runaway, self.runaway_descents = descent_runaway
        self.gripper_delay = gripper_delay  # [s] screwing/unscrewing time the plant takes
        self.gripper_never = gripper_never  # the plant accepts but never completes
        self.pending = []  # (time, gripper, state) changes the plant will report
        self.log = []
        self.phases = []
        self.stages = []  # (time [s], stage) at every tick
        self.motion = None
        self.joined = []  # (time, phase, lift fraction, sweep fraction) of a joined motion

    def run_step(self, step, max_time=60.0):
        targets = plan_step_targets(KIN, self.frame, step, TRUSS.position(step.from_node),
                                    TRUSS.position(step.to_node), self.theta,
                                    PARAMS.gripper.approach_height)
        self.targets = targets
        self.execute(self.sequencer.start(step, targets, self.now, dict(self.grippers)))
        while self.sequencer.busy and self.now < max_time:
            self.advance()
        return self.sequencer.outcome

    def execute(self, commands):
        for command in commands:
            self.log.append(command)
            if isinstance(command, GripperRequest):
                self.gripper(command)
            elif isinstance(command, TrajectoryRequest):
                self.requested.append((self.now, command))
                if command.then is None:  # every motion takes 1 s
                    self.motion = [command, self.now, 1.0]
                    self.sequencer.trajectory_started(1.0, self.now)
                else:  # the second starts command.lead before the first ends
                    self.motion = [command, self.now, 2.0 - command.lead]
                    self.sequencer.trajectory_started(2.0 - command.lead, self.now, 1.0)
            elif isinstance(command, CancelTrajectory):
                if self.motion is not None and self.motion[0].purpose == 'insertion':
                    self.runaway_descents -= self.runaway_descents > 0
                self.motion = None
            elif isinstance(command, PrepareTrajectory):  # planned at once, 1 s like any motion
                purpose = command.request.purpose
                if purpose == 'coarse' and self.coarse_plan_delay == math.inf:
                    self.sequencer.motion_not_planned(purpose)
                elif purpose == 'coarse' and self.coarse_plan_delay > 0.0:
                    self.plans_due.append((self.now + self.coarse_plan_delay, purpose))
                else:
                    self.sequencer.motion_planned(purpose, 1.0)

    def gripper(self, request):
        assert not (request.action == 'unscrew'
                    and self.grippers[_other(request.gripper)] != 'attached'), \
            'released a gripper while the other was not attached'
        if request.action == 'unscrew':
            if self.refuse_unscrew:
                self.execute(self.sequencer.gripper_done(False, 'interlock', self.now))
                return
            self.grippers[request.gripper] = 'unscrewing'
            self.later(request.gripper, 'free')
            self.execute(self.sequencer.gripper_done(True, '', self.now))
        else:
            if self.jams > 0:
                self.jams -= 1
                if self.jam_seen_first:
                    self.grippers[request.gripper] = 'jammed'
                    self.late_answers.append('jammed 3 mm off')
                    return
                self.execute(self.sequencer.gripper_done(False, 'jammed 3 mm off', self.now))
                return
            if self.stale_states:
                self.pending.append((self.now + self.stale_states, request.gripper, 'screwing'))
            else:
                self.grippers[request.gripper] = 'screwing'
            self.later(request.gripper, 'attached')
            self.execute(self.sequencer.gripper_done(True, '', self.now))

    def later(self, gripper, state):
        if not self.gripper_never:
            self.pending.append((self.now + self.gripper_delay, gripper, state))

    def advance(self):
        self.now += DT
        for change in [c for c in self.pending if c[0] <= self.now]:
            self.pending.remove(change)
            self.grippers[change[1]] = change[2]
        for due in [p for p in self.plans_due if p[0] <= self.now + 1e-9]:
            self.plans_due.remove(due)
            self.sequencer.motion_planned(due[1], 1.0)
        velocities = np.zeros(5)
        if self.motion is not None and not self.stall:
            request, started, duration = self.motion
            fraction = min(1.0, (self.now - started) / duration)
            previous = self.theta
            goal = request.goal.copy()
            if request.purpose == 'coarse':
                goal[0] -= self.coarse_miss * math.copysign(1.0, request.sweep)
            at_mouth = request.purpose == 'fine' and np.allclose(request.goal_point,
                                                                 self.targets.point_to)
            if request.purpose == 'insertion' or (at_mouth and self.mouth_lines_miss):
                goal[0] -= self.descent_miss
            runaway = request.purpose == 'insertion' and self.runaway_descents > 0
            if runaway:
                goal[0] -= self.runaway
            if request.then is None:
                self.theta = request.start + fraction * (goal - request.start)
            else:
                elapsed = self.now - started
                lift = min(1.0, elapsed)
                sweep = float(np.clip(elapsed - (1.0 - request.lead), 0.0, 1.0))
                then_goal = request.then.goal.copy()
                then_goal[0] -= self.coarse_miss * math.copysign(1.0, request.then.sweep)
                self.theta = (request.start + lift * (goal - request.start)
                              + sweep * (then_goal - request.then.start))
                self.joined.append((self.now, self.sequencer.phase, lift, sweep))
            velocities = (self.theta - previous) / DT
            if fraction >= 1.0 and request.purpose == 'extraction' and self.lift_lag:
                joint, lag, time_ = self.lift_lag
                self.lagging = (joint, goal[joint], self.now + time_)
                self.theta[joint] -= lag
                self.lift_lag = None
            if fraction >= 1.0:
                self.motion = None
                self.runaway_descents -= runaway
                self.execute(self.sequencer.trajectory_done(True, '', self.now))
        if self.lagging is not None and self.motion is None:
            joint, end, caught_up = self.lagging
            if self.now >= caught_up:
                self.theta[joint], self.lagging = end, None
        assert any(state == 'attached' for state in self.grippers.values())
        self.phases.append(self.sequencer.phase)
        self.stages.append((self.now, self.sequencer.stage))
        late, self.late_answers = self.late_answers, []  # sent before this tick's states
        self.execute(self.sequencer.tick(self.now, self.theta, velocities, dict(self.grippers)))
        for message in late:
            self.execute(self.sequencer.gripper_done(False, message, self.now))


def _other(gripper):
    return 'b' if gripper == 'a' else 'a'


@pytest.mark.parametrize('to_node', ['n1_2', 'n1_0', 'n0_1'])
def test_a_step_runs_the_four_phases_in_order_and_swaps_the_base(to_node):
    world = World()
    step = next(s for s in possible_steps(TRUSS, world.stance) if s.to_node == to_node)
    outcome = world.run_step(step)
    assert outcome.success, outcome.message
    order = [p for i, p in enumerate(world.phases) if i == 0 or world.phases[i - 1] != p]
    assert order[:4] == [Phase.EXTRACTION, Phase.COARSE, Phase.FINE, Phase.INSERTION]
    assert world.sequencer.phase == Phase.IDLE
    assert world.sequencer.base_gripper == 'b'
    assert world.log[-1] == SetControlMode('hold', 'b')
    assert world.grippers == {'a': 'attached', 'b': 'attached'}
    assert set(outcome.phase_durations) == {'extraction', 'coarse', 'fine', 'insertion'}
    assert outcome.insertion_error <= SUPERVISOR.insertion_alignment
    tip = KIN.forward(world.theta)[:3]
    np.testing.assert_allclose(world.frame.to_truss(tip), TRUSS.position(to_node), atol=1e-9)


def _leading_world(lead=0.3, **options):
    world = World(**options)
    world.sequencer = StepSequencer(dataclasses.replace(SUPERVISOR, sweep_lead=lead), KIN, 'a')
    return world


def test_with_a_sweep_lead_the_sweep_streams_with_the_lift_and_the_step_is_that_much_shorter():
    """The coarse motion starts ``sweep_lead`` before the lift ends, in one stream with it.

    EXTRACTION lasts as long as the lift, COARSE (and its controller mode) begins at the
    first tick after it, no second request is made for the coarse motion, and the step ends
    ``sweep_lead`` sooner than with the motions one after the other.
    """
    lead = 0.3
    step = possible_steps(TRUSS, START)[0]
    world = _leading_world(lead)
    outcome = world.run_step(step)
    assert outcome.success, outcome.message
    requests = [c for c in world.log if isinstance(c, TrajectoryRequest)]
    joined = [c for c in requests if c.then is not None]
    assert len(joined) == 1 and joined[0].purpose == 'extraction'
    assert joined[0].then.purpose == 'coarse' and joined[0].lead == lead
    assert joined[0].mode == 'coarse'  # commanded as the stream begins: Ka as the sweep does
    assert 'coarse' not in [c.purpose for c in requests]
    # both were asked for ahead as they stream, so both plans are taken and can be joined
    # ahead: the lift is not planned again as its gripper comes free
    prepared = [c.request for c in world.log if isinstance(c, PrepareTrajectory)]
    assert [r.purpose for r in prepared] == ['extraction', 'coarse', 'insertion']
    assert prepared[0].then.same_motion(prepared[1]) and prepared[0].lead == lead
    assert joined[0].same_motion(prepared[0]) and joined[0].then.same_motion(prepared[1])
    # the sweep moved while the phase was still EXTRACTION; COARSE from the lift's end
    assert any(phase == Phase.EXTRACTION and sweep > 0 for _, phase, _, sweep in world.joined)
    assert all(lift == 1.0 for _, phase, lift, _ in world.joined if phase == Phase.COARSE)
    lift_end = min(t for t, _, lift, _ in world.joined if lift == 1.0)
    coarse_start = min(t for t, phase, _, _ in world.joined if phase == Phase.COARSE)
    assert lift_end <= coarse_start <= lift_end + DT + 1e-9
    modes = [c.mode for c in world.log if isinstance(c, SetControlMode)]
    assert modes[:2] == ['hold', 'fine']  # FINE as the tip enters the region: no other
    order = [p for i, p in enumerate(world.phases) if i == 0 or world.phases[i - 1] != p]
    assert order[:4] == [Phase.EXTRACTION, Phase.COARSE, Phase.FINE, Phase.INSERTION]
    after = World()
    separate = after.run_step(step)
    assert separate.success, separate.message
    assert outcome.duration == pytest.approx(separate.duration - lead, abs=2 * DT + 1e-9)
    assert outcome.insertion_error <= SUPERVISOR.insertion_alignment


def test_a_motion_asked_ahead_serves_its_request_whatever_mode_and_company_it_streams_in():
    """The plan depends on the motion alone, not on the controller mode or what streams with it.

    A lift asked ahead serves the lift streamed alone (the sweep's plan refused) as well as
    the lift streamed with the sweep; another motion it does not serve.
    """
    step = possible_steps(TRUSS, START)[0]
    world = _leading_world(0.3, coarse_plan_delay=math.inf)
    assert world.run_step(step).success
    prepared = next(c.request for c in world.log if isinstance(c, PrepareTrajectory))
    lift = next(c for c in world.log if isinstance(c, TrajectoryRequest))
    assert prepared.then is not None and prepared.mode == 'coarse'
    assert lift.purpose == 'extraction' and lift.then is None and lift.mode == 'fine'
    assert lift.same_motion(prepared) and prepared.same_motion(lift)
    lower = dataclasses.replace(lift, goal_point=lift.goal_point - [0.0, 0.0, 1e-3])
    assert not lower.same_motion(prepared)
    assert not dataclasses.replace(lift, purpose='retry_lift').same_motion(prepared)
    without = World()
    assert without.run_step(step).success
    alone = next(c.request for c in without.log if isinstance(c, PrepareTrajectory))
    assert alone.then is None  # no sweep_lead: the lift is asked for alone


def _lift_start(world):
    """[s] When the lift was requested (it streams at once in the World)."""
    return next(t for t, request in world.requested if request.purpose == 'extraction')


def test_a_freed_gripper_waits_for_a_late_sweep_plan_and_streams_the_two_together():
    """A plan back within ``sweep_lead`` of the gripper coming free is waited for.

    The lift starts when the plan is in (``awaiting_plan`` until then, which holds the sim
    clock in the node), joined with the sweep: the step is longer than with the plan in time
    by that wait only.
    """
    lead, delay = 0.3, 0.15
    step = possible_steps(TRUSS, START)[0]
    on_time = _leading_world(lead, gripper_delay=0.1)
    assert on_time.run_step(step).success
    world = _leading_world(lead, gripper_delay=0.1, coarse_plan_delay=delay)
    waiting = []
    tick = world.sequencer.tick

    def recording_tick(now, *args):
        commands = tick(now, *args)
        waiting.append((now, world.sequencer.awaiting_plan))
        return commands
    world.sequencer.tick = recording_tick
    outcome = world.run_step(step)
    assert outcome.success, outcome.message
    requests = [c for c in world.log if isinstance(c, TrajectoryRequest)]
    assert requests[0].then is not None and requests[0].then.purpose == 'coarse'
    assert 'coarse' not in [c.purpose for c in requests]
    # planned at 0.15 s, the gripper free at 0.1 s: the lift waited from then until the plan
    assert _lift_start(world) == pytest.approx(delay, abs=DT + 1e-9)
    assert _lift_start(on_time) == pytest.approx(0.1, abs=DT + 1e-9)
    assert [t for t, w in waiting if w] and all(0.1 - 1e-9 <= t < delay + 1e-9
                                                for t, w in waiting if w)
    assert outcome.duration == pytest.approx(on_time.sequencer.outcome.duration + delay - 0.1,
                                             abs=2 * DT + 1e-9)


@pytest.mark.parametrize('answer', ['planned', 'not planned'])
def test_the_wait_for_the_sweeps_plan_ends_with_its_answer_before_any_tick(answer):
    """``awaiting_plan`` turns False as the answer comes, before any tick.

    It holds the sim-time clock in the node: on a held clock no tick would come to end it.
    """
    world = _leading_world(0.3, gripper_delay=0.1, coarse_plan_delay=10.0)
    step = possible_steps(TRUSS, START)[0]
    world.targets = plan_step_targets(KIN, world.frame, step, TRUSS.position(step.from_node),
                                      TRUSS.position(step.to_node), world.theta,
                                      PARAMS.gripper.approach_height)
    world.execute(world.sequencer.start(step, world.targets, world.now, dict(world.grippers)))
    while not world.sequencer.awaiting_plan:
        assert world.now < 1.0, 'the freed gripper never waited for the plan'
        world.advance()
    assert world.sequencer.stage == 'unscrewing'
    if answer == 'planned':
        world.sequencer.motion_planned('coarse', 1.0)
    else:
        world.sequencer.motion_not_planned('coarse')
    assert not world.sequencer.awaiting_plan
    world.advance()  # the next tick lifts
    assert world.sequencer.stage == 'lifting'
    lift = world.requested[-1][1]
    assert lift.purpose == 'extraction' and (lift.then is not None) == (answer == 'planned')


@pytest.mark.parametrize('delay', [0.5, math.inf])  # later than the lead; refused
def test_without_the_sweeps_plan_in_time_the_lift_streams_alone_and_the_sweep_follows_it(delay):
    """The lift waits for a late plan at most ``sweep_lead``; for a refused one, not at all."""
    lead = 0.3
    world = _leading_world(lead, gripper_delay=0.1, coarse_plan_delay=delay)
    outcome = world.run_step(possible_steps(TRUSS, START)[0])
    assert outcome.success, outcome.message
    requests = [c for c in world.log if isinstance(c, TrajectoryRequest)]
    assert all(c.then is None for c in requests)
    assert [c.purpose for c in requests][:2] == ['extraction', 'coarse']
    waited = lead if delay < math.inf else 0.0
    assert _lift_start(world) == pytest.approx(0.1 + waited, abs=DT + 1e-9)


def test_a_sweep_lead_longer_than_the_whole_stream_still_ends_in_coarse():
    """A joined stream that ends before a tick has seen the lift end goes on in COARSE.

    No second request for the coarse motion: it has streamed already.
    """
    world = _leading_world(1.0)  # the World's lift takes 1 s: they start together
    outcome = world.run_step(possible_steps(TRUSS, START)[0])
    assert outcome.success, outcome.message
    purposes = [c.purpose for c in world.log if isinstance(c, TrajectoryRequest)]
    assert purposes[0] == 'extraction' and 'coarse' not in purposes
    order = [p for i, p in enumerate(world.phases) if i == 0 or world.phases[i - 1] != p]
    assert order[:4] == [Phase.EXTRACTION, Phase.COARSE, Phase.FINE, Phase.INSERTION]


@pytest.mark.parametrize('ticks', [30, 80])  # the lift only; the lift and the sweep
def test_a_hold_while_the_sweep_streams_with_the_lift_is_resumed_to_the_step_end(ticks):
    world = _leading_world(0.5)
    step = _hold_during(world, Phase.EXTRACTION, ticks=ticks)
    assert world.grippers[step.moving_gripper] == 'free'
    assert [c for c in world.log if isinstance(c, CancelTrajectory)]
    _resume(world)
    _run_to_the_end(world)
    assert world.grippers == {'a': 'attached', 'b': 'attached'}


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


def _stage_times(world, stage):
    return [t for t, s in world.stages if s == stage]


def test_a_tip_over_the_hole_and_slow_descends_without_waiting_to_settle():
    """The descent starts at the first tick the tip is aligned and the joints slow.

    The insertion settles at the mouth before the screw-in, so the fine phase need not wait
    ``settle_time`` too: here (ideal tracking) the coarse motion ends on the point above the
    hole, and the descent is requested at once; the mouth settles for ``mouth_settle_time``,
    not for the longer ``settle_time``.
    """
    parameters = dataclasses.replace(SUPERVISOR, settle_time=0.5, mouth_settle_time=0.2)
    world = World()
    world.sequencer = StepSequencer(parameters, KIN, 'a')
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert outcome.success, outcome.message
    arriving = _stage_times(world, 'arriving')  # FINE while the coarse motion runs on
    descent = _stage_times(world, 'descending')
    mouth = _stage_times(world, 'settling')
    screw = _stage_times(world, 'screwing')
    assert arriving and descent and mouth and screw
    # the motion ends, its last step still moving; the next ticks are still: down at once
    assert descent[0] - arriving[-1] <= 3 * DT + 1e-9 < 0.1 * parameters.settle_time
    at_mouth = min(t for t in mouth if t > descent[0])
    waited = screw[0] - at_mouth  # still from the first tick at the mouth (ideal tracking)
    assert parameters.mouth_settle_time - 1e-9 <= waited < parameters.settle_time


def test_a_correction_line_waits_settle_time_not_mouth_settle_time():
    """A tip that stopped short waits ``settle_time`` before its line: joint 1 may yet come in."""
    parameters = dataclasses.replace(SUPERVISOR, settle_time=0.4, mouth_settle_time=0.05)
    world = World(coarse_miss=0.004)  # 3.6 mm short at 0.9 m
    world.sequencer = StepSequencer(parameters, KIN, 'a')
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert outcome.success, outcome.message
    settling = _stage_times(world, 'settling')
    line = _stage_times(world, 'moving')
    fine_line_start = min(t for t in line if t > settling[0])
    assert fine_line_start - settling[0] >= parameters.settle_time - 1e-9


def test_the_descent_is_planned_on_entering_fine_and_streams_unchanged():
    """The descent asked for when FINE ends is the one prepared as FINE began (no replanning)."""
    world = World(coarse_miss=0.004)  # a correction line too: the descent stays the same
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert outcome.success, outcome.message
    prepared = [c.request for c in world.log
                if isinstance(c, PrepareTrajectory) and c.request.purpose == 'insertion']
    descents = [c for c in world.log
                if isinstance(c, TrajectoryRequest) and c.purpose == 'insertion']
    assert len(prepared) == 1 and len(descents) == 1
    assert prepared[0].same_motion(descents[0])
    # straight down the axis, from the point above the hole to its mouth
    np.testing.assert_allclose(descents[0].start_point[:2], descents[0].goal_point[:2])
    np.testing.assert_allclose(KIN.forward(descents[0].start)[:3], descents[0].start_point,
                               atol=1e-9)


def test_joints_away_from_the_prepared_start_descend_from_where_they_are():
    """A wrist turned another way (a resumed step's way back) is not sent the prepared descent."""
    world = World(coarse_miss=0.004)  # at rest 3.6 mm short: no descent before the tick below
    world.run_step(possible_steps(TRUSS, world.stance)[0], max_time=0.0)  # unscrewing
    while world.sequencer.phase != Phase.FINE:
        world.advance()
    while world.motion is not None:  # the coarse motion runs on to its end
        world.advance()
    turned = world.targets.above_to + np.array([0.0, 0.0, 0.0, 0.0, 1.0])  # J5 a radian off
    commands = world.sequencer.tick(world.now + DT, turned, np.zeros(5), dict(world.grippers))
    descents = [c for c in commands if isinstance(c, TrajectoryRequest)]
    assert [c.purpose for c in descents] == ['insertion']
    np.testing.assert_allclose(descents[0].start, turned)
    np.testing.assert_allclose(descents[0].goal_point, world.targets.point_to)


def test_an_aligned_tip_still_moving_is_not_lowered():
    """Over the hole but a joint faster than ``settle_velocity``: no descent until it slows."""
    world = World()
    step = possible_steps(TRUSS, world.stance)[0]
    world.run_step(step, max_time=0.0)  # unscrewing
    while world.sequencer.phase != Phase.FINE:
        world.advance()
    while world.motion is not None:  # the coarse motion runs on to its end
        world.advance()
    assert world.sequencer.stage == 'settling'
    sequencer = world.sequencer
    theta = world.targets.above_to
    fast = np.array([0.0, 1.5 * SUPERVISOR.settle_velocity, 0.0, 0.0, 0.0])
    for k in range(20):
        assert sequencer.tick(world.now + k * DT, theta, fast, dict(world.grippers)) == []
    commands = sequencer.tick(world.now + 20 * DT, theta, np.zeros(5), dict(world.grippers))
    assert [c.purpose for c in commands if isinstance(c, TrajectoryRequest)] == ['insertion']
    assert sequencer.phase == Phase.INSERTION


def _settling_above_the_hole(world):
    """Run a step until its coarse motion has ended above the hole (FINE, 'settling').

    ``world`` stops joint 1 short of the goal (``coarse_miss``), outside ``descent_region``.
    """
    world.run_step(possible_steps(TRUSS, world.stance)[0], max_time=0.0)  # unscrewing
    while world.sequencer.phase != Phase.FINE:
        world.advance()
    while world.motion is not None:  # the coarse motion runs on to its end
        world.advance()
    assert world.sequencer.stage == 'settling'
    return world.sequencer


def _joint1_short_by(world, errors):
    """Joint angles (roles) with the tip these distances [m] short of the point above the hole.

    Joint 1 alone turns the tip about the base axis, as it does coming in behind its filter.
    """
    above = world.targets.above_to
    thetas = []
    for error in errors:
        theta = above.copy()
        # find the joint-1 offset that puts the tip this far from the point (bisection)
        low, high = 0.0, 0.1
        for _ in range(60):
            middle = 0.5 * (low + high)
            theta[0] = above[0] - middle
            distance = np.linalg.norm(KIN.forward(theta)[:3] - world.targets.point_above_to)
            low, high = (middle, high) if distance < error else (low, middle)
        theta[0] = above[0] - 0.5 * (low + high)
        thetas.append(theta)
    return thetas


def test_a_tip_still_closing_inside_the_descent_region_descends_at_once():
    """Joint 1 coming in behind its filter: the descent starts inside ``descent_region``.

    The joints are faster than ``settle_velocity`` and the tip farther than
    ``insertion_alignment``, as when the sweep's setpoints have ended and joint 1's filtered
    reference is still arriving; closing on the point, the tip starts down at the first tick
    inside the region, and not before.
    """
    world = World(coarse_miss=0.004)  # 3.6 mm short at 0.9 m
    sequencer = _settling_above_the_hole(world)
    parameters = sequencer.parameters
    errors = [4.0e-3, 3.0e-3, 2.4e-3, 1.6e-3, 1.0e-3]  # [m], 20 ms apart
    moving = np.array([0.04, 0.0, 0.0, 0.0, 0.0])  # [rad/s] twice settle_velocity
    assert moving[0] > parameters.settle_velocity
    started = None
    for k, theta in enumerate(_joint1_short_by(world, errors)):
        commands = sequencer.tick(world.now + k * DT, theta, moving, dict(world.grippers))
        if any(isinstance(c, TrajectoryRequest) for c in commands):
            started = k
            break
    assert started is not None
    assert errors[started] <= parameters.descent_region < errors[started - 1]
    assert errors[started] > parameters.insertion_alignment
    assert sequencer.phase == Phase.INSERTION


def test_a_tip_swinging_through_or_at_rest_off_the_point_is_not_lowered():
    """Through the point faster than it closes, or away, or still: not lowered.

    Outside ``insertion_alignment`` at rest it settles and gets a correction line, as a tip
    that stopped short always has.
    """
    world = World(coarse_miss=0.004)  # 3.6 mm short at 0.9 m
    sequencer = _settling_above_the_hole(world)
    parameters = sequencer.parameters
    inside = 0.5 * (parameters.descent_region + parameters.insertion_alignment)
    # [m] 20 ms apart: in by more than what remains each tick, through, out again, then still
    errors = [1.5 * parameters.descent_region, 0.3 * parameters.descent_region, 0.0,
              0.6 * inside, inside, inside]
    moving = np.array([0.2, 0.0, 0.0, 0.0, 0.0])
    for k, theta in enumerate(_joint1_short_by(world, errors)):
        velocities = moving if k < 5 else np.zeros(5)
        commands = sequencer.tick(world.now + k * DT, theta, velocities, dict(world.grippers))
        assert not any(isinstance(c, TrajectoryRequest) for c in commands), k
    assert sequencer.phase == Phase.FINE
    at_rest = _joint1_short_by(world, [inside])[0]
    requests = []
    for k in range(int(round(parameters.settle_time / DT)) + 2):
        requests += [c for c in sequencer.tick(world.now + (len(errors) + k) * DT, at_rest,
                                               np.zeros(5), dict(world.grippers))
                     if isinstance(c, TrajectoryRequest)]
    assert [c.purpose for c in requests] == ['fine']  # a correction line, not the descent


def test_a_tip_swinging_through_between_two_ticks_close_together_is_not_lowered():
    """Ticks late and then bunched up (a real-time supervisor): the speed, not the tick, counts.

    2 ms apart the tip comes 1 mm closer with 1.5 mm to go, which the change of its error
    between the ticks took for closing slowly; its joints say it moves at 0.45 m/s, through
    the point. It is not lowered; coming in at the same place slowly, it is.
    """
    world = World(coarse_miss=0.004)
    sequencer = _settling_above_the_hole(world)
    far, near = _joint1_short_by(world, [2.5e-3, 1.5e-3])
    swinging = np.array([0.5, 0.0, 0.0, 0.0, 0.0])  # [rad/s] joint 1, towards the point
    for k, theta in enumerate((far, near)):
        commands = sequencer.tick(world.now + k * 0.002, theta, swinging, dict(world.grippers))
        assert not any(isinstance(c, TrajectoryRequest) for c in commands), k
    assert sequencer.phase == Phase.FINE
    coming_in = np.array([0.02, 0.0, 0.0, 0.0, 0.0])  # [rad/s] about 18 mm/s of tip
    commands = sequencer.tick(world.now + 0.004, near, coming_in, dict(world.grippers))
    assert [c.purpose for c in commands if isinstance(c, TrajectoryRequest)] == ['insertion']


def test_a_tip_moving_away_inside_the_descent_region_is_not_lowered():
    world = World(coarse_miss=0.004)
    sequencer = _settling_above_the_hole(world)
    (near,) = _joint1_short_by(world, [1.5e-3])
    leaving = np.array([-0.02, 0.0, 0.0, 0.0, 0.0])  # [rad/s] joint 1, away from the point
    for k in range(3):
        commands = sequencer.tick(world.now + k * DT, near, leaving, dict(world.grippers))
        assert not any(isinstance(c, TrajectoryRequest) for c in commands), k
    assert sequencer.phase == Phase.FINE


def _purposes(world):
    return [c.purpose if isinstance(c, TrajectoryRequest) else
            c.action if isinstance(c, GripperRequest) else 'cancel'
            for c in world.log if isinstance(c, (TrajectoryRequest, GripperRequest,
                                                 CancelTrajectory))]


def test_a_descent_that_leaves_the_axis_is_stopped_lifted_back_and_inserted_again():
    """Joint 1 running 18 mm off as the gripper goes down: stopped before the mouth."""
    world = World(descent_runaway=(0.02, 1))
    offsets = []
    original_tick = world.sequencer.tick

    def tick(*args):
        commands = original_tick(*args)
        if world.sequencer.stage == 'descending':
            offsets.append(world.sequencer.mouth_offset())
        return commands
    world.sequencer.tick = tick
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert outcome.success, outcome.message
    purposes = _purposes(world)
    assert purposes[purposes.index('insertion'):] == [
        'insertion', 'cancel', 'retry_lift', 'fine', 'insertion', 'screw_in']
    assert outcome.insertion_attempts == 2  # lifted straight up 5 mm off: a line over the hole
    # stopped within a tick of crossing the tolerance, far from the 18 mm it was heading for
    assert max(offsets) < SUPERVISOR.descent_axis_tolerance + 0.002
    lift = next(c for c in world.log
                if isinstance(c, TrajectoryRequest) and c.purpose == 'retry_lift')
    np.testing.assert_allclose(lift.goal_point[2], world.targets.point_above_to[2])
    assert any(isinstance(c, Notice) and "left the hole's axis" in c.message
               for c in world.log)


def test_descents_that_keep_leaving_the_axis_end_in_safe_hold_attached():
    world = World(descent_runaway=(0.02, 99))
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert not outcome.success
    assert "left the hole's axis" in outcome.message
    assert outcome.insertion_attempts == SUPERVISOR.max_insertion_attempts
    assert world.sequencer.phase == Phase.SAFE_HOLD
    assert 'screw_in' not in _purposes(world)
    assert world.grippers[world.sequencer.base_gripper] == 'attached'


def test_parameters_refuse_an_axis_tolerance_within_the_descent_region():
    with pytest.raises(ParameterError, match='descent_axis_tolerance'):
        dataclasses.replace(SUPERVISOR, descent_axis_tolerance=SUPERVISOR.descent_region)


def test_parameters_refuse_a_descent_region_outside_alignment_and_region():
    with pytest.raises(ParameterError, match='descent_region'):
        dataclasses.replace(SUPERVISOR, descent_region=0.5 * SUPERVISOR.insertion_alignment)
    with pytest.raises(ParameterError, match='descent_region'):
        dataclasses.replace(SUPERVISOR, descent_region=SUPERVISOR.coarse_to_fine_region)


def test_a_tip_that_settles_off_the_hole_axis_after_the_descent_is_aligned_at_the_mouth():
    world = World(descent_miss=0.0015)  # 1.35 mm off the axis at 0.9 m
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert outcome.success, outcome.message
    purposes = [c.purpose if isinstance(c, TrajectoryRequest) else c.action
                for c in world.log if isinstance(c, (TrajectoryRequest, GripperRequest))]
    assert purposes == ['unscrew', 'extraction', 'coarse', 'insertion', 'fine', 'screw_in']
    line = next(c for c in world.log if isinstance(c, TrajectoryRequest) and c.purpose == 'fine')
    settled_tip = KIN.forward(line.start)[:3]
    assert np.linalg.norm(settled_tip[:2] - line.goal_point[:2]) > SUPERVISOR.insertion_alignment
    np.testing.assert_allclose(line.goal_point, world.targets.point_to)
    np.testing.assert_allclose(line.goal, world.targets.at_to)
    assert world.sequencer.mouth_offset() < 1e-9  # screwed in on the axis


def test_after_a_line_at_the_mouth_the_screw_in_waits_settle_time():
    """A line at the mouth moves joint 1, which may yet come in: the long wait, not the mouth's."""
    parameters = dataclasses.replace(SUPERVISOR, settle_time=0.4, mouth_settle_time=0.05)
    world = World(descent_miss=0.0015)  # 1.35 mm off the axis: one line at the mouth
    world.sequencer = StepSequencer(parameters, KIN, 'a')
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert outcome.success, outcome.message
    descent, aligning = _stage_times(world, 'descending'), _stage_times(world, 'aligning')
    settling, screw = _stage_times(world, 'settling'), _stage_times(world, 'screwing')
    after_descent = min(t for t in settling if t > descent[-1])
    after_line = min(t for t in settling if t > aligning[-1])
    # after the descent the short wait, then the line; after the line the long one
    assert parameters.mouth_settle_time - 1e-9 <= aligning[0] - after_descent \
        < parameters.settle_time
    assert screw[0] - after_line >= parameters.settle_time - 1e-9


def test_a_mouth_that_will_not_align_is_screwed_into_after_a_bounded_number_of_lines():
    world = World(descent_miss=0.0015, mouth_lines_miss=True)
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert outcome.success, outcome.message  # the screw-in itself is the final check
    # the error reported is the joints' estimate where it screwed in, off the axis at the mouth
    assert outcome.insertion_error > SUPERVISOR.insertion_alignment
    lines = [i for i, c in enumerate(world.log)
             if isinstance(c, TrajectoryRequest) and c.purpose == 'fine']
    assert len(lines) == MAX_FINE_LINES
    screw = next(i for i, c in enumerate(world.log)
                 if isinstance(c, GripperRequest) and c.action == 'screw_in')
    assert screw > lines[-1]


def test_controller_modes_follow_the_phases():
    world = World()
    world.run_step(possible_steps(TRUSS, world.stance)[0])
    modes = [c.mode for c in world.log if isinstance(c, SetControlMode)]
    # the controllers hold while the gripper unscrews (a relaxation under way runs on); each
    # motion then commands its own mode just before it streams (TrajectoryRequest.mode)
    assert modes[0] == 'hold' and 'coarse' in modes
    assert modes.index('coarse') < len(modes) - 1 - modes[::-1].index('fine')
    purposes = [c.purpose for c in world.log if isinstance(c, TrajectoryRequest)]
    # tracking is ideal here: the coarse motion ends on the point above the hole, no fine line
    assert purposes == ['extraction', 'coarse', 'insertion']
    assert [c.mode for c in world.log if isinstance(c, TrajectoryRequest)] == \
        ['fine', 'coarse', 'fine']


def test_coarse_hands_over_to_fine_mode_inside_the_region_and_runs_to_its_end():
    world = World()
    world.run_step(possible_steps(TRUSS, world.stance)[0])
    coarse = next(i for i, c in enumerate(world.log)
                  if isinstance(c, TrajectoryRequest) and c.purpose == 'coarse')
    fine = next(i for i, c in enumerate(world.log[coarse:], coarse)
                if isinstance(c, SetControlMode) and c.mode == 'fine')
    assert not any(isinstance(c, CancelTrajectory) for c in world.log), 'nothing is cancelled'
    assert world.phases.count(Phase.FINE) > 0
    assert fine > coarse


def test_a_tip_that_settles_off_the_hole_gets_a_fine_line_from_where_it_settled():
    world = World(coarse_miss=0.004)  # 3.6 mm short at 0.9 m
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert outcome.success, outcome.message
    lines = [c for c in world.log if isinstance(c, TrajectoryRequest) and c.purpose == 'fine']
    assert len(lines) == 1
    settled_tip = KIN.forward(lines[0].start)[:3]
    assert np.linalg.norm(settled_tip - lines[0].goal_point) > SUPERVISOR.insertion_alignment
    np.testing.assert_allclose(lines[0].goal_point, world.targets.point_above_to)


def test_the_unscrew_waits_for_the_base_and_never_releases_it():
    world = World()
    world.run_step(possible_steps(TRUSS, world.stance)[1])
    releases = [c for c in world.log if isinstance(c, GripperRequest) and c.action == 'unscrew']
    assert releases == [GripperRequest('b', 'unscrew')]


def test_a_jammed_insertion_is_retried():
    world = World(jams=2)
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert outcome.success and outcome.insertion_attempts == 3
    lifts = [c for c in world.log
             if isinstance(c, TrajectoryRequest) and c.purpose == 'retry_lift']
    assert len(lifts) == 2


@pytest.mark.parametrize('jams, attempts', [(2, 3), (5, 3)])
def test_a_jam_seen_in_the_gripper_states_before_its_answer_counts_once(jams, attempts):
    world = World(jams=jams, jam_seen_first=True)
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    lifts = [c for c in world.log
             if isinstance(c, TrajectoryRequest) and c.purpose == 'retry_lift']
    screw_ins = [c for c in world.log if c == GripperRequest('b', 'screw_in')]
    assert len(screw_ins) == attempts and len(lifts) == attempts - 1
    if jams < attempts:
        assert outcome.success and outcome.insertion_attempts == attempts
    else:
        assert not outcome.success and f'jammed {attempts} times' in outcome.message
        assert world.sequencer.phase == Phase.SAFE_HOLD
    assert world.late_answers == []


def test_a_retry_is_not_judged_by_the_last_attempts_jammed_state():
    """A retried screw-in that succeeds is not a second jam while the old state lingers.

    For a while the sequencer still sees the gripper reported jammed (the plant's new state is
    late): that is the last attempt's state, not a second jam.
    """
    world = World(jams=1, jam_seen_first=True, stale_states=0.1, gripper_delay=0.3)
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    screw_ins = [c for c in world.log if c == GripperRequest('b', 'screw_in')]
    assert outcome.success, outcome.message
    assert outcome.insertion_attempts == 2 and len(screw_ins) == 2


def test_an_answer_that_nobody_waits_for_is_refused():
    world = World()
    with pytest.raises(SequencerError, match='unexpected gripper result'):
        world.sequencer.gripper_done(True, '', 0.0)


def test_too_many_jams_abort_to_safe_hold_with_the_base_attached():
    world = World(jams=5)
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert not outcome.success and 'jammed 3 times' in outcome.message
    assert world.sequencer.phase == Phase.SAFE_HOLD
    assert world.grippers['a'] == 'attached'
    assert world.log[-1] == SetControlMode('hold', 'a')


def test_a_refused_unscrew_aborts_before_anything_moves():
    world = World(refuse_unscrew=True)
    start = world.theta.copy()
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert not outcome.success and 'interlock' in outcome.message
    assert not any(isinstance(c, TrajectoryRequest) for c in world.log)
    np.testing.assert_array_equal(world.theta, start)


def test_a_stalled_trajectory_times_out_to_safe_hold():
    world = World(stall_trajectories=True)
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0], max_time=30.0)
    assert not outcome.success and 'overran' in outcome.message
    assert world.now == pytest.approx(1.0 + SUPERVISOR.phase_timeout, abs=3 * DT)
    assert isinstance(world.log[-2], CancelTrajectory)


def test_a_trajectory_the_planner_never_answers_times_out_to_safe_hold():
    world = World()
    step = possible_steps(TRUSS, world.stance)[0]
    targets = plan_step_targets(KIN, world.frame, step, TRUSS.position(step.from_node),
                                TRUSS.position(step.to_node), world.theta, 0.03)
    sequencer = world.sequencer
    sequencer.start(step, targets, 0.0, dict(world.grippers))
    sequencer.gripper_done(True, '', 0.0)
    request = sequencer.tick(0.5, world.theta, np.zeros(5), {'a': 'attached', 'b': 'free'})
    assert [c.purpose for c in request if isinstance(c, TrajectoryRequest)] == ['extraction']
    now = 0.5
    while sequencer.phase != Phase.SAFE_HOLD:  # no trajectory_started, no trajectory_done
        now += DT
        assert now < 0.5 + SUPERVISOR.phase_timeout + 1.0, 'the request waits forever'
        commands = sequencer.tick(now, world.theta, np.zeros(5),
                                  {'a': 'attached', 'b': 'free'})
    assert now == pytest.approx(0.5 + SUPERVISOR.phase_timeout, abs=3 * DT)
    assert 'extraction trajectory did not start' in sequencer.reason
    assert 'planner' in sequencer.reason
    assert commands == [CancelTrajectory(), SetControlMode('hold', 'a')]


def test_a_hold_while_a_trajectory_is_being_planned_cancels_it():
    """The plan's answer, arriving after the hold, must not start a motion."""
    world = World()
    step = possible_steps(TRUSS, world.stance)[0]
    targets = plan_step_targets(KIN, world.frame, step, TRUSS.position(step.from_node),
                                TRUSS.position(step.to_node), world.theta, 0.03)
    sequencer = world.sequencer
    sequencer.start(step, targets, 0.0, dict(world.grippers))
    sequencer.gripper_done(True, '', 0.0)
    sequencer.tick(0.5, world.theta, np.zeros(5), {'a': 'attached', 'b': 'free'})
    assert sequencer.hold('hold requested by an operator', 0.6) == [
        CancelTrajectory(), SetControlMode('hold', 'a')]


def test_losing_the_base_during_a_step_aborts():
    world = World()
    step = possible_steps(TRUSS, world.stance)[0]
    targets = plan_step_targets(KIN, world.frame, step, TRUSS.position(step.from_node),
                                TRUSS.position(step.to_node), world.theta, 0.03)
    world.execute(world.sequencer.start(step, targets, 0.0, dict(world.grippers)))
    commands = world.sequencer.tick(0.1, world.theta, np.zeros(5), {'a': 'free', 'b': 'free'})
    assert world.sequencer.phase == Phase.SAFE_HOLD
    assert 'base gripper a' in world.sequencer.reason
    assert commands[-1] == SetControlMode('hold', 'a')


def test_steps_are_refused_unless_both_grippers_are_attached_and_idle():
    world = World()
    step = possible_steps(TRUSS, world.stance)[0]
    targets = plan_step_targets(KIN, world.frame, step, TRUSS.position(step.from_node),
                                TRUSS.position(step.to_node), world.theta, 0.03)
    with pytest.raises(SequencerError, match='both grippers attached'):
        world.sequencer.start(step, targets, 0.0, {'a': 'attached', 'b': 'free'})
    world.sequencer.start(step, targets, 0.0, dict(world.grippers))
    with pytest.raises(SequencerError, match='already under way'):
        world.sequencer.start(step, targets, 0.0, dict(world.grippers))
    world.sequencer.hold('operator hold', 0.5)
    with pytest.raises(SequencerError, match='SAFE_HOLD'):
        world.sequencer.start(step, targets, 0.0, dict(world.grippers))
    wrong_base = PlannedStep('b', 'n2_1', 'n1_1', 'n3_1', math.pi)
    fresh = StepSequencer(SUPERVISOR, KIN, 'a')
    with pytest.raises(SequencerError, match='base is gripper a'):
        fresh.start(wrong_base, targets, 0.0, dict(world.grippers))


def test_resume_with_both_grippers_attached_returns_to_idle():
    world = World()
    world.sequencer.hold('operator', 0.0)
    assert world.sequencer.phase == Phase.SAFE_HOLD
    world.sequencer.require_safe_hold()  # a hold: resumable
    commands = world.sequencer.resume(0.1, world.theta, dict(world.grippers),
                                      {'a': 'n1_1', 'b': 'n2_1'})
    assert world.sequencer.phase == Phase.IDLE and commands == [SetControlMode('hold', 'a')]
    with pytest.raises(SequencerError, match='not in SAFE_HOLD'):
        world.sequencer.resume(0.2, world.theta, dict(world.grippers), {})
    with pytest.raises(SequencerError, match=r'not in SAFE_HOLD \(phase IDLE\)'):
        world.sequencer.require_safe_hold()  # what the node answers first, whatever the health


def _hold_during(world, phase, step=None, ticks=20, reason='a fault'):
    """Run a step until ``ticks`` into ``phase``, then hold (an operator's hold, or a fault)."""
    step = step or possible_steps(TRUSS, world.stance)[0]
    targets = plan_step_targets(KIN, world.frame, step, TRUSS.position(step.from_node),
                                TRUSS.position(step.to_node), world.theta, 0.03)
    world.targets = targets
    world.execute(world.sequencer.start(step, targets, world.now, dict(world.grippers)))
    while world.sequencer.phase != phase:
        world.advance()
    for _ in range(ticks):
        world.advance()
    world.execute(world.sequencer.hold(reason, world.now))
    world.motion = None  # the stream stops where the arm is
    assert world.sequencer.phase == Phase.SAFE_HOLD
    return step


def _resume(world):
    """Resume the held step (gripper b free); return the motion the resume asked for."""
    world.execute(world.sequencer.resume(world.now, world.theta, dict(world.grippers),
                                         {'a': 'n1_1', 'b': ''}))
    return [c for c in world.log if isinstance(c, TrajectoryRequest)][-1]


def _run_to_the_end(world):
    while world.sequencer.busy:
        world.advance()
    assert world.sequencer.outcome.success, world.sequencer.outcome.message


@pytest.mark.parametrize('accepted', [True, False])
def test_a_gripper_answer_after_a_hold_is_ignored(accepted):
    world = World()
    step = possible_steps(TRUSS, world.stance)[0]
    targets = plan_step_targets(KIN, world.frame, step, TRUSS.position(step.from_node),
                                TRUSS.position(step.to_node), world.theta, 0.03)
    start = world.sequencer.start(step, targets, world.now, dict(world.grippers))
    assert GripperRequest(step.moving_gripper, 'unscrew') in start
    world.execute(world.sequencer.hold('hold requested by an operator', world.now))
    # the plant's answer to the unscrew sent before the hold comes in now
    assert world.sequencer.gripper_done(accepted, '', world.now) == []
    assert world.sequencer.phase == Phase.SAFE_HOLD
    assert world.sequencer.reason == 'hold requested by an operator'


@pytest.mark.parametrize('phase', [Phase.COARSE, Phase.FINE])
def test_resume_mid_step_recovers_to_the_target_and_completes_the_step(phase):
    world = World()
    step = _hold_during(world, phase)
    assert world.grippers[step.moving_gripper] == 'free'
    recover = _resume(world)
    assert recover.purpose == 'recover' and recover.mode == 'fine'
    np.testing.assert_allclose(recover.goal_point, world.targets.point_above_to)
    _run_to_the_end(world)
    assert world.grippers == {'a': 'attached', 'b': 'attached'}
    assert world.sequencer.base_gripper == 'b'


def test_a_step_completed_after_resume_has_its_outcome_taken_once():
    world = World()
    step = possible_steps(TRUSS, world.stance)[0]
    assert world.sequencer.take_outcome() is None
    _hold_during(world, Phase.COARSE)
    aborted = world.sequencer.take_outcome()
    assert aborted is not None and not aborted.success and aborted.message == 'a fault'
    assert world.sequencer.take_outcome() is None
    world.execute(world.sequencer.resume(world.now, world.theta, dict(world.grippers),
                                         {'a': 'n1_1', 'b': ''}))
    assert world.sequencer.take_outcome() is None, 'the step is under way again'
    while world.sequencer.busy:
        world.advance()
    completed = world.sequencer.take_outcome()
    assert completed is not None and completed.success
    assert world.sequencer.take_outcome() is None, 'taken once: no walk counts it again'
    assert world.sequencer.step == step


def test_resume_in_the_hole_lifts_out_first():
    world = World()
    _hold_during(world, Phase.EXTRACTION)
    assert _resume(world).purpose == 'extraction'
    _run_to_the_end(world)


@pytest.mark.parametrize('grippers, words', [
    ({'a': 'free', 'b': 'attached'}, 'base gripper a is not attached'),
    ({'a': 'attached', 'b': 'unscrewing'}, 'still unscrewing'),
])
def test_resume_refuses_what_is_not_safe(grippers, words):
    world = World()
    _hold_during(world, Phase.COARSE)
    with pytest.raises(SequencerError, match=words):
        world.sequencer.resume(world.now, world.theta, grippers, {})
    assert world.sequencer.phase == Phase.SAFE_HOLD


def test_resume_without_a_step_to_complete_is_refused():
    world = World()
    world.sequencer.hold('operator', 0.0)
    with pytest.raises(SequencerError, match='no step to complete'):
        world.sequencer.resume(0.1, world.theta, {'a': 'attached', 'b': 'free'}, {})


def test_a_step_forgotten_after_an_operator_changed_the_stance_is_not_completed():
    world = World()
    _hold_during(world, Phase.COARSE)
    world.sequencer.forget_step()
    with pytest.raises(SequencerError, match='no step to complete'):
        world.sequencer.resume(world.now, world.theta, dict(world.grippers), {'a': 'n1_1'})
    world.sequencer.resume(world.now, world.theta, {'a': 'attached', 'b': 'attached'},
                           {'a': 'n1_1', 'b': 'n2_1'})
    assert world.sequencer.phase == Phase.IDLE


def test_a_step_under_way_cannot_be_forgotten():
    world = World()
    step = possible_steps(TRUSS, world.stance)[0]
    targets = plan_step_targets(KIN, world.frame, step, TRUSS.position(step.from_node),
                                TRUSS.position(step.to_node), world.theta, 0.03)
    world.execute(world.sequencer.start(step, targets, world.now, dict(world.grippers)))
    with pytest.raises(SequencerError, match='a step is under way'):
        world.sequencer.forget_step()
    assert world.sequencer.step is step


def test_walking_a_route_there_and_back_keeps_every_joint_inside_its_limits():
    world = World()
    stance = world.stance
    limits = (KIN.lower[0], KIN.upper[0])
    yaws = (world.theta[0], world.theta[4])  # base a: J1 is a_yaw_joint, J5 b_yaw_joint
    route = plan_route(TRUSS, stance, 'n4_3', yaws=yaws, yaw_limits=limits)
    turned = sum(step.sweep for step in route)
    route += plan_route(TRUSS, route[-1].stance_after(), 'n0_0',
                        yaws=(yaws[0] + turned, yaws[1] + turned), yaw_limits=limits)
    assert any(step.is_half_turn for step in route) and len(route) >= 6
    for step in route:
        world.frame = BaseFrame.from_stance(KIN, world.theta, TRUSS.position(stance.base_node),
                                            TRUSS.position(stance.other_node))
        outcome = world.run_step(step)
        assert outcome.success, outcome.message
        assert KIN.within_limits(world.theta)
        tip = world.frame.to_truss(KIN.forward(world.theta)[:3])
        np.testing.assert_allclose(tip, TRUSS.position(step.to_node), atol=1e-9)
        stance = step.stance_after()
        world.stance = stance
        world.theta = world.theta[::-1].copy()  # the roles mirror with the new base


def test_parameters_refuse_an_alignment_looser_than_the_region():
    with pytest.raises(ParameterError, match='smaller'):
        SupervisorParameters(0.01, 0.02, 0.02, 0.1, 5.0, 3, 1.0, 0.02, 0.3, 0.1, 0.02, 0.03,
                             0.02, 0.0)


def test_nothing_moves_until_the_gripper_reports_free_and_the_step_ends_when_attached():
    world = World(gripper_delay=0.5)
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert outcome.success, outcome.message
    lift = next(i for i, c in enumerate(world.log) if isinstance(c, TrajectoryRequest))
    assert world.log[lift].purpose == 'extraction'
    # the extraction line starts only once the plant reported gripper b free (0.5 s later)
    assert outcome.phase_durations['extraction'] >= 0.5 + 1.0
    assert outcome.phase_durations['insertion'] >= 0.5 + SUPERVISOR.settle_time


def test_a_gripper_that_never_completes_aborts_the_step_with_the_base_attached():
    world = World(gripper_never=True)
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert not outcome.success and 'did not unscrew in time' in outcome.message
    assert not any(isinstance(c, TrajectoryRequest) for c in world.log)
    assert world.grippers['a'] == 'attached'


def test_a_coarse_motion_that_stops_outside_the_region_goes_on_in_fine_motion():
    world = World(coarse_miss=0.06)  # 54 mm short at 0.9 m, outside the 30 mm region
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert outcome.success, outcome.message
    lines = [c for c in world.log if isinstance(c, TrajectoryRequest) and c.purpose == 'fine']
    assert lines and lines[0].mode == 'fine'
    assert np.linalg.norm(KIN.forward(lines[0].start)[:3] - lines[0].goal_point) > \
        SUPERVISOR.coarse_to_fine_region


def test_the_coarse_motion_waits_for_a_joint_that_lags_the_extraction_line():
    # Joint J4 is 0.1 rad short when the extraction stream ends (late efforts, friction): a
    # coarse motion planned from the line's end would start that far from it (the planner
    # refuses that); the step waits in EXTRACTION until the joint is there.
    world = World(lift_lag=(3, 0.1, 0.5))
    step = possible_steps(TRUSS, world.stance)[0]
    targets = plan_step_targets(KIN, world.frame, step, TRUSS.position(step.from_node),
                                TRUSS.position(step.to_node), world.theta,
                                PARAMS.gripper.approach_height)
    world.execute(world.sequencer.start(step, targets, world.now, dict(world.grippers)))
    coarse_start = None
    while world.sequencer.busy and world.now < 60.0:
        world.advance()
        request = world.log[-1]
        if coarse_start is None and isinstance(request, TrajectoryRequest) \
                and request.purpose == 'coarse':
            coarse_start = world.now
            gap = np.max(np.abs(world.theta - targets.above_from))
            assert gap <= SUPERVISOR.coarse_start_tolerance
    assert world.sequencer.outcome.success, world.sequencer.outcome.message
    lifted = next(i for i, p in enumerate(world.phases) if p == Phase.COARSE)
    # the joint caught up 0.5 s after the line ended: EXTRACTION lasted that much longer
    assert world.sequencer.outcome.phase_durations['extraction'] > 1.0 + 0.45
    assert coarse_start is not None and lifted > 0


def test_a_joint_that_never_reaches_the_coarse_start_ends_the_step_in_safe_hold():
    world = World(lift_lag=(3, 0.1, 1e9))
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert not outcome.success and 'extraction overran' in outcome.message
    assert world.sequencer.phase == Phase.SAFE_HOLD
    assert world.grippers[world.stance.base_gripper] == 'attached'


def _folded_mid_sweep(world, radius, height=0.03, turned=0.9):
    """Joints with the tip ``radius`` from the base yaw axis, ``turned`` rad into the sweep."""
    sweep = world.sequencer.step.sweep
    start = world.targets.point_above_from
    angle = math.atan2(start[1], start[0]) + turned * math.copysign(1.0, sweep)
    point = [radius * math.cos(angle), radius * math.sin(angle), height, 0.0,
             world.targets.above_from[4]]
    return KIN.inverse(point, reference=world.targets.above_from)


def _hold_a_half_turn_in_coarse_motion(world):
    step = next(s for s in possible_steps(TRUSS, world.stance)
                if abs(abs(s.sweep) - math.pi) < 1e-9)
    return _hold_during(world, Phase.COARSE, step, ticks=0, reason='controllers held mid-sweep')


def test_resume_where_the_arm_folded_mid_sweep_goes_back_in_joint_space_and_completes():
    world = World()
    _hold_a_half_turn_in_coarse_motion(world)
    world.theta = _folded_mid_sweep(world, 0.205)  # no straight tip line from here
    back = _resume(world)
    assert back.purpose == 'recover_joint' and back.mode == 'fine'
    np.testing.assert_allclose(back.goal, world.targets.above_to)
    _run_to_the_end(world)


def test_resume_with_no_safe_way_back_is_refused_and_changes_nothing():
    world = World()
    _hold_a_half_turn_in_coarse_motion(world)
    world.theta = _folded_mid_sweep(world, 0.205, height=0.005)  # low, folded
    with pytest.raises(SequencerError, match='no safe way back above n0_1'):
        world.sequencer.resume(world.now, world.theta, dict(world.grippers),
                               {'a': 'n1_1', 'b': ''})
    assert world.sequencer.phase == Phase.SAFE_HOLD
    assert world.sequencer.reason == 'controllers held mid-sweep'


def test_resume_in_the_hole_lifts_straight_up_from_where_the_gripper_drifted():
    world = World()
    _hold_during(world, Phase.EXTRACTION)
    world.theta = world.theta + np.array([0.003, 0.0, 0.0, 0.0, 0.0])  # ~2.7 mm sideways
    tip = KIN.forward(world.theta)[:3]
    assert np.linalg.norm(tip[:2] - world.targets.point_above_from[:2]) > 0.002
    lift = _resume(world)
    assert lift.purpose == 'extraction'
    np.testing.assert_allclose(lift.goal_point[:2], tip[:2], atol=1e-9)  # vertical
    assert lift.goal_point[2] == pytest.approx(world.targets.point_above_from[2])
    np.testing.assert_allclose(KIN.forward(lift.goal)[:3], lift.goal_point, atol=1e-9)
    _run_to_the_end(world)


def test_resume_with_the_gripper_tilted_at_the_mouth_turns_it_upright_before_the_line():
    """A fault in the descent left the gripper tilted: turned upright first, then the line.

    A line (gripper vertical) from there would start away from the joints, and the planner
    refuses such a stream every time.
    """
    world = World()
    _hold_during(world, Phase.INSERTION)
    world.theta = world.theta + np.array([0.0, 0.0, 0.0, 0.06, 0.0])  # the wrist, J4
    held = world.theta.copy()
    tip = KIN.forward(held)
    assert abs(tip[3]) > 0.05  # the gripper tilted
    upright = _resume(world)
    assert upright.purpose == 'upright' and upright.mode == 'fine'
    np.testing.assert_allclose(upright.start, held)
    goal = KIN.forward(upright.goal)
    np.testing.assert_allclose(goal[:3], tip[:3], atol=1e-9)  # the tip stays where it is
    assert goal[3] == pytest.approx(0.0, abs=1e-9)  # the gripper vertical
    np.testing.assert_allclose(upright.goal_point, tip[:3], atol=1e-12)
    _run_to_the_end(world)
    purposes = [c.purpose for c in world.log if isinstance(c, TrajectoryRequest)]
    after = purposes[purposes.index('upright') + 1]
    assert after == 'fine', purposes  # then the line, from where the gripper stood upright


def test_resume_with_the_gripper_upright_takes_the_line_at_once():
    world = World()
    _hold_during(world, Phase.INSERTION)
    world.theta = world.theta + np.array([0.0, 0.0, 0.0, 0.01, 0.0])  # within the tolerance
    assert _resume(world).purpose == 'recover'


def test_a_way_back_the_planner_refuses_is_taken_again_in_joint_space_once():
    world = World()
    _hold_during(world, Phase.COARSE)
    assert _resume(world).purpose == 'recover' == world.motion[0].purpose
    world.motion = None
    world.execute(world.sequencer.trajectory_done(False, 'the path leaves the workspace',
                                                  world.now))
    again = world.motion[0]
    assert again.purpose == 'recover_joint' and world.sequencer.phase == Phase.FINE
    np.testing.assert_allclose(again.goal, world.targets.above_to)
    world.motion = None  # refused as well: then the step holds
    world.execute(world.sequencer.trajectory_done(False, 'refused again', world.now))
    assert world.sequencer.phase == Phase.SAFE_HOLD
    assert 'refused again' in world.sequencer.reason


def test_the_step_ends_at_the_screw_in_holding_under_the_new_base():
    """Screwed in: the step ends, HOLD under the new base (the controllers relax after it)."""
    world = World()
    outcome = world.run_step(possible_steps(TRUSS, world.stance)[0])
    assert outcome.success, outcome.message
    holds = [i for i, c in enumerate(world.log) if c == SetControlMode('hold', 'b')]
    screw_in = max(i for i, c in enumerate(world.log)
                   if isinstance(c, GripperRequest) and c.action == 'screw_in')
    assert holds == [len(world.log) - 1] and holds[0] > screw_in
    attached = next(t for t, stage in reversed(world.stages) if stage == 'screwing')
    assert world.now == pytest.approx(attached)  # no wait: the relaxation overlaps what follows
    assert world.sequencer.relaxed_at == pytest.approx(world.now + SUPERVISOR.relaxation_wait)
    assert world.sequencer.phase == Phase.IDLE


def _next_step(world):
    stance = Stance(world.sequencer.base_gripper, world.sequencer.step.to_node,
                    world.sequencer.step.base_node)
    return next(s for s in possible_steps(TRUSS, stance)
                if s.to_node != world.sequencer.step.from_node)


def _remeasuring(world, step, calls, fail=False):
    """Return a ``remeasure`` like the node's (the stance against the nodes), noting calls."""
    def remeasure(theta):
        calls.append((world.now, world.grippers[step.moving_gripper], theta.copy()))
        if fail:
            raise KinematicsError('joint 3 beyond its limit')
        return measure_step_targets(KIN, step, TRUSS.position(step.base_node),
                                    TRUSS.position(step.from_node),
                                    TRUSS.position(step.to_node), theta, 0.03)
    return remeasure


def _start_next_step(world, step, remeasure):
    frame = BaseFrame.from_stance(KIN, world.theta, TRUSS.position(step.base_node),
                                  TRUSS.position(step.from_node))
    world.frame = frame
    world.targets = plan_step_targets(KIN, frame, step, TRUSS.position(step.from_node),
                                      TRUSS.position(step.to_node), world.theta, 0.03)
    assert world.sequencer.can_start(world.now)
    commands = world.sequencer.start(step, world.targets, world.now, dict(world.grippers),
                                     remeasure)
    world.execute(commands)
    return commands


def test_the_next_step_measures_its_stance_after_the_relaxation_while_still_attached():
    """A step started during the relaxation takes its targets from the relaxed joints."""
    world = World(gripper_delay=0.5)  # the plant's screw_time
    assert world.run_step(possible_steps(TRUSS, world.stance)[0]).success
    relaxed_at = world.sequencer.relaxed_at
    step, calls = _next_step(world), []
    first = len(world.log)
    commands = _start_next_step(world, step, _remeasuring(world, step, calls))
    assert commands[0] == SetControlMode('hold', step.base_gripper)  # the relaxation runs on
    assert not any(isinstance(c, PrepareTrajectory) for c in commands)  # targets not final
    relaxed = world.theta.copy()
    relaxed[1] += 1e-3  # the dither lets the joints slide out of the bend
    while world.now < relaxed_at - DT / 2:
        world.advance()
    world.theta = relaxed
    while world.sequencer.phase == Phase.EXTRACTION and world.sequencer.stage == 'unscrewing':
        world.advance()
    assert len(calls) == 1
    when, state, theta = calls[0]
    assert when >= relaxed_at - 1e-9 and state == 'unscrewing'
    np.testing.assert_array_equal(theta, relaxed)
    np.testing.assert_array_equal(world.sequencer.targets.start, relaxed)
    prepared = [c.request for c in world.log[first:] if isinstance(c, PrepareTrajectory)]
    assert [r.purpose for r in prepared] == ['extraction', 'coarse']
    while world.sequencer.busy:
        world.advance()
    assert world.sequencer.outcome.success, world.sequencer.outcome.message
    requested = [c for c in world.log[first:] if isinstance(c, TrajectoryRequest)]
    extraction, coarse = (next(r for r in reversed(requested) if r.purpose == purpose)
                          for purpose in ('extraction', 'coarse'))
    assert extraction.same_motion(prepared[0]) and coarse.same_motion(prepared[1])
    np.testing.assert_array_equal(extraction.start, relaxed)


def test_a_step_started_after_the_relaxation_prepares_its_motions_at_once():
    world = World(gripper_delay=0.5)
    step, calls = possible_steps(TRUSS, world.stance)[0], []
    commands = _start_next_step(world, step, _remeasuring(world, step, calls))
    prepared = [c.request for c in commands if isinstance(c, PrepareTrajectory)]
    assert [r.purpose for r in prepared] == ['extraction', 'coarse']
    while world.sequencer.busy:
        world.advance()
    assert calls == []  # nothing to wait for: the stance at the start is relaxed
    requested = [c for c in world.log if isinstance(c, TrajectoryRequest)]
    assert requested[0].same_motion(prepared[0]) and requested[1].same_motion(prepared[1])
    assert not requested[2].same_motion(prepared[1])  # the insertion is planned when due


def test_a_stance_that_gives_no_targets_after_the_relaxation_keeps_the_first_ones():
    world = World(gripper_delay=0.5)
    assert world.run_step(possible_steps(TRUSS, world.stance)[0]).success
    step, calls = _next_step(world), []
    _start_next_step(world, step, _remeasuring(world, step, calls, fail=True))
    first = world.sequencer.targets
    while world.sequencer.stage == 'unscrewing':
        world.advance()
    assert len(calls) == 1 and world.sequencer.targets is first
    notices = [c.message for c in world.log if isinstance(c, Notice)]
    assert len(notices) == 1 and 'joint 3 beyond its limit' in notices[0]
    assert [c.request.purpose for c in world.log if isinstance(c, PrepareTrajectory)][-2:] \
        == ['extraction', 'coarse']
    while world.sequencer.busy:
        world.advance()
    assert world.sequencer.outcome.success


def test_a_step_may_start_only_when_its_unscrewing_outlasts_the_relaxation():
    slow = dataclasses.replace(SUPERVISOR, relaxation_wait=1.0)
    world = World()
    world.sequencer = StepSequencer(slow, KIN, world.stance.base_gripper, screw_time=0.5)
    assert world.run_step(possible_steps(TRUSS, world.stance)[0]).success
    relaxed_at = world.sequencer.relaxed_at
    earliest = relaxed_at - (0.5 - STANCE_MARGIN)
    assert not world.sequencer.can_start(earliest - 1e-6)
    assert world.sequencer.can_start(earliest)


def test_without_a_relaxation_wait_a_next_step_starts_at_once_and_measures_nothing_again():
    world = World(gripper_delay=0.5)
    world.sequencer = StepSequencer(dataclasses.replace(SUPERVISOR, relaxation_wait=0.0), KIN,
                                    world.stance.base_gripper)
    assert world.run_step(possible_steps(TRUSS, world.stance)[0]).success
    assert world.sequencer.can_start(world.now)
    step, calls = _next_step(world), []
    commands = _start_next_step(world, step, _remeasuring(world, step, calls))
    assert any(isinstance(c, PrepareTrajectory) for c in commands)
    while world.sequencer.busy:
        world.advance()
    assert calls == [] and world.sequencer.outcome.success


def test_a_resume_that_changes_the_base_lets_the_next_step_measure_after_the_relaxation():
    """Held while screwing in: the resume swaps the base, which starts the relaxation."""
    world = World(gripper_delay=0.5)
    step = possible_steps(TRUSS, world.stance)[0]
    world.targets = plan_step_targets(KIN, world.frame, step, TRUSS.position(step.from_node),
                                      TRUSS.position(step.to_node), world.theta, 0.03)
    world.execute(world.sequencer.start(step, world.targets, world.now, dict(world.grippers)))
    while world.sequencer.stage != 'screwing':
        world.advance()
    world.execute(world.sequencer.hold('a fault', world.now))
    assert world.sequencer.base_gripper == step.base_gripper
    for _ in range(60):  # the screw-in completes during the hold
        world.advance()
    assert world.grippers[step.moving_gripper] == 'attached'
    commands = world.sequencer.resume(world.now, world.theta, dict(world.grippers),
                                      {step.base_gripper: step.base_node,
                                       step.moving_gripper: step.to_node})
    assert commands == [SetControlMode('hold', step.moving_gripper)]
    assert world.sequencer.relaxed_at == pytest.approx(world.now + SUPERVISOR.relaxation_wait)
    next_step, calls = _next_step(world), []
    _start_next_step(world, next_step, _remeasuring(world, next_step, calls))
    while world.sequencer.stage == 'unscrewing':
        world.advance()
    assert len(calls) == 1 and calls[0][0] >= world.sequencer.relaxed_at - 1e-9


def test_a_resume_that_keeps_the_base_does_not_wait():
    world = World()
    _hold_during(world, Phase.COARSE)
    before = world.sequencer.relaxed_at
    world.sequencer.resume(world.now, world.theta, {'a': 'attached', 'b': 'attached'},
                           {'a': 'n1_1', 'b': 'n2_1'})
    assert world.sequencer.relaxed_at == before < world.now
