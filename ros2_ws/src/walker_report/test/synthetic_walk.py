"""A two-step walk with known content, written as a bag with walker_bag's core writer.

Everything the report computes is known from here: the phases (start and end of each), the
step reports, the tip's path (linear between the nodes, a known sine near each target), the
joint states (written in reversed name order), the controller states (a known peak torque, a
known number of clamped samples) and the torque limits of the recorded URDF.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from walker_bag.core.bag_metadata import TopicMetadata
from walker_bag.core.bag_reader import walker_typestore
from walker_bag.core.bag_writer import BagWriter
from walker_bag.core.message_definitions import message_definition, type_description_hash
from walker_bag.core.qos import QosProfile
from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_core.robot_parameters import load_walker_parameters
from walker_core.truss import Truss

NS = '/walker'
SENSOR = QosProfile('best_effort', 'volatile')
RELIABLE = QosProfile('reliable', 'volatile')
LATCHED = QosProfile('reliable', 'transient_local')
TOPICS = {
    'joint_states': ('sensor_msgs/msg/JointState', SENSOR),
    'tip_pose': ('geometry_msgs/msg/PoseStamped', SENSOR),
    'gripper_a_pose': ('geometry_msgs/msg/PoseStamped', SENSOR),
    'gripper_b_pose': ('geometry_msgs/msg/PoseStamped', SENSOR),
    'gripper_states': ('walker_msgs/msg/GripperStates', LATCHED),
    'phase': ('walker_msgs/msg/StepPhase', LATCHED),
    'step_reports': ('walker_msgs/msg/StepReport', LATCHED),
    'control_mode': ('walker_msgs/msg/ControlMode', LATCHED),
    'robot_description': ('std_msgs/msg/String', LATCHED),
    **{f'controllers/{j}/state': ('walker_msgs/msg/ControllerState', RELIABLE)
       for j in PHYSICAL_JOINT_NAMES},
}
PHASES = ('extraction', 'coarse', 'fine', 'insertion')
PHASE_CODES = {'idle': 0, 'extraction': 1, 'coarse': 2, 'fine': 3, 'insertion': 4,
               'safe hold': 5}
END = 12.5  # [s] the bag's last message
TIP_RATE, STATE_RATE = 100, 50  # [Hz]
#: Torque limits of the recorded URDF [N*m]: not the parameter file's (10, 12, 10, 12, 10).
URDF_LIMITS = {'a_yaw_joint': 9.0, 'a_pitch_joint': 11.0, 'vertex_joint': 9.5,
               'b_pitch_joint': 11.0, 'b_yaw_joint': 9.0}
PEAK_FRACTION = 0.6  # peak commanded torque over the limit, every joint
CLAMPED = 7  # a_pitch_joint samples flagged saturated
APPROACH = 0.03  # [m] height of the tip above the hole before insertion
PROGRESS_REPEAT = 0.01  # [s] after each phase entry, the phase again with more progress


@dataclasses.dataclass(frozen=True)
class Step:
    """A step of the synthetic walk; times in s, lengths in m."""

    index: int
    base: str
    moving: str
    base_node: str
    from_node: str
    to_node: str
    phases: dict[str, tuple[float, float]]
    vibration: float  # amplitude of the sine near the target [m]
    frequency: float  # [Hz]
    axis: int  # 0: x, 1: y
    offset: tuple[float, float]  # mean tip offset from the hole axis while settling [m]
    insertion_error: float
    residual: float

    @property
    def start(self) -> float:
        return self.phases['extraction'][0]

    @property
    def end(self) -> float:
        return max(b for _, b in self.phases.values())

    @property
    def insertion_start(self) -> float | None:
        return self.phases['insertion'][0] if 'insertion' in self.phases else None


STEPS = (
    Step(0, 'a', 'b', 'n1_1', 'n2_1', 'n1_2',
         {'extraction': (0.5, 2.0), 'coarse': (2.0, 3.0), 'fine': (3.0, 5.0),
          'insertion': (5.0, 6.0)}, 0.0015, 3.0, 0, (0.0, 0.0005), 0.0007, 0.0003),
    Step(1, 'b', 'a', 'n1_2', 'n1_1', 'n2_2',
         {'extraction': (6.5, 7.5), 'coarse': (7.5, 8.5), 'fine': (8.5, 11.0),
          'insertion': (11.0, 12.0)}, 0.0004, 5.0, 1, (0.0, 0.0), 0.0009, 0.0002),
)
SAFE_HOLD_AT = 10.0  # [s] where step 2 stops in the SAFE_HOLD variant
SAFE_HOLD_REASON = 'fine overran its planned time (settling)'


def walker_truss() -> Truss:
    return Truss.from_parameters(load_walker_parameters())


def _steps(safe_hold: bool) -> tuple[Step, ...]:
    if not safe_hold:
        return STEPS
    second = STEPS[1]
    phases = {'extraction': second.phases['extraction'], 'coarse': second.phases['coarse'],
              'fine': (second.phases['fine'][0], SAFE_HOLD_AT)}
    return STEPS[0], dataclasses.replace(second, phases=phases)


def tip_position(t: float, steps=STEPS, truss: Truss | None = None) -> np.ndarray:
    """Position [m] of the tip (the moving gripper) at ``t`` [s]."""
    truss = truss or walker_truss()
    current = steps[0]
    for step in steps:
        if t >= step.start:
            current = step
    step = current
    source, target = truss.position(step.from_node), truss.position(step.to_node)
    if t < step.start:
        return source
    if t >= step.end:
        return target if step.insertion_start is not None else _settled(step, t, target)
    ext, coarse = step.phases['extraction'], step.phases['coarse']
    if t < ext[1]:
        return source + [0.0, 0.0, APPROACH * (t - ext[0]) / (ext[1] - ext[0])]
    if t < coarse[1]:
        s = (t - coarse[0]) / (coarse[1] - coarse[0])
        return source + s * (target - source) + [0.0, 0.0, APPROACH]
    start = step.insertion_start
    if start is None or t < start:
        return _settled(step, t, target)
    s = min(1.0, (t - start) / (step.end - start))
    return target + [step.offset[0], step.offset[1], APPROACH * (1.0 - s)]


def _settled(step: Step, t: float, target: np.ndarray) -> np.ndarray:
    reference = step.insertion_start if step.insertion_start is not None else step.end
    point = target + [step.offset[0], step.offset[1], APPROACH]
    point[step.axis] += step.vibration * math.sin(2 * math.pi * step.frequency * (t - reference))
    return point


def phase_events(steps=STEPS, safe_hold: bool = False) -> list[tuple[float, str, int, int, str,
                                                                     str, str]]:
    """``(time, phase, step_index, step_count, from, to, reason)`` of every phase message."""
    events = [(0.0, 'idle', 0, 0, '', '', '')]
    for step in steps:
        for name in PHASES:
            if name in step.phases:
                events.append((step.phases[name][0], name, step.index, len(steps),
                               step.from_node, step.to_node, ''))
        if step.insertion_start is None and safe_hold:
            events.append((step.end, 'safe hold', step.index, len(steps), step.from_node,
                           step.to_node, SAFE_HOLD_REASON))
        else:
            events.append((step.end, 'idle', step.index + 1, len(steps), '', '', ''))
    return events


def _urdf() -> str:
    joints = ''.join(f'<joint name="{name}" type="revolute"><parent link="l{k}"/>'
                     f'<child link="l{k + 1}"/><axis xyz="0 0 1"/>'
                     f'<limit lower="-3" upper="3" effort="{limit}" velocity="1.5"/></joint>'
                     for k, (name, limit) in enumerate(URDF_LIMITS.items()))
    links = ''.join(f'<link name="l{k}"/>' for k in range(6))
    return f'<?xml version="1.0"?><robot name="walker">{links}{joints}</robot>'


class _Writer:
    def __init__(self, writer: BagWriter, typestore, topics) -> None:
        self.writer, self.store, self.t = writer, typestore, typestore.types
        for relative in topics:
            type_name, qos = TOPICS[relative]
            writer.add_topic(TopicMetadata(f'{NS}/{relative}', type_name, (qos,),
                                           type_description_hash(type_name)),
                             message_definition(type_name))
        self.topics = set(topics)

    def header(self, t: float, frame: str = ''):
        ns = int(round(t * 1e9))
        return self.t['std_msgs/msg/Header'](
            self.t['builtin_interfaces/msg/Time'](sec=ns // 10**9, nanosec=ns % 10**9), frame)

    def write(self, relative: str, t: float, message) -> None:
        if relative not in self.topics:
            return
        type_name = TOPICS[relative][0]
        data = bytes(self.store.serialize_cdr(message, type_name))
        self.writer.write(f'{NS}/{relative}', data, int(round(t * 1e9)))

    def pose(self, relative: str, t: float, position) -> None:
        t_ = self.t
        pose = t_['geometry_msgs/msg/Pose'](
            t_['geometry_msgs/msg/Point'](*(float(v) for v in position)),
            t_['geometry_msgs/msg/Quaternion'](0.0, 0.0, 0.0, 1.0))
        self.write(relative, t, t_['geometry_msgs/msg/PoseStamped'](self.header(t, 'truss'),
                                                                     pose))


def effort_at(joint: str, t: float) -> float:
    """Commanded torque of a joint at ``t`` [N*m]: peaks at PEAK_FRACTION of its URDF limit."""
    return PEAK_FRACTION * URDF_LIMITS[joint] * math.sin(2 * math.pi * t / 6.0)


def error_at(joint: str, t: float) -> float:
    """Position error of a joint at ``t`` [rad]: 0.2 rad during coarse motion, else 0.1 mrad."""
    coarse = any(s.phases['coarse'][0] <= t < s.phases['coarse'][1] for s in STEPS)
    return 0.2 if coarse and joint == 'a_yaw_joint' else 1e-4


def build_walk_bag(path: Path, *, reports: bool = True, controllers: bool = True,
                   description: bool = True, safe_hold: bool = False,
                   leave_out: tuple[str, ...] = (),
                   custom_data: dict[str, str] | None = None) -> Path:
    """Write the synthetic walk as a bag at ``path`` and return it.

    Parameters
    ----------
    reports, controllers, description : bool
        Record the step reports, the controller states, the URDF.
    safe_hold : bool
        Stop step 2 in SAFE_HOLD during fine motion (no insertion, no report for it).
    leave_out : tuple of str
        Further topics (relative names) not to record.
    custom_data : dict, optional
        Further ``custom_data`` of the bag (a recorder's record of its losses).
    """
    steps = _steps(safe_hold)
    truss = walker_truss()
    topics = [t for t in TOPICS if (reports or t != 'step_reports')
              and (controllers or not t.startswith('controllers/'))
              and (description or t != 'robot_description') and t not in leave_out]
    store = walker_typestore()
    with BagWriter(path, custom_data={'clock': 'sim_time', **(custom_data or {})}) as bag:
        w = _Writer(bag, store, topics)
        t_ = w.t
        messages = []  # (time, order, callable) written in time order
        if description:
            messages.append((0.0, 0, lambda: w.write(
                'robot_description', 0.0, t_['std_msgs/msg/String'](_urdf()))))
        for time_, name, index, count, source, target, reason in phase_events(steps, safe_hold):
            # each phase as the supervisor publishes it: on entry, and again as its progress
            # grows (the same phase, step and reason: not a new entry)
            for at, progress in ((time_, 0.0), (time_ + PROGRESS_REPEAT, 0.25)):
                def phase(time_=at, name=name, index=index, count=count, source=source,
                          target=target, reason=reason, progress=progress):
                    w.write('phase', time_, t_['walker_msgs/msg/StepPhase'](
                        header=w.header(time_), phase=PHASE_CODES[name],
                        base_gripper=STEPS[min(index, 1)].base, step_index=index,
                        step_count=count, from_node=source, to_node=target, base_node='',
                        base_heading=0.0, phase_progress=progress,
                        reason=reason))
                messages.append((at, 1, phase))
        for time_, states in gripper_events(safe_hold):
            def grippers(time_=time_, states=states):
                gripper = t_['walker_msgs/msg/GripperState']
                w.write('gripper_states', time_, t_['walker_msgs/msg/GripperStates'](
                    w.header(time_), [gripper(n, s, node, 0.0, 0.0, '')
                                      for n, (s, node) in states.items()]))
            messages.append((time_, 2, grippers))
        for time_, mode, base in (MODES if not safe_hold else MODES[:6]):
            messages.append((time_, 3, lambda time_=time_, mode=mode, base=base: w.write(
                'control_mode', time_, t_['walker_msgs/msg/ControlMode'](
                    w.header(time_), mode, base, '/walker/supervisor'))))
        for step in steps if reports else ():
            if step.insertion_start is None:
                continue
            messages.append((step.end, 4, lambda step=step: w.write(
                'step_reports', step.end, step_report(t_, w.header(step.end), step))))
        for k in range(int(round(END * TIP_RATE)) + 1):
            time_ = k / TIP_RATE

            def poses(time_=time_):
                tip = tip_position(time_, steps, truss)
                w.pose('tip_pose', time_, tip)
                second = time_ >= STEPS[1].start
                w.pose('gripper_a_pose', time_, tip if second else truss.position('n1_1'))
                w.pose('gripper_b_pose', time_, truss.position('n1_2') if second else tip)
            messages.append((time_, 5, poses))
        for k in range(int(round(END * STATE_RATE)) + 1):
            time_ = k / STATE_RATE
            messages.append((time_, 6, lambda time_=time_, k=k: _states(w, time_, k,
                                                                       controllers)))
        messages.sort(key=lambda m: (m[0], m[1]))
        for _, _, write in messages:
            write()
    return path


def joint_positions(t: float) -> np.ndarray:
    """Joint angles [rad], physical order, at ``t``."""
    return np.array([0.1 * math.sin(t), 0.3, 1.4, 0.3 + 0.01 * t, -0.1 * math.cos(t)])


def _states(w: _Writer, t: float, k: int, controllers: bool) -> None:
    t_ = w.t
    names = list(reversed(PHYSICAL_JOINT_NAMES))  # the report must reorder them
    position = np.ascontiguousarray(joint_positions(t)[::-1])
    w.write('joint_states', t, t_['sensor_msgs/msg/JointState'](
        w.header(t), names, position, np.zeros(5), np.zeros(5)))
    if not controllers:
        return
    for joint in PHYSICAL_JOINT_NAMES:
        efforts = dict.fromkeys((
            'velocity_setpoint', 'acceleration_setpoint', 'velocity', 'acceleration',
            'feedforward_effort', 'proportional_effort', 'integral_effort',
            'derivative_effort', 'acceleration_feedback_effort',
            'friction_compensation_effort'), 0.0)
        w.write(f'controllers/{joint}/state', t, t_['walker_msgs/msg/ControllerState'](
            header=w.header(t), joint_name=joint, role=1, mode=3, position_setpoint=0.0,
            position=-error_at(joint, t), position_error=error_at(joint, t),
            effort=effort_at(joint, t), saturated=joint == 'a_pitch_joint' and k < CLAMPED,
            stale=False, **efforts))


# (time, {gripper: (state, node)}): the grippers of the walk
def gripper_events(safe_hold: bool = False):
    events = [
        (0.0, {'a': (2, 'n1_1'), 'b': (2, 'n2_1')}),
        (0.5, {'a': (2, 'n1_1'), 'b': (3, 'n2_1')}),
        (1.0, {'a': (2, 'n1_1'), 'b': (0, '')}),
        (5.5, {'a': (2, 'n1_1'), 'b': (1, 'n1_2')}),
        (6.0, {'a': (2, 'n1_1'), 'b': (2, 'n1_2')}),
        (6.5, {'a': (3, 'n1_1'), 'b': (2, 'n1_2')}),
        (7.0, {'a': (0, ''), 'b': (2, 'n1_2')}),
    ]
    if not safe_hold:
        events += [(11.5, {'a': (1, 'n2_2'), 'b': (2, 'n1_2')}),
                   (12.0, {'a': (2, 'n2_2'), 'b': (2, 'n1_2')})]
    return events


# (time, ControlMode constant, base)
MODES = ((0.5, 3, 'a'), (2.0, 2, 'a'), (3.0, 3, 'a'), (6.0, 1, 'b'), (6.5, 3, 'b'),
         (7.5, 2, 'b'), (8.5, 3, 'b'), (12.0, 1, 'a'))


def step_report(t_, header, step: Step):
    durations = [step.phases[p][1] - step.phases[p][0] for p in PHASES]
    duration = step.end - step.start
    return t_['walker_msgs/msg/StepReport'](
        header=header, step_index=step.index, step_count=len(STEPS), base_gripper=step.base,
        moving_gripper=step.moving, base_node=step.base_node, from_node=step.from_node,
        to_node=step.to_node, sweep=math.pi / 2, success=True, message='',
        phase_names=list(PHASES), phase_durations=np.array(durations), duration=duration,
        time_optimal_bound=1.0, bound_ratio=duration, insertion_error=step.insertion_error,
        insertion_error_estimated=step.insertion_error, residual_vibration=step.residual,
        insertion_attempts=1, search_probes=0, hole_offset=0.0)
