"""The walk runner's shell in the lock-step loop: what the supervisor node does, by calls.

Every decision is :class:`~walker_supervisor.core.runner.WalkRunner`'s, the very object the
supervisor node drives. :class:`WalkShell` feeds it its events at the simulated times the
node hears them with the plant waiting for its decisions (``sim.wait_for_decisions``), and
carries out its commands on the loop's cores, as the node does over ROS
(``walker_supervisor.supervisor_node``, ``inputs``, ``links``):

* each state: the end of a stream (``follow_trajectory``'s result), the gripper states when
  the plant sends them (changed, or its heartbeat);
* every :data:`~walker_supervisor.core.runner.TICK_PERIOD` of simulated time, and at once when
  the runner asks (:class:`~walker_supervisor.core.commands.DecideNow`): the sampled inputs
  (the newest joint state, the tip poses since the last sample, each controller's newest
  state report), then the decision (:meth:`WalkRunner.tick`);
* every :data:`~walker_supervisor.core.runner.WATCH_PERIOD`: the watchdog, on simulated time
  (the only clock there is);
* its commands: the mode to the five controllers and the planner's hold, a gripper command to
  the plant core, a look to the plant core's wrist camera (the frame is exposed at once and
  rendered by the plant's render process while the loop steps on; it is answered once its
  exposure latency has passed, its render waited for then, so the frames are the same however
  long a render takes), planner requests to :class:`~walker_headless.planner.HeadlessPlanner`;
  the phase and the step reports to the bag and the walk's records, each frame of a look (with
  its truth) and the hole it showed to the bag
  (:class:`~walker_headless.camera_recording.CameraRecording`), the feedback to
  ``progress``, its notices to ``say``. The answers come back as the node's do, after the
  commands of the call that asked for them, and take no simulated time (the graph holds its
  clock for them).

What the node has and the loop has not is ignored: a planner client made anew, the
``control_mode`` publisher made anew, the step-state file of a restart, an operator's jog.
"""

from __future__ import annotations

import collections
import math
from collections.abc import Callable

from walker_core.camera import CameraModel
from walker_supervisor.core.commands import (
    CancelFollow, DecideNow, Feedback, FollowMotion, GoalEnded, GripperRequest, HoleSighted,
    LookRequest, Notice, PhaseRecord, PlanMotion, SetControlMode, StepRecord, StopOrphanStream)
from walker_supervisor.core.goals import GoalRefusedError
from walker_supervisor.core.reports import phase_fields, report_fields
from walker_supervisor.core.runner import TICK_PERIOD, WATCH_PERIOD, WalkRunner

from walker_headless import records
from walker_headless.camera_recording import CameraRecording
from walker_headless.loop import RobotLoop, stamp_seconds
from walker_headless.planner import HeadlessPlanner

__all__ = ['WalkShell', 'look_record']


def look_record(look, truths: dict) -> dict:
    """Return a look of the runner against the plant's truth, as ``summary.json`` keeps it.

    ``look`` is the runner's :class:`~walker_supervisor.core.sighting.LookResult`, ``truths``
    the true hole's axis in the gripper's frame [m] (x, y) at each frame's instant [s] (the
    plant's :class:`~walker_sim.core.wrist_camera.CameraFrame`). Each frame's error is taken in
    the gripper's frame at its instant and the frames' errors are weighted as the look weighs
    them (the links' ringing moves the gripper and the hole it sees alike): ``error`` [m] is
    that of the hole as the looks so far located it (what the step aims at), ``frame_error``
    [m] that of the frames alone, at the height the step assumed (both None when not seen);
    ``spread`` [m] is the located hole's stated standard deviation and ``offset`` [m] the true
    hole's distance from the gripper's axis. ``last_frame`` is the look's last frame (the one a
    walk report shows at a screw-in): its instant ``time`` [s] (its image's stamp), the hole's
    axis from the gripper's axis that frame alone ``measured`` [m] (x, y; None when not seen)
    and the ``true`` one [m] (x, y).
    """
    def error(name: str):
        pairs = [(f.weight, getattr(f, name) - truths[f.exposure_time]) for f in look.frames
                 if getattr(f, name) is not None]
        if not pairs:
            return None
        total = sum(w for w, _ in pairs)
        return float(math.hypot(*sum(w * e for w, e in pairs) / total))

    first, last = look.frames[0], look.frames[-1]
    return {'time': first.exposure_time, 'gripper': look.gripper, 'node': look.node,
            'frames': len(look.frames), 'seen': look.found, 'reason': look.reason,
            'error': error('located'), 'frame_error': error('measured'),
            'spread': look.spread if math.isfinite(look.spread) else None,
            'offset': float(math.hypot(*truths[first.exposure_time])), 'final': look.final,
            'last_frame': {
                'time': last.exposure_time,
                'measured': None if last.measured is None else [float(v) for v in last.measured],
                'true': [float(v) for v in truths[last.exposure_time]]}}


class WalkShell:
    """The walk runner composed with the loop's cores (see the module docstring).

    Parameters
    ----------
    loop : RobotLoop
        The plant, the controllers and the planner's streamer.
    say : callable, optional
        ``say(level, text)``: what the supervisor logs.
    progress : callable, optional
        ``progress(feedback, time)``: the goal's feedback, and the simulated time [s].

    Attributes
    ----------
    runner : WalkRunner
    phases : list of records.PhaseRecord
        Every phase published, in order.
    reports : list of records.StepReportRecord
        One per step ended.
    ended : GoalEnded or None
        The goal's result, once it has ended.
    refusal : str
        Why the goal was refused ('' when it was taken, or not yet given).
    """

    def __init__(self, loop: RobotLoop, say: Callable[[str, str], None] | None = None,
                 progress: Callable[[Feedback, float], None] | None = None) -> None:
        self.loop = loop
        self.planner = HeadlessPlanner(loop)
        configuration = loop.configuration
        self.runner = WalkRunner(configuration.walker, configuration.supervisor, self.planner.join)
        self._say = say or (lambda level, text: None)
        self._progress = progress
        self.phases: list[records.PhaseRecord] = []
        self.reports: list[records.StepReportRecord] = []
        self.ended: GoalEnded | None = None
        self.refusal = ''
        self._goal: tuple[str, str] | None = None  # (goal, target) to take at the next tick
        self._answers: collections.deque[Callable[[], list]] = collections.deque()
        self._tick_due = False
        self._tick_ns = round(TICK_PERIOD * 1e9)
        self._watch_ns = round(WATCH_PERIOD * 1e9)
        self._next_tick = self._next_watch = 0  # [ns]
        self._poses: list = []  # (stamp [s], tip position [m]) since the last sample
        self._map_version = -1  # the truss map's version last drawn
        self._frames: list = []  # wrist camera frames exposed and not yet ready (PendingFrame)
        self._truths: dict = {}  # the true hole in the gripper's frame, by frame instant
        #: every look the runner took, against the plant's truth (:func:`look_record`)
        self.looks: list[dict] = []
        camera = configuration.walker.gripper.camera
        self._camera_bag = CameraRecording(loop.recording, CameraModel.from_parameters(camera)) \
            if loop.recording is not None and camera.enabled else None

    @property
    def done(self) -> bool:
        """True once the goal has ended, or was refused."""
        return self.ended is not None or bool(self.refusal)

    def send_goal(self, goal: str, target: str) -> None:
        """Give the runner a ``walk_to`` or ``step`` goal at its next decision."""
        self._goal = (goal, target)

    # ------------------------------------------------------------------ each state
    def decide(self) -> None:
        """Hear the loop's state stamped ``loop.stamp`` and decide, as the node does then."""
        loop, runner = self.loop, self.runner
        stamp, now = loop.stamp, loop.time
        self._draw_map()  # the map as it starts, before the first decision changes it
        if loop.poses_out:
            state = loop.state
            self._poses.append((stamp_seconds(stamp), state.poses[state.tip].position))
        for ticket, completed, message in self.planner.take_ended():
            self._carry_out(runner.follow_done(ticket, completed, message, now))
        for pending in [f for f in self._frames if f.ready_time <= now]:
            self._frames.remove(pending)
            if pending.discarded:  # the plant was reset since
                continue
            frame = pending.result()  # rendered beside the loop while it stepped
            self._truths[frame.exposure_time] = frame.mouth_in_gripper[:2]
            if self._camera_bag is not None:
                self._camera_bag.frame(stamp, frame)
            runner.last_look = None
            commands = runner.frame_seen(frame.gripper, frame.image, frame.exposure_time, now)
            if runner.last_look is not None:
                self.looks.append(look_record(runner.last_look, self._truths))
            self._carry_out(commands)
        if loop.grippers_out:
            self._carry_out(runner.gripper_states(loop.gripper_readings(), now, now,
                                                  loop.gripper_position_errors()))
        if stamp >= self._next_tick:  # the node's timer, on its grid of simulated time
            self._tick_due = True
            while self._next_tick <= stamp:
                self._next_tick += self._tick_ns
        self._settle()
        if stamp >= self._next_watch:
            while self._next_watch <= stamp:
                self._next_watch += self._watch_ns
            self._carry_out(runner.watch(now, now))
            self._settle()
        self._draw_map()

    def _draw_map(self) -> None:
        """Draw the truss map if it has changed since last drawn, as the node latches it."""
        survey, viz = self.runner.mapped.map, self.loop.viz
        if viz is not None and survey.version != self._map_version:
            self._map_version = survey.version
            viz.truss_map(self.loop.stamp, survey.estimates())

    def _settle(self) -> None:
        """Decide while a decision is due, and hand the runner the answers waiting."""
        answers = self._answers
        while self._tick_due or answers:
            if self._tick_due:
                self._tick_due = False
                self._tick()
            else:
                self._carry_out(answers.popleft()())

    def _tick(self) -> None:
        loop, runner = self.loop, self.runner
        now = loop.time
        runner.joint_states(loop.state.position.copy(), loop.state.velocity.copy(), now)
        for stamp, point in self._poses:
            runner.tip_pose(stamp, point)
        self._poses.clear()
        self._carry_out(runner.controller_states(loop.take_reports(), now, now))
        if self._goal is not None:
            goal, self._goal = self._goal, None
            try:
                self._carry_out(runner.start_goal(*goal, now, now))
            except GoalRefusedError as error:
                self.refusal = str(error)
                self._say('warning', f'{goal[0]} to {goal[1]!r} rejected: {error}')
                if loop.recording is not None:
                    loop.recording.goal_rejection(loop.stamp, *goal, self.refusal)
                return
        self._carry_out(runner.tick(now, now))

    # ------------------------------------------------------------------ commands
    def _carry_out(self, commands: list) -> None:
        """Carry out the runner's commands in order; queue the answers they will have."""
        loop, runner, answers = self.loop, self.runner, self._answers
        now = loop.time
        for command in commands:
            if isinstance(command, SetControlMode):
                loop.command_mode(command.mode, command.base_gripper)
            elif isinstance(command, PhaseRecord):
                record = records.PhaseRecord(loop.stamp, **phase_fields(command))
                self.phases.append(record)
                if loop.recording is not None:
                    loop.recording.phase(record)
                    loop.viz.phase(loop.stamp, record.base_gripper, record.to_node)
            elif isinstance(command, PlanMotion):
                runner.request_sent(command.ticket, now)
                answer = self.planner.plan(command.call)
                answers.append(lambda t=command.ticket, a=answer:
                               runner.plan_answered(t, a, now))
            elif isinstance(command, FollowMotion):
                self._follow(command, now)
            elif isinstance(command, GripperRequest):
                answer = loop.plant.command_gripper(command.gripper, command.action)
                answers.append(lambda a=answer: runner.gripper_answered(*a, now))
            elif isinstance(command, LookRequest):
                self._frames.append(loop.plant.expose_camera(command.gripper))
            elif isinstance(command, HoleSighted):
                if self._camera_bag is not None:
                    self._camera_bag.hole(loop.stamp, command)
            elif isinstance(command, CancelFollow):
                self.planner.cancel(command.ticket)
            elif isinstance(command, DecideNow):
                self._tick_due = True
            elif isinstance(command, StepRecord):
                record = records.StepReportRecord(loop.stamp, **report_fields(command))
                self.reports.append(record)
                if loop.recording is not None:
                    loop.recording.step_report(record)
            elif isinstance(command, Feedback):
                if self._progress is not None:
                    self._progress(command, now)
            elif isinstance(command, GoalEnded):
                self.ended = command
            elif isinstance(command, Notice):
                self._say(command.level, command.message)
            elif isinstance(command, StopOrphanStream):
                self.planner.stop()

    def _follow(self, command: FollowMotion, now: float) -> None:
        runner, ticket = self.runner, command.ticket
        runner.request_sent(ticket, now)
        accepted, aborted = self.planner.follow(ticket, command.trajectory)
        self._answers.append(lambda: runner.follow_accepted(ticket, accepted, now))
        if aborted is not None:
            self._answers.append(lambda: runner.follow_done(ticket, False, aborted, now))
