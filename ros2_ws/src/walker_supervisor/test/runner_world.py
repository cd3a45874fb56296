"""A headless world around the walk runner, for its tests: the planner core and an ideal arm.

The loop the runner's docstring describes, with no ROS: every period the joints follow the
stream under way exactly (the planner core's own plans, sampled), the plant's grippers screw in
and out in ``gripper.screw_time`` (a screw-in farther than ``gripper.insertion_position_
tolerance`` from a hole jams), and the runner hears joint, gripper and controller states; it
decides every ``TICK_PERIOD`` (and at once on ``DecideNow``) and watches every
``WATCH_PERIOD``. The planner can be told to fall silent (its requests go unanswered), or to
die mid-motion: the arm follows the trajectory under way to its end and holds it, as the
controllers hold a whole trajectory, and the end is never reported.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from walker_core.joint_roles import PHYSICAL_JOINT_NAMES, physical_to_roles
from walker_core.kinematics import WalkerKinematics
from walker_core.parameter_schema import load_parameter_file, section_from_flat
from walker_core.robot_parameters import default_parameter_file, load_walker_parameters
from walker_core.truss import Truss
from walker_planner.core.chaining import chain
from walker_planner.core.errors import PlanningError
from walker_planner.core.parameters import PREFIX, PlannerParameters
from walker_planner.core.planning import PlanningContext, plan
from walker_planner.core.streaming import SampledTrajectory
from walker_supervisor.core.commands import (
    CancelFollow, DecideNow, FollowMotion, GoalEnded, GripperRequest, Notice, PhaseRecord,
    PlanMotion, RenewPlannerClient, SetControlMode)
from walker_supervisor.core.controller_watch import ControllerReport, expected_role
from walker_supervisor.core.prepared_motions import PlanAnswer, stream_lead
from walker_supervisor.core.runner import TICK_PERIOD, WATCH_PERIOD, WalkRunner
from walker_supervisor.core.parameters import SupervisorParameters
from walker_supervisor.core.step_geometry import BaseFrame

__all__ = ['World', 'PARAMS', 'KIN', 'TRUSS', 'SETTINGS', 'START', 'DT', 'join']

PARAMS = load_walker_parameters()
KIN = WalkerKinematics.from_parameters(PARAMS)
TRUSS = Truss.from_parameters(PARAMS)
_FLAT = load_parameter_file(default_parameter_file())
# the ideal arm meets no node's face: its descents go to the nominal mouth (the descent to
# contact is tested on the plant, tests/on_plant/test_contact_on_plant.py)
SETTINGS = dataclasses.replace(section_from_flat(SupervisorParameters, _FLAT, 'supervisor.'),
                               insertion_overtravel=0.0)
PLANNING = PlanningContext.from_parameters(PARAMS, section_from_flat(PlannerParameters, _FLAT,
                                                                     PREFIX))
DT = 0.01  # [s] the loop's period
#: Joint angles (physical order, base a in n1_1) with gripper b in the hole of n2_1: the
#: base frame's y axis along the truss's x axis.
START = KIN.inverse([0.0, TRUSS.spacing, 0.0, 0.0, 0.0])


def join(first: PlanAnswer, second: PlanAnswer, lead: float) -> SampledTrajectory:
    """Two planned motions as one stream (the planner core's chain)."""
    return chain(first.trajectory, second.trajectory, stream_lead(first, second, lead))


class World:
    """The runner in a loop with the planner core, an ideal arm and a plant's grippers.

    Parameters
    ----------
    settings : SupervisorParameters
    recorded_step : RecordedStep, optional
        What a restarted supervisor finds on record.
    grippers : dict, optional
        gripper -> (state, node) at the start (both attached, a in n1_1, b in n2_1).
    positions : ndarray, optional
        Physical joint angles at the start [rad] (:data:`START`).
    frame : tuple, optional
        ``(gripper, BaseFrame)``: the gripper the arm hangs from and its frame in the truss
        (by default measured from the stance, both grippers attached).
    """

    def __init__(self, settings: SupervisorParameters = SETTINGS, recorded_step=None,
                 grippers=None, positions=None, frame=None) -> None:
        self.runner = WalkRunner(PARAMS, settings, join, recorded_step=recorded_step)
        self.now = 0.0
        self.positions = np.array(START if positions is None else positions, dtype=float)
        self.velocities = np.zeros(5)
        self.grippers = dict(grippers or {'a': ('attached', 'n1_1'), 'b': ('attached', 'n2_1')})
        # the gripper the arm hangs from, and its frame in the truss
        self.anchor, self.frame = frame or ('a', BaseFrame.from_stance(
            KIN, physical_to_roles(self.positions, 'a'), TRUSS.position(self.grippers['a'][1]),
            TRUSS.position(self.grippers['b'][1])))
        self.changes = []  # (time, gripper, state, node) the plant will report
        self.stream = None  # (ticket, trajectory, start time)
        self.mode = 'hold'
        self.base = 'a'  # the base the controllers follow
        self.rogue = ''  # a mode another control_mode publisher keeps the controllers in
        self.planner_silent = False  # the planner answers nothing ...
        self.heard_after_renewal = False  # ... until a client of it is made anew
        self.acceptances_lost = 0  # stream requests whose acceptance is lost on the way back
        self.planner_dead = False  # the planner reports no motion's end and answers nothing
        self.end_delay = 0.0  # [s] the planner reports each motion's end this late
        self.unanswered = []  # PlanMotion and FollowMotion commands it did not answer
        self.jam = 0  # screw-ins that jam whatever the tip
        self.position_errors = None  # gripper -> [m] the plant's tip-to-hole axis distances
        self.holes = {}  # node -> (x, y) [m]: its hole off its nominal place by this much
        self.planned = []  # (purpose, PlanAnswer) of every plan the planner answered
        self.silent = set()  # the sources the runner no longer hears: 'grippers', a joint
        self.log = []  # every command the runner gave
        self.stamps = []  # [s] the loop time of each
        self.next_tick = self.next_watch = 0.0
        self.period()  # the runner hears the world once before anything is asked of it

    # ------------------------------------------------------------------ records
    def of(self, kind) -> list:
        return [command for command in self.log if isinstance(command, kind)]

    def when(self, kind) -> list[float]:
        """Return the loop times [s] of the commands of a kind."""
        return [t for t, command in zip(self.stamps, self.log, strict=True)
                if isinstance(command, kind)]

    @property
    def phases(self) -> list:
        return [record.phase for record in self.of(PhaseRecord)]

    @property
    def notices(self) -> list[str]:
        return [notice.message for notice in self.of(Notice)]

    def tip(self) -> np.ndarray:
        """Return the free (or last moved) gripper's contact point in the truss frame [m]."""
        roles = physical_to_roles(self.positions, self.anchor)
        return self.frame.to_truss(KIN.forward(roles)[:3])

    # ------------------------------------------------------------------ the loop
    def run_until(self, condition, limit: float = 60.0) -> None:
        """Step the loop until ``condition()`` or ``limit`` [s] of loop time have passed."""
        end = self.now + limit
        while not condition():
            assert self.now < end, f'not within {limit} s (phases {self.phases[-5:]})'
            self.period()

    def goal(self, goal: str, target: str, limit: float = 120.0) -> GoalEnded:
        """Send a goal and run it to its end; return its result."""
        ended = len(self.of(GoalEnded))
        self.execute(self.runner.start_goal(goal, target, self.now, self.now))
        self.run_until(lambda: len(self.of(GoalEnded)) > ended, limit)
        return self.of(GoalEnded)[-1]

    def period(self) -> None:
        """One control period: the world moves, the runner hears it, decides and watches."""
        self.now = round(self.now + DT, 9)
        self._move()
        for change in [c for c in self.changes if c[0] <= self.now]:
            self.changes.remove(change)
            self.grippers[change[1]] = change[2:]
        runner = self.runner
        runner.joint_states(self.positions, self.velocities, self.now)
        runner.tip_pose(self.now, self.tip())
        if 'grippers' not in self.silent:
            self.execute(runner.gripper_states(self.grippers, self.now, self.now,
                                               self.position_errors))
        mode = self.rogue or self.mode
        self.execute(runner.controller_states(
            {joint: ControllerReport(self.now, False, mode == 'hold', mode,
                                     expected_role(joint, self.base))
             for joint in PHYSICAL_JOINT_NAMES if joint not in self.silent}, self.now,
            self.now))
        if self.now >= self.next_tick - 1e-9:
            self.next_tick = self.now + TICK_PERIOD
            self.execute(runner.tick(self.now, self.now))
        if self.now >= self.next_watch - 1e-9:
            self.next_watch = self.now + WATCH_PERIOD
            self.execute(runner.watch(self.now, self.now))

    def _move(self) -> None:
        previous = self.positions
        if self.stream is not None:
            ticket, trajectory, started = self.stream
            elapsed = self.now - started
            self.positions = np.array(trajectory.sample(min(elapsed, trajectory.duration))
                                      .position)
            if elapsed >= trajectory.duration + self.end_delay and not self.planner_dead:
                self.stream = None
                self.execute(self.runner.follow_done(ticket, True, '', self.now))
        self.velocities = (self.positions - previous) / DT

    # ------------------------------------------------------------------ commands
    def execute(self, commands: list) -> None:
        for command in commands:
            self.log.append(command)
            self.stamps.append(self.now)
            if isinstance(command, RenewPlannerClient) and self.heard_after_renewal:
                self.planner_silent = False
            if isinstance(command, SetControlMode):
                self.mode, self.base = command.mode, command.base_gripper
            elif isinstance(command, GripperRequest):
                self._gripper(command)
            elif isinstance(command, (PlanMotion, FollowMotion)):
                self._planner(command)
            elif isinstance(command, CancelFollow):
                if self.stream is not None and self.stream[0] == command.ticket \
                        and not self.planner_dead:  # a dead planner sends no hold
                    self.stream = None
            elif isinstance(command, DecideNow):
                self.execute(self.runner.tick(self.now, self.now))

    def _planner(self, command) -> None:
        """Answer at once with the planner core (unless silent), as a headless loop would."""
        self.runner.request_sent(command.ticket, self.now)
        if self.planner_silent or self.planner_dead:
            self.unanswered.append(command)
        elif isinstance(command, PlanMotion):
            answer = self.plan(command.call)
            self.planned.append((command.purpose, answer))
            self.execute(self.runner.plan_answered(command.ticket, answer, self.now))
        elif self.acceptances_lost:
            self.acceptances_lost -= 1
            self.unanswered.append(command)
        else:
            self.stream = (command.ticket, command.trajectory, self.now)
            self.execute(self.runner.follow_accepted(command.ticket, True, self.now))

    def plan(self, call) -> PlanAnswer:
        try:
            result = plan(call, PLANNING)
        except PlanningError as error:
            return PlanAnswer(False, str(error))
        trajectory = SampledTrajectory(result.times, *result.samples)
        return PlanAnswer(True, '', result.duration, result.time_optimal_bound or 0.0,
                          trajectory)

    def _gripper(self, request: GripperRequest) -> None:
        gripper, other = request.gripper, 'b' if request.gripper == 'a' else 'a'
        screw_time = PARAMS.gripper.screw_time
        if request.action == 'unscrew':
            if self.grippers[other][0] != 'attached':
                answer = (False, 'refused: it is the only gripper attached')
            else:
                if self.anchor == gripper:  # the arm now hangs from the other gripper
                    roles = physical_to_roles(self.positions, other)
                    self.frame = BaseFrame.from_stance(
                        KIN, roles, TRUSS.position(self.grippers[other][1]),
                        TRUSS.position(self.grippers[gripper][1]))
                    self.anchor = other
                node = self.grippers[gripper][1]
                self.grippers[gripper] = ('unscrewing', node)
                self.changes.append((self.now + screw_time, gripper, 'free', ''))
                answer = (True, '')
        else:
            node, _ = TRUSS.nearest_node(self.tip())
            hole = TRUSS.position(node) + np.array([*self.holes.get(node, (0.0, 0.0)), 0.0])
            distance = float(np.linalg.norm(self.tip()[:2] - hole[:2]))
            tolerance = PARAMS.gripper.insertion_position_tolerance
            if self.jam > 0 or distance > tolerance or abs(self.tip()[2]) > tolerance:
                self.jam = max(0, self.jam - 1)
                self.grippers[gripper] = ('jammed', node)
                answer = (False, f'jammed {distance * 1e3:.1f} mm off')
            else:
                self.grippers[gripper] = ('screwing', node)
                self.changes.append((self.now + screw_time, gripper, 'attached', node))
                answer = (True, '')
        self.execute(self.runner.gripper_answered(*answer, self.now))

