"""Messages to and from the walk runner's plain values (the supervisor's ROS layer).

Nothing here decides: each function turns a message into what
:class:`~walker_supervisor.core.runner.WalkRunner` takes, or one of its records and commands
into the message the node publishes or sends.
"""

from __future__ import annotations

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PointStamped
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory
from walker_msgs.action import Step, WalkTo
from walker_msgs.msg import (
    ControllerState, ControlMode, GripperStates, StepPhase, StepReport)
from walker_msgs.srv import PlanTrajectory

from walker_core.gripper_state import GripperState, reported_state
from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_core.urdf import GRIPPER_LINKS
from walker_planner.conversions import chained_message
from walker_supervisor.core.commands import (
    Feedback, GoalEnded, HoleSighted, PhaseRecord, SetControlMode, StepRecord)
from walker_supervisor.core.controller_watch import ControllerReport
from walker_supervisor.core.prepared_motions import PlanAnswer, stream_lead
from walker_supervisor.core.reports import phase_fields, report_fields

__all__ = ['MODES', 'joint_arrays', 'gripper_readings', 'gripper_position_errors',
           'gripper_state_code',
           'controller_report', 'seconds', 'mode_message', 'phase_message', 'report_message',
           'hole_message',
           'feedback_message', 'result_message', 'plan_request_message', 'plan_answer',
           'join_answers', 'diagnostics_message']

MODES = {'off': ControlMode.OFF, 'hold': ControlMode.HOLD, 'coarse': ControlMode.COARSE,
         'fine': ControlMode.FINE}


def seconds(stamp) -> float:
    """Return a ``builtin_interfaces/Time`` in seconds."""
    return stamp.sec + stamp.nanosec * 1e-9


def stamp_nanoseconds(stamp) -> int:
    """Return a ``builtin_interfaces/Time`` in nanoseconds."""
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def joint_arrays(msg: JointState) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Return positions [rad] and velocities [rad/s] in physical order (None: not all there)."""
    index = {name: i for i, name in enumerate(msg.name)}
    if not all(name in index for name in PHYSICAL_JOINT_NAMES):
        return None, None
    order = [index[name] for name in PHYSICAL_JOINT_NAMES]
    if len(msg.position) != len(msg.name):
        return None, None
    positions = np.array([msg.position[i] for i in order])
    velocities = (np.array([msg.velocity[i] for i in order])
                  if len(msg.velocity) == len(msg.name) else None)
    return positions, velocities


def gripper_readings(msg: GripperStates) -> dict[str, tuple[str, str]]:
    """Return gripper -> (state, node) of a ``GripperStates`` message.

    The state is a :class:`~walker_core.gripper_state.GripperState`, or
    ``walker_core.gripper_state.UNKNOWN`` for a code the message does not define.
    """
    return {state.name: (reported_state(state.state), state.node) for state in msg.grippers}


def gripper_position_errors(msg: GripperStates) -> dict[str, float]:
    """Return gripper -> its tip's distance from the nearest hole's axis [m], as the plant says."""
    return {state.name: float(state.position_error) for state in msg.grippers}


def gripper_state_code(state: str) -> int:
    """Return the ``walker_msgs/GripperState`` constant of ``state`` (FREE for an unknown one)."""
    try:
        return GripperState(state).code
    except ValueError:
        return GripperState.FREE.code


#: ``walker_msgs/ControllerState`` mode constants -> the supervisor's mode names
_CONTROLLER_MODES = {ControllerState.OFF: 'off', ControllerState.HOLD: 'hold',
                     ControllerState.COARSE: 'coarse', ControllerState.FINE: 'fine'}


def controller_report(msg: ControllerState) -> ControllerReport:
    """Return a controller's state message as the runner reads it."""
    return ControllerReport(seconds(msg.header.stamp), bool(msg.stale),
                            msg.mode == ControllerState.HOLD,
                            _CONTROLLER_MODES.get(msg.mode, 'unknown'), int(msg.role))


def mode_message(command: SetControlMode, stamp, commander: str) -> ControlMode:
    """Return the ``control_mode`` message of a mode command, stamped ``stamp``.

    ``commander``: the supervisor's fully qualified node name, the one the controllers and the
    planner take mode commands from (:mod:`walker_core.mode_command`).
    """
    message = ControlMode(mode=MODES[command.mode], base_gripper=command.base_gripper,
                          commander=commander)
    message.header.stamp = stamp
    return message


def phase_message(record: PhaseRecord, stamp) -> StepPhase:
    """Return the ``phase`` message of a phase record."""
    message = StepPhase(**phase_fields(record))
    message.header.stamp = stamp
    return message


def report_message(record: StepRecord, stamp) -> StepReport:
    """Return the ``step_reports`` message of a step that ended."""
    message = StepReport(**report_fields(record))
    message.header.stamp = stamp
    return message


def hole_message(record: HoleSighted) -> PointStamped:
    """Return the ``camera_<g>/hole`` message of a frame: the hole in the gripper's frame."""
    message = PointStamped()
    stamp = message.header.stamp
    stamp.sec, stamp.nanosec = divmod(round(record.exposure_time * 1e9), 1_000_000_000)
    message.header.frame_id = GRIPPER_LINKS[record.gripper]
    message.point.x, message.point.y, message.point.z = (float(v) for v in record.point)
    return message


def feedback_message(feedback: Feedback):
    """Return the action feedback of a goal's progress (``WalkTo`` or ``Step``)."""
    if feedback.goal == 'walk_to':
        return WalkTo.Feedback(step_index=feedback.step_index, step_count=feedback.step_count,
                               phase=int(feedback.phase), from_node=feedback.from_node,
                               to_node=feedback.to_node,
                               tip_position_error=feedback.tip_position_error)
    return Step.Feedback(phase=int(feedback.phase),
                         phase_progress=float(feedback.phase_progress),
                         tip_position_error=feedback.tip_position_error)


def result_message(ended: GoalEnded):
    """Return the action result of a goal that ended (``WalkTo`` or ``Step``)."""
    if ended.goal == 'walk_to':
        return WalkTo.Result(success=ended.success, message=ended.message,
                             steps_taken=ended.steps_taken, duration=ended.duration,
                             path=list(ended.path))
    return Step.Result(success=ended.success, message=ended.message,
                       base_gripper=ended.base_gripper, base_node=ended.base_node,
                       duration=float(ended.step_duration),
                       time_optimal_bound=float(ended.time_optimal_bound),
                       insertion_error=float(ended.insertion_error))


def plan_request_message(call) -> PlanTrajectory.Request:
    """Return the ``plan_trajectory`` request of a planner core request."""
    return PlanTrajectory.Request(
        trajectory_type=call.trajectory_type, base_gripper=call.base_gripper,
        start=[float(v) for v in call.start], goal=[float(v) for v in call.goal],
        duration=float(call.duration), max_velocity=float(call.max_velocity),
        max_acceleration=float(call.max_acceleration),
        start_joints=[float(v) for v in call.start_joints], min_radius=float(call.min_radius),
        sweep_direction=int(call.sweep_direction))


def plan_answer(future) -> PlanAnswer | None:
    """Return the answer of a done ``plan_trajectory`` future; None if the call failed."""
    try:
        response = future.result()
    except Exception:  # a failed call is a plan that will not come
        return None
    if response is None:
        return None
    return PlanAnswer(response.success, response.message, response.duration,
                      response.time_optimal_bound, response.trajectory)


def join_answers(first: PlanAnswer, second: PlanAnswer, lead: float) -> JointTrajectory:
    """Join two ``plan_trajectory`` answers, the second ``lead`` [s] before the first ends.

    The lead is kept within both (:func:`~walker_supervisor.core.prepared_motions.stream_lead`;
    :func:`walker_planner.conversions.chained_message` joins them).
    """
    return chained_message(first.trajectory, second.trajectory,
                           stream_lead(first, second, lead))


def diagnostics_message(name: str, hardware_id: str, level, summary: str,
                        values: list[tuple[str, str]], stamp) -> DiagnosticArray:
    """Return a ``/diagnostics`` message of one status."""
    status = DiagnosticStatus(name=name, hardware_id=hardware_id, message=summary)
    status.level = bytes([int(level)])  # a one-byte field in rclpy
    status.values = [KeyValue(key=key, value=value) for key, value in values]
    message = DiagnosticArray(status=[status])
    message.header.stamp = stamp
    return message
