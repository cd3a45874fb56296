"""The robot side of the walker in one lock-step loop: plant, five joint controllers, streamer.

What the node graph does over DDS in sim time (docs/architecture.md, "Timing"), by calls, with
the very core objects the nodes use:

* the plant core (:class:`~walker_sim.core.plant.WalkerPlant`) publishes the state stamped
  ``t_k``; its slower outputs (``/clock``, the gripper poses, the gripper states on change)
  are due as the plant node decides (:mod:`walker_sim.core.outputs`);
* the planner's streamer (:class:`~walker_planner.core.streamer.TrajectoryStreamer`) takes
  the state and sends the setpoints due, up to ``planner.stream.lookahead`` periods ahead,
  into the five controllers' setpoint buffers;
* each joint's :class:`~walker_control.core.channel.ControllerChannel` answers the state with
  its effort (the newest setpoint not later than ``t_k``), which the plant's
  :class:`~walker_sim.core.commands.EffortCommands` take as the plant node takes
  ``effort_commands``;
* the plant steps one control period with those efforts, to ``t_(k+1)``.

Between the answers and the step the caller may decide (the supervisor's tick): a mode
command reaches the controllers for the next state, a stream started now begins one period
after ``t_k``, and a gripper command acts on the plant before it steps, as in the graph whose
plant waits for the supervisor's decisions (``sim.wait_for_decisions``). Nothing waits for
anything: every setpoint is in place before the state it applies to, every effort answers its
state, and a run is the same however busy the machine is.

Stamps are integer nanoseconds; a controller sees them as the node does, ``sec + nanosec *
1e-9`` seconds. What the loop publishes goes to a recorder, if one is given
(:class:`~walker_headless.recording.WalkRecording`), and is kept for the supervisor's shell
(:mod:`~walker_headless.shell`): the gripper states when they go out, each controller's
newest state report.
"""

from __future__ import annotations

import math

import numpy as np

from walker_config.core.configuration import WalkerConfiguration
from walker_control.core.channel import ControllerChannel
from walker_control.core.inputs import Setpoint
from walker_control.core.joint_controller import Measurement
from walker_control.core.modes import Mode
from walker_core.gripper_state import GripperState
from walker_core.joint_roles import GRIPPERS, PHYSICAL_JOINT_NAMES
from walker_core.stamps import stamp_seconds
from walker_planner.core.streamer import TrajectoryStreamer
from walker_sim.core.commands import EffortCommands, seconds_to_ns
from walker_sim.core.outputs import StampedRate, gripper_states_key
from walker_sim.core.plant import PlantState, WalkerPlant
from walker_supervisor.core.controller_watch import ControllerReport

from walker_headless.viz import HeadlessViz

__all__ = ['RobotLoop', 'stamp_seconds', 'MODES']

#: The sequencer's mode names as ``walker_msgs/ControlMode`` values.
MODES = {'off': Mode.OFF, 'hold': Mode.HOLD, 'coarse': Mode.COARSE, 'fine': Mode.FINE}


class RobotLoop:
    """The plant, the five joint controllers and the planner's stream, lock-stepped.

    Parameters
    ----------
    configuration : WalkerConfiguration
        The walker's configuration (:func:`~walker_config.core.configuration.load_configuration`).
    recording : WalkRecording, optional
        Where the loop's messages go (none recorded without it).
    whole_trajectories : bool, optional
        The planner's streamer sends each trajectory once, whole, and the controllers hold
        and sample it (``TrajectoryStreamer``'s ``send_trajectory``), instead of one setpoint
        per period; by default as the graph's planner does (``planner.send_whole_trajectories``).

    Raises
    ------
    ParameterError
        If the plant refuses its settings.
    """

    def __init__(self, configuration: WalkerConfiguration, recording=None,
                 whole_trajectories: bool | None = None) -> None:
        self.configuration = configuration
        self.plant = WalkerPlant(*configuration.plant)
        self.period = configuration.controllers.sample_time
        self.period_ns = seconds_to_ns(self.period)
        self.channels = [ControllerChannel(configuration.controllers, joint)
                         for joint in PHYSICAL_JOINT_NAMES]
        stream = configuration.planner.stream
        if whole_trajectories is None:
            whole_trajectories = configuration.planner.send_whole_trajectories
        self.streamer = TrajectoryStreamer(
            self.period_ns, stream.lookahead, stream.start_tolerance, self._take_setpoints,
            self._take_trajectory if whole_trajectories else None)
        self.commands = EffortCommands(configuration.sim.command_timeout)
        self.recording = recording
        #: the viz node's TF and markers, drawn into the bag (None without one)
        self.viz = HeadlessViz(configuration, recording) if recording is not None else None
        self._clock_rate = StampedRate(configuration.sim.clock_rate)
        self._pose_rate = StampedRate(configuration.sim.pose_rate)
        # the node's heartbeat of the gripper states runs on the steady clock; here on the
        # only clock there is
        self._heartbeat = StampedRate(configuration.sim.gripper_state_rate)
        self._gripper_key: tuple | None = None
        self.stamp = 0  # [ns] of the state in self.state
        self.state: PlantState = self.plant.state()
        self.positions: list[float] = self.state.position.tolist()  # [rad] physical order
        self.velocities: list[float] = self.state.velocity.tolist()  # [rad/s]
        self.tracking = False
        self.poses_out = False  # the gripper poses went out with the state in self.state
        self.grippers_out = False  # and the gripper states (changed, or the heartbeat)
        #: the grip monitor: gripper-state messages sent, and those with no gripper attached
        self.grip_states = 0
        self.grip_losses = 0
        #: each controller's newest state report not yet taken (joint -> report)
        self.reports: dict[str, ControllerReport] = {}
        #: commands the drives refused (non-finite) and clamped at the torque limit, so far
        self.counts = {'refused': 0, 'saturated': 0}

    @property
    def time(self) -> float:
        """The state's time [s] (``stamp * 1e-9``, as a ROS clock reads it)."""
        return self.stamp * 1e-9

    def close(self) -> None:
        """Release the simulator."""
        self.plant.close()

    # ------------------------------------------------------------------ one period
    def sense(self) -> None:
        """Send the state stamped :attr:`stamp` out: to the recording and the planner's stream."""
        state, stamp = self.state, self.stamp
        self.positions = state.position.tolist()
        self.velocities = state.velocity.tolist()
        recording = self.recording
        if recording is not None:
            if self._clock_rate.due(stamp):
                recording.clock(stamp)
            recording.joint_states(stamp, self.positions, self.velocities,
                                   state.effort.tolist())
        self.poses_out = self._pose_rate.due(stamp)
        if recording is not None and self.poses_out:
            recording.poses(stamp, state)
        key = gripper_states_key(state)
        self.grippers_out = self._heartbeat.due(stamp, force=key != self._gripper_key)
        if self.grippers_out:
            self.grip_states += 1
            if not any(state.statuses[g].mode == GripperState.ATTACHED for g in GRIPPERS):
                self.grip_losses += 1
            if recording is not None:
                recording.gripper_states(stamp, state)
        self._gripper_key = key
        viz = self.viz
        if viz is not None:
            if self.grippers_out:
                viz.grippers(self.gripper_readings())
            poses = ({g: state.poses[g].matrix() for g in GRIPPERS} if self.poses_out
                     else None)  # the grippers' poses, heard at the plant's pose rate
            if not viz.flexible:
                viz.joint_state(stamp, self.positions, poses)
            elif self.poses_out:  # the plant's flexible joint states go out with the poses
                viz.joint_state(stamp, self.positions + self.plant.bending().tolist(), poses)
            viz.tick(stamp)
        if all(map(math.isfinite, self.positions)):  # the planner takes finite states only
            self.streamer.on_state(stamp, state.position)

    def control(self) -> None:
        """Each controller answers the state; the plant takes the efforts."""
        stamp = self.stamp
        seconds = stamp_seconds(stamp)
        positions, velocities = self.positions, self.velocities
        accelerations = self.state.acceleration.tolist()
        recording = self.recording
        receive = self.commands.receive
        for k, channel in enumerate(self.channels):
            measurement = Measurement(positions[k], velocities[k], accelerations[k], positions)
            output = channel.answer(seconds, measurement)
            effort = channel.last_effort
            if effort is not None:
                receive(channel.joint, effort, stamp)
            if output is not None and channel.state_due(seconds):
                stale = channel.reports_stale
                self.reports[channel.joint] = ControllerReport(
                    seconds, stale, output.mode == Mode.HOLD, Mode(output.mode).name.lower(),
                    int(channel.controller.role))
                if recording is not None:
                    recording.controller_state(stamp, channel.joint, measurement, output,
                                               stale)

    def step(self) -> None:
        """Step the plant one control period with the efforts in force."""
        torques, _ = self.commands.torques(self.stamp)
        state = self.state = self.plant.step(torques, self.period)
        self.stamp += self.period_ns
        counts = self.counts
        counts['refused'] += int(np.count_nonzero(state.refused))
        counts['saturated'] += int(np.count_nonzero(state.saturated))

    def gripper_readings(self) -> dict[str, tuple[GripperState, str]]:
        """Return gripper -> (state, node) as the plant's ``gripper_states`` says now."""
        statuses = self.state.statuses
        return {g: (statuses[g].mode, statuses[g].node) for g in GRIPPERS}

    def gripper_position_errors(self) -> dict[str, float]:
        """Return gripper -> its tip's distance from the nearest hole's axis [m] (the plant's)."""
        return {g: float(self.state.grippers[g].alignment.position_error) for g in GRIPPERS}

    def take_reports(self) -> dict[str, ControllerReport]:
        """Return each controller's newest state report since the last call (joint -> report)."""
        reports, self.reports = self.reports, {}
        return reports

    # ------------------------------------------------------------------ commands
    def command_mode(self, mode: str, base_gripper: str) -> None:
        """Put the five controllers (and the planner's hold) in ``mode`` for ``base_gripper``."""
        value = MODES[mode]
        now = self.time
        for channel in self.channels:
            channel.command_mode(value, base_gripper, now, now)
        self.tracking = value.tracks_setpoints
        self.streamer.on_control_mode(self.tracking)
        if self.recording is not None:
            self.recording.control_mode(self.stamp, int(value), base_gripper)
            self.viz.base(self.stamp, base_gripper)

    def _take_trajectory(self, start: int, trajectory) -> None:
        """Give each controller a whole trajectory from ``start`` [ns] (physical order)."""
        velocities = () if trajectory.velocities is None else trajectory.velocities
        accelerations = () if trajectory.accelerations is None else trajectory.accelerations
        for channel in self.channels:
            channel.take_trajectory(PHYSICAL_JOINT_NAMES, trajectory.times,
                                    trajectory.positions, velocities, accelerations,
                                    stamp_seconds(start))

    def _take_setpoints(self, stamp: int, positions, velocities, accelerations) -> None:
        seconds = stamp_seconds(stamp)
        now = self.time
        for k, channel in enumerate(self.channels):
            channel.take_setpoint('', Setpoint(positions[k], velocities[k], accelerations[k]),
                                  seconds, now)
