"""The plant node: the simulated walker on the ROS graph (``ros2 run walker_sim plant_node``).

Thin layer over :class:`walker_sim.core.plant.WalkerPlant`: it declares the parameters, converts
messages and clocks, and calls the core. Interfaces (relative to the node's namespace, normally
``/walker``), as docs/architecture.md specifies:

* publishes ``joint_accelerations`` then ``joint_states`` every control period; ``tip_pose``,
  ``gripper_a_pose``, ``gripper_b_pose`` (truss frame) and ``flexible_joint_states`` (every
  joint the plant simulates: the five and the links' passive bending joints, as a simulator
  publishes them) at ``sim.pose_rate``, with the joint state's stamp;
  ``gripper_states`` (on change, and at ``sim.gripper_state_rate`` on the steady clock: a
  liveness heartbeat); ``robot_description`` (once, latched);
  ``/clock`` (sim time, at ``sim.clock_rate``);
  ``/diagnostics`` (1 Hz, wall clock: missed commands, refused and clamped torques);
  ``joint_accelerations`` and the poses only while subscribed (:mod:`walker_runtime.listened`);
* subscribes to ``effort_commands`` (``sensor_msgs/JointState``: joint names and efforts,
  stamped with the state they answer) and, in sim time, ``supervisor/decided_until``
  (``rosgraph_msgs/Clock``: with ``sim.wait_for_decisions`` no state is stepped to past it);
* serves ``gripper_command`` (``walker_msgs/srv/GripperCommand``): answers at once with the
  gripper's new state (SCREWING, UNSCREWING, JAMMED, or the refusal), the turn done
  ``gripper.screw_time`` later (``gripper_states``); cameras: :mod:`walker_sim.camera_publishers`.

Clock modes (``sim.clock_mode``): ``real_time`` steps on a steady wall-clock timer, like
hardware, stamping with the system clock; ``sim_time`` publishes ``/clock`` and is lock-stepped
with the controllers (state for t_k out, wait for the five efforts stamped t_k, step). In sim
time, with the five controllers as one node in the same process (``run_all.py
--composed-loop``), the state goes to them and their efforts come back by call
(:meth:`PlantNode.hand_states_to`), not through DDS.
"""

from __future__ import annotations

import math
import sys

from rcl_interfaces.msg import ParameterDescriptor
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock as ClockMsg
from sensor_msgs.msg import JointState

from walker_core.joint_roles import GRIPPERS
from walker_runtime.node_parameters import declare_section, guard_section_updates
from walker_runtime.realtime import log_realtime_request
from walker_core.robot_parameters import WalkerParameters
from walker_runtime.node_main import run_node
from walker_core.text import unknown_choice
from walker_msgs.srv import GripperCommand
from walker_sim.core.commands import (
    CommandError, DecisionGate, EffortCommands, LockStep, seconds_to_ns)
from walker_sim.core.config import SimParameters
from walker_core.gripper_state import TURNING
from walker_sim.core.outputs import StampedRate, gripper_states_key
from walker_sim.core.plant import PlantState, WalkerPlant
from walker_sim.core.snapshot import SnapshotKeeper
from walker_sim.messages import COMMAND_QOS, gripper_state_msg, stamp_ns
from walker_sim.camera_publishers import CameraPublishers
from walker_sim.plant_publishers import PlantPublishers
from walker_sim.state_handover import StateHandover

__all__ = ['PlantNode', 'main']

# [s] steady-clock period of the sim-time watch (timeouts, re-sends); also the pace at which
# the plant steps when no controller answers at all
_WATCH_PERIOD = 0.005
# [s] period of /diagnostics and of the throttled warnings (wall clock)
_REPORT_PERIOD = 1.0
# Most control periods a late real-time tick steps at once to catch up with the wall clock
_MAX_CATCH_UP = 10
#: The commands of gripper_command: the plant core's action for each (how an unknown one is
#: refused, by name)
_GRIPPER_COMMANDS = {'SCREW_IN': GripperCommand.Request.SCREW_IN,
                     'UNSCREW': GripperCommand.Request.UNSCREW}
_GRIPPER_ACTIONS = {code: name.lower() for name, code in _GRIPPER_COMMANDS.items()}


class PlantNode(Node):
    """ROS node around the walker plant (invalid parameters: ParameterError, no start)."""

    def __init__(self, **kwargs) -> None:
        super().__init__('plant', **kwargs)
        self.params = declare_section(self, WalkerParameters)
        self.sim = declare_section(self, SimParameters, 'sim.')
        self.plant = WalkerPlant(self.params, self.sim)
        # the physical state a killed plant had, restored as a driver re-reads its encoders
        self._snapshots = SnapshotKeeper(self.declare_parameter(
            'state_file', '', ParameterDescriptor(description=(
                "file of the plant's state snapshot: restored from when it exists, kept up "
                "to date ('' : none)"), read_only=True)).value)
        restored = self._snapshots.restore_into(self.plant)
        self.period = 1.0 / self.params.timing.control_rate
        self.period_ns = seconds_to_ns(self.period)
        self.commands = EffortCommands(self.sim.command_timeout)
        self.lockstep = LockStep(self.sim.lockstep_timeout)
        self.gate = DecisionGate(self.sim.decision_timeout)
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._system = Clock(clock_type=ClockType.SYSTEM_TIME)
        self.sim_time = self.sim.clock_mode == 'sim_time'
        self._clock_rate = StampedRate(self.sim.clock_rate)
        self._pose_rate = StampedRate(self.sim.pose_rate)
        self._out = PlantPublishers(self, self.params, self.sim_time)
        self._cameras = CameraPublishers(self, self.params, self.sim)
        self.create_subscription(JointState, 'effort_commands', self._on_effort, COMMAND_QOS)
        if self.sim_time:
            self.create_subscription(ClockMsg, 'supervisor/decided_until', self._on_decided,
                                     COMMAND_QOS)
        self.create_service(GripperCommand, 'gripper_command', self._on_gripper_command)
        guard_section_updates(self, SimParameters, 'sim.', lambda: self.sim, self._apply_sim)
        self._counts = {'refused': 0, 'saturated': 0, 'expired': 0, 'overruns': 0}
        self._gripper_key: tuple | None = None
        self._last_tick = math.nan
        self._last_tick_wall = math.nan  # [s] steady time the last real-time tick ran
        self._longest_tick_interval = 0.0  # [s] the longest wall time between two ticks
        self._loop_closed = False  # every controller has answered (real time)
        self._started = not self.sim_time
        self._handover: StateHandover | None = None  # controllers in this process (sim time)
        self._last_sent = self._steady_now()
        self._last_warning = -math.inf
        self._stamp = 0 if self.sim_time else self._system.now().nanoseconds
        if restored is not None:
            self.get_logger().info(f'plant state restored from {self._snapshots.path} at '
                                   f't={restored.time:.3f} s, base gripper {restored.base}')
            if self.sim_time:
                self._stamp = round(restored.time / self.period) * self.period_ns
        self._publish(self.plant.state())
        self.create_timer(_REPORT_PERIOD, self._report, clock=self._steady)
        self.create_timer(1.0 / self.sim.gripper_state_rate, self._heartbeat,
                          clock=self._steady)
        if self.sim_time:
            self.create_timer(_WATCH_PERIOD, self._watch, clock=self._steady)
        else:
            self.create_timer(self.period, self._tick, clock=self._steady)
        self.get_logger().info(
            f'plant ready: {self.sim.clock_mode}, control {self.params.timing.control_rate:g} '
            f'Hz, physics {self.sim.physics_rate:g} Hz, base gripper {self.plant.state().base}')
        if not self.sim_time and self.get_parameter('use_sim_time').value:
            self.get_logger().warning(
                'use_sim_time is true but sim.clock_mode is real_time: nobody publishes /clock '
                'and the stamps are wall-clock time; set sim.clock_mode:=sim_time for sim time')

    def request_realtime_scheduling(self) -> bool:
        """Ask for ``SCHED_FIFO`` (``timing.realtime_priority``) on the wall clock, and log it.

        Called by :func:`main`, for the process the node owns: a node built inside another
        process (a composed graph, a test) leaves that process's scheduling alone.
        """
        if self.sim_time:
            return False
        return log_realtime_request(self.get_logger(), self.params.timing.realtime_priority)

    def hand_states_to(self, controllers, planner=None) -> None:
        """Sim time: hand each state to ``controllers`` (and ``planner``) here by a call.

        ``controllers`` is a controller node of this process answering every joint, connected
        with its ``answer_plant_directly(self.take_efforts)``; a ``planner`` streaming by call
        takes each state first (:mod:`walker_sim.state_handover`). ``joint_states`` and
        ``joint_accelerations`` are still published for every other subscriber.

        Raises
        ------
        ValueError
            In real time: the wall clock paces the plant, and a controller's answer is not
            waited for, so the exchange stays on DDS.
        """
        if not self.sim_time:
            raise ValueError('states are handed to controllers by call only in sim time '
                             '(sim.clock_mode: sim_time)')
        self._handover = StateHandover(controllers, self._steady_now, planner)
        controllers.answer_plant_directly(self.take_efforts)

    def take_efforts(self, message: JointState) -> None:
        """Take an ``effort_commands`` message from controllers in this process."""
        self._on_effort(message)

    @property
    def handover_pending(self) -> bool:
        """A state waits to be handed to the controllers (see :meth:`hand_over_states`)."""
        return self._handover is not None and self._handover.pending

    def hand_over_states(self, budget: float = 0.002) -> None:
        """Hand the newest state to the controllers in this process, and the next, and so on.

        For at most ``budget`` seconds of wall time (:meth:`StateHandover.run`). The process's
        spin loop calls it between two turns of its executor (``walker_bringup.composition``),
        so that setpoints, modes, timers and services are served between two slices of the
        loop.
        """
        if self._handover is not None:
            self._handover.run(budget)

    def destroy_node(self) -> None:
        """Release the simulator with the node."""
        self.plant.close()
        super().destroy_node()

    # ------------------------------------------------------------------ clocks
    def _steady_now(self) -> float:
        return self._steady.now().nanoseconds * 1e-9

    def _apply_sim(self, sim: SimParameters) -> None:
        self.sim = sim
        self.commands.command_timeout = sim.command_timeout
        self.lockstep.timeout = sim.lockstep_timeout
        self.gate.timeout = sim.decision_timeout
        self._clock_rate.rate, self._pose_rate.rate = sim.clock_rate, sim.pose_rate
        if not sim.wait_for_decisions:
            self.gate.open()
            if self.sim_time and self._started:
                self._try_advance()  # it may have been waiting at the gate just dropped
        if sim.jam_screw_ins != self.plant.fouled_screw_ins:
            self.plant.foul_thread(sim.jam_screw_ins)
            self.get_logger().warning(
                f'fault injected: the next {sim.jam_screw_ins} screw-ins jam (sim.jam_screw_ins)'
                if sim.jam_screw_ins else 'injected fault cleared: screw-ins jam only when '
                'out of tolerance')

    def _count_down_injected_jams(self) -> None:
        """Keep ``sim.jam_screw_ins`` equal to the jams still to come, for ``ros2 param get``."""
        if self.plant.fouled_screw_ins != self.sim.jam_screw_ins:
            self.set_parameters([Parameter('sim.jam_screw_ins',
                                           value=self.plant.fouled_screw_ins)])

    # ------------------------------------------------------------------ stepping
    def _advance(self, periods: int = 1) -> None:
        """Step the plant ``periods`` control periods with the commands in force; publish."""
        torques, expired = self.commands.torques(self._stamp)
        self._counts['expired'] += len(expired)
        state = self.plant.step(torques, periods * self.period)
        self._counts['refused'] += int(state.refused.sum())
        self._counts['saturated'] += int(state.saturated.sum())
        self._stamp = (self._stamp + self.period_ns if self.sim_time
                       else self._system.now().nanoseconds)
        self._publish(state)

    def _tick(self) -> None:
        """Real time: advance the physics by the wall-clock time since the last tick.

        Normally one control period. When the process was late (a loaded machine), the physics
        still follows the wall clock, as hardware would: the missed periods are stepped at
        once (up to :data:`_MAX_CATCH_UP`) with the commands in force, their states are never
        published, and they are counted as overruns.
        """
        now = self._steady_now()
        if not self._loop_closed:  # start-up (discovery, first publications) is not the loop
            self._loop_closed = all(self.commands.stamp_of(joint) is not None
                                    for joint in self.lockstep.joints)
        elif math.isfinite(self._last_tick_wall):
            self._longest_tick_interval = max(self._longest_tick_interval,
                                              now - self._last_tick_wall)
        self._last_tick_wall = now
        periods = 1
        if math.isfinite(self._last_tick):
            periods = min(max(1, round((now - self._last_tick) / self.period)), _MAX_CATCH_UP)
        self._counts['overruns'] += periods - 1
        self._last_tick += periods * self.period
        if not math.isfinite(self._last_tick) or now - self._last_tick > self.period:
            self._last_tick = now  # too far behind to catch up: let time slip
        self.lockstep.count_misses(self.commands)
        self._advance(periods)

    def _try_advance(self) -> None:
        """Sim time: step when every joint waited for has answered the current state."""
        waiting = self.lockstep.waiting_for(self.commands)
        if waiting or len(self.lockstep.lost) == len(self.lockstep.joints):
            return
        if not self._started:
            self._started = True
            self.get_logger().info('every controller answered: sim time starts')
        if not self.gate.allows(self._stamp + self.period_ns):
            self.gate.wait(self._steady_now())
            return
        self.lockstep.count_misses(self.commands)
        self._advance()

    def _watch(self) -> None:
        """Sim time: re-send the first state, or give up waiting after the timeout."""
        now = self._steady_now()
        if not self._started:
            if now - self._last_sent >= self.sim.startup_resend_period:
                self._publish(self.plant.state())
                self._warn(now, 'waiting for effort commands stamped t=0 from: '
                           + ', '.join(self.lockstep.waiting_for(self.commands)))
            return
        if not self.gate.allows(self._stamp + self.period_ns):
            self.gate.wait(now)  # a release that held the clock where it stood restarts no wait
            if self.gate.expired(now):
                self.gate.drop()
                self._warn(now, f'the supervisor has not decided beyond t={self._stamp * 1e-9:.3f}'
                           f' s within {self.gate.timeout:g} s: not waiting for it until it '
                           'does (sim.wait_for_decisions)')
                self._try_advance()
            return
        if len(self.lockstep.lost) == len(self.lockstep.joints):
            self.lockstep.count_misses(self.commands)
            self._advance()
        elif self.lockstep.expired(now):
            late = self.lockstep.give_up(self.commands)
            self._warn(now, f'no effort from {", ".join(late)} within '
                       f'{self.lockstep.timeout:g} s at t={self._stamp * 1e-9:.3f} s: applying '
                       f'the last ones and not waiting for them until they answer again')
            self._advance()

    # ------------------------------------------------------------------ publishing
    def _publish(self, state: PlantState) -> None:
        stamp = self._stamp
        # /clock at its rate, and at every state the supervisor's release stops at: its
        # ROS-time timer must see the time it released up to
        if self.sim_time and self._clock_rate.due(
                stamp, force=not self.gate.allows(stamp + self.period_ns)):
            self._out.clock(stamp)
        accelerations, joint_states = self._out.state(state, stamp)
        if self._pose_rate.due(stamp):
            self._out.poses(state, self.plant.bending(), stamp)
        self._cameras.publish(self.plant, stamp)  # frames triggered (or streamed) only
        self._publish_grippers(state)
        self._last_sent = self._steady_now()
        self.lockstep.begin(stamp, self._last_sent)
        if self._handover is not None:
            self._handover.offer(accelerations, joint_states)

    def _publish_grippers(self, state: PlantState, force: bool = False) -> None:
        key = gripper_states_key(state)
        self._snapshots.keep(self.plant, self._steady_now(), key)
        if force or key != self._gripper_key:
            self._out.grippers(state, self._stamp)
            self._gripper_key = key

    def _heartbeat(self) -> None:
        """Publish the gripper states on the steady clock: the plant's liveness heartbeat.

        It keeps coming while sim time stands still (waiting for a controller), so that a
        watchdog can tell a waiting plant from a dead one.
        """
        self._publish_grippers(self.plant.state(), force=True)

    def _report(self) -> None:
        """Publish /diagnostics: missed, expired, refused and clamped commands, late ticks."""
        self._out.diagnostics(self.sim, self.plant.time, self.lockstep, self.gate, self._counts,
                              None if self.sim_time else self._longest_tick_interval,
                              self._stamp)

    def _warn(self, now: float, text: str) -> None:
        if now - self._last_warning >= _REPORT_PERIOD:
            self.get_logger().warning(text)
            self._last_warning = now

    # ------------------------------------------------------------------ callbacks
    def _on_effort(self, message: JointState) -> None:
        if len(message.effort) != len(message.name):
            self._warn(self._steady_now(), f'effort command refused: {len(message.name)} '
                       f'names but {len(message.effort)} efforts')
            return
        stamp = stamp_ns(message.header.stamp)
        for name, effort in zip(message.name, message.effort, strict=True):
            try:
                self.commands.receive(name, effort, stamp)
            except CommandError as error:
                self._warn(self._steady_now(), str(error))
        if self.sim_time:
            self._try_advance()

    def _on_decided(self, message: ClockMsg) -> None:
        """Take the time up to which the supervisor has decided (``sim.wait_for_decisions``)."""
        if not self.sim.wait_for_decisions:
            return
        self.gate.release(stamp_ns(message.clock))
        if self._started and self.gate.allows(self._stamp + self.period_ns):
            self._try_advance()

    def _on_gripper_command(self, request: GripperCommand.Request,
                            response: GripperCommand.Response) -> GripperCommand.Response:
        gripper = request.gripper
        action = _GRIPPER_ACTIONS.get(request.command)
        if action is None:
            response.success = False
            response.message = unknown_choice('gripper command', request.command,
                                              _GRIPPER_COMMANDS)
        else:
            response.success, response.message = self.plant.command_gripper(gripper, action)
            if action == 'screw_in':
                self._count_down_injected_jams()
        state = self.plant.state()
        if gripper in GRIPPERS:
            response.state = gripper_state_msg(state.grippers[gripper])
        if not response.success:
            self.get_logger().warning(f'gripper command refused: {response.message}')
        elif state.statuses[gripper].mode in TURNING:
            self.get_logger().info(f'gripper {gripper}: {state.statuses[gripper].mode.name}')
        self._publish_grippers(state, force=True)
        return response


def main(args=None) -> int:
    """Run the plant node until shut down; exit codes of :mod:`walker_runtime.node_main`."""
    return run_node(PlantNode, 'plant', args, start=PlantNode.request_realtime_scheduling)


if __name__ == '__main__':
    sys.exit(main())
