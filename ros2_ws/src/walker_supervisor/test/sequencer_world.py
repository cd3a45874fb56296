"""An ideal world around the step sequencer, for its tests: joints follow each motion exactly.

Every motion takes 1 s (two streamed together: 2 s less their lead) and the joints track it
exactly; the plant's grippers answer as scripted (jams, refusals, delays, states seen late).
"""

import dataclasses
import math

import numpy as np

from walker_core.kinematics import KinematicsError, WalkerKinematics
from walker_core.robot_parameters import load_walker_parameters
from walker_core.truss import Truss
from walker_supervisor.core.route import Stance, possible_steps
from walker_supervisor.core.commands import (
    CancelTrajectory, GripperRequest, PrepareTrajectory, TrajectoryRequest)
from walker_supervisor.core.parameters import SupervisorParameters
from walker_supervisor.core.phases import Phase
from walker_supervisor.core.sequencer import StepSequencer
from walker_supervisor.core.step_geometry import BaseFrame, measure_step_targets, plan_step_targets

PARAMS = load_walker_parameters()
KIN = WalkerKinematics.from_parameters(PARAMS)
TRUSS = Truss.from_parameters(PARAMS)
SUPERVISOR = SupervisorParameters(coarse_to_fine_region=0.03, insertion_alignment=0.001,
                                  settle_velocity=0.02, settle_time=0.1, phase_timeout=5.0,
                                  motion_end_margin=2.0,
                                  max_insertion_attempts=3, watchdog_timeout=1.0,
                                  mode_mismatch_hold_time=1.0,
                                  coarse_start_tolerance=0.02, relaxation_wait=0.3,
                                  mouth_settle_time=0.1, descent_region=0.002,
                                  descent_axis_tolerance=0.005, descent_arrival_time=0.02,
                                  sweep_lead=0.0, node_prior_std=0.0015,
                                  joint_reading_std=0.0002, search_radius=0.0,
                                  search_sigmas=3.0,
                                  insertion_overtravel=0.0)  # no face: see runner_world
DT = 0.01
START = Stance('a', 'n1_1', 'n2_1')


class World:
    """Executes the sequencer's commands: ideal tracking, scripted gripper results."""

    def __init__(self, stance=START, jams=0, refuse_unscrew=False,
                 stall_trajectories=False, coarse_miss=0.0, gripper_delay=0.0,
                 gripper_never=False, lift_lag=None, jam_seen_first=False, stale_states=0.0,
                 descent_miss=0.0, mouth_lines_miss=False, coarse_plan_delay=0.0,
                 descent_runaway=(0.0, 0), fine_miss=(0.0, 0), start_lag=0.0):
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
        # lines at the mouth stop as short (True), or short by this fraction of the last miss
        self.mouth_lines_miss = float(mouth_lines_miss)
        self.lines_since_descent = 0  # fine lines asked for since the last descent
        # ([rad], n): in the first n descents J1 runs this far off as the gripper goes down
        self.runaway, self.runaway_descents = descent_runaway
        # ([rad], n): the first n fine lines above the hole stop J1 this short of their end
        self.fine_miss, self.fine_misses = fine_miss
        self.start_lag = start_lag  # [s] every motion starts moving this late (tracking lag)
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
                self.lines_since_descent = 0 if command.purpose == 'insertion' else \
                    self.lines_since_descent + (command.purpose == 'fine')
                refusal = _vertical_line_refusal(command)
                if refusal:  # as the planner refuses it
                    self.execute(self.sequencer.trajectory_done(False, refusal, self.now))
                    continue
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
                    and self.grippers[other(request.gripper)] != 'attached'), \
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
            fraction = min(1.0, max(0.0, self.now - started - self.start_lag) / duration)
            previous = self.theta
            goal = request.goal.copy()
            if request.purpose == 'coarse':
                goal[0] -= self.coarse_miss * math.copysign(1.0, request.sweep)
            at_mouth = request.purpose == 'fine' and np.allclose(request.goal_point,
                                                                 self.targets.point_to)
            missing = request.purpose == 'fine' and not at_mouth and self.fine_misses > 0
            if missing:
                goal[0] -= self.fine_miss
            if request.purpose == 'insertion':
                goal[0] -= self.descent_miss
            elif at_mouth and self.mouth_lines_miss:
                goal[0] -= self.descent_miss * self.mouth_lines_miss ** self.lines_since_descent
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
                self.fine_misses -= missing
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


def _vertical_line_refusal(request):
    """Return the planner's refusal of a line along the hole axis that goes the wrong way."""
    rise = {'insertion': -1.0, 'retry_lift': 1.0, 'extraction': 1.0}.get(request.purpose)
    if rise is None or request.start_point is None:
        return ''
    if rise * (request.goal_point[2] - request.start_point[2]) <= 0.0:
        return f'{request.purpose} goes the wrong way along the hole axis'
    return ''


def other(gripper):
    return 'b' if gripper == 'a' else 'a'


def leading_world(lead=0.3, **options):
    world = World(**options)
    world.sequencer = StepSequencer(dataclasses.replace(SUPERVISOR, sweep_lead=lead), KIN, 'a')
    return world


def hold_during(world, phase, step=None, ticks=20, reason='a fault'):
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


def resume_step(world):
    """Resume the held step (gripper b free); return the motion the resume asked for."""
    world.execute(world.sequencer.resume(world.now, world.theta, dict(world.grippers),
                                         {'a': 'n1_1', 'b': ''}))
    return [c for c in world.log if isinstance(c, TrajectoryRequest)][-1]


def run_to_the_end(world):
    while world.sequencer.busy:
        world.advance()
    assert world.sequencer.outcome.success, world.sequencer.outcome.message


def motion_purposes(world):
    return [c.purpose if isinstance(c, TrajectoryRequest) else
            c.action if isinstance(c, GripperRequest) else 'cancel'
            for c in world.log if isinstance(c, (TrajectoryRequest, GripperRequest,
                                                 CancelTrajectory))]


def stage_times(world, stage):
    return [t for t, s in world.stages if s == stage]


def settling_above_the_hole(world):
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


def joint1_short_by(world, errors):
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

def following_step(world):
    stance = Stance(world.sequencer.base_gripper, world.sequencer.step.to_node,
                    world.sequencer.step.base_node)
    return next(s for s in possible_steps(TRUSS, stance)
                if s.to_node != world.sequencer.step.from_node)


def remeasuring(world, step, calls, fail=False):
    """Return a ``remeasure`` like the node's (the stance against the nodes), noting calls."""
    def remeasure(theta):
        calls.append((world.now, world.grippers[step.moving_gripper], theta.copy()))
        if fail:
            raise KinematicsError('joint 3 beyond its limit')
        return measure_step_targets(KIN, step, TRUSS.position(step.base_node),
                                    TRUSS.position(step.from_node),
                                    TRUSS.position(step.to_node), theta, 0.03)
    return remeasure


def start_next_step(world, step, remeasure):
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
