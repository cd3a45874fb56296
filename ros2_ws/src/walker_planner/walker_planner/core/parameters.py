"""The planner's parameters: the ``planner.*`` group of the one parameter file.

They live in ``walker_core/config/walker.yaml`` (section ``/**``) beside the robot's, each value
with its source; this frozen section checks them (``ParameterError`` naming the parameter) and
the planner node declares them with :func:`walker_runtime.node_parameters.declare_section`. All but
``planner.send_whole_trajectories`` (read once, at start) may change at run time (``ros2 param
set``); an invalid update is refused and changes nothing.
"""

from __future__ import annotations

import dataclasses

from walker_core.parameter_schema import ParameterError, parameter

__all__ = ['JointPlanning', 'CartesianPlanning', 'BangBangPlanning', 'StreamParameters',
           'PlannerParameters', 'PREFIX']

#: Dotted prefix of the section in the parameter file.
PREFIX = 'planner.'


def _writable(description, unit='', minimum=None, maximum=None, *, source=''):
    return parameter(description, unit, minimum, maximum, read_only=False, source=source)


@dataclasses.dataclass(frozen=True)
class JointPlanning:
    """Defaults and bounds of the joint-space types."""

    velocity_fraction: float = _writable(
        "default speed of joint-space types, as a fraction of each drive's velocity_limit",
        '', 0.01, 1.0,
        source='chosen: a margin for tracking')
    max_acceleration: float = _writable(
        'default joint acceleration of joint-space types (when a request gives 0)',
        'rad/s^2', 0.001, 100.0,
        source='chosen: J1 then needs 3.1 N*m at the stance (eq (9)), a third of its available '
               'torque')
    acceleration_limit: float = _writable(
        'largest joint acceleration a request may ask for', 'rad/s^2', 0.001, 100.0,
        source="chosen: about J1's available torque over its inertia at the stance")

    def __post_init__(self) -> None:
        if self.max_acceleration > self.acceleration_limit:
            raise ParameterError(
                f'planner.joint.max_acceleration ({self.max_acceleration} rad/s^2) must not '
                f'exceed planner.joint.acceleration_limit ({self.acceleration_limit} rad/s^2)')


@dataclasses.dataclass(frozen=True)
class CartesianPlanning:
    """Defaults and bounds of the Cartesian types (tip speeds along the path)."""

    max_velocity: float = _writable(
        'default tip speed of the Cartesian parabolic types (when a request gives 0)',
        'm/s', 0.0001, 10.0,
        source='chosen: about 0.11 rad/s of J1 at the 0.9 m stance')
    max_acceleration: float = _writable(
        'default tip acceleration of the Cartesian parabolic types (when a request gives 0)',
        'm/s^2', 0.0001, 100.0,
        source='chosen: 0.22 rad/s^2 of J1 at 0.9 m')
    acceleration_limit: float = _writable(
        'largest tip acceleration a request may ask for', 'm/s^2', 0.0001, 100.0,
        source='chosen: 2.2 rad/s^2 of J1 at 0.9 m, within what its available torque gives')
    fine_speed: float = _writable(
        'speed of the constant-velocity line of fine motion (when a request gives 0)',
        'm/s', 0.0001, 1.0,
        source='paper section 5: a constant-velocity line for fine motion; chosen: slow')
    insertion_speed: float = _writable(
        'peak speed of the minimum-jerk insertion and extraction lines (when a request gives 0)',
        'm/s', 0.0001, 1.0,
        source='chosen: the 30 mm approach height in 0.29 s')

    def __post_init__(self) -> None:
        if self.max_acceleration > self.acceleration_limit:
            raise ParameterError(
                f'planner.cartesian.max_acceleration ({self.max_acceleration} m/s^2) must not '
                f'exceed planner.cartesian.acceleration_limit ({self.acceleration_limit} m/s^2)')


@dataclasses.dataclass(frozen=True)
class BangBangPlanning:
    """The bang-bang node-to-node planner (paper section 5)."""

    torque_fraction: float = _writable(
        'fraction of the available torque (limit minus friction) nominal plans use as tau_ref',
        '', 0.01, 1.0,
        source='paper section 5: +-tau_ref; chosen: the rest for feedback and what the planar '
               'model omits')
    velocity_fraction: float = _writable(
        "fraction of each drive's velocity_limit nominal bang-bang plans may reach", '', 0.01, 1.0,
        source='chosen: the shaped references track it within 2 mrad')
    min_radius: float = _writable(
        'smallest distance of the tip from the base yaw axis at the midpoint (2 l2 rho_min)',
        'm', 0.01, 10.0,
        source="paper section 5: r >= r_min; chosen: half a metre from the base gripper's axis")
    coast: bool = _writable(
        'a rate-bound plan coasts at the rate cap (bang-coast-bang) instead of the bang-bang '
        'triangle',
        source="chosen: 90 deg in 1.80 s instead of 2.21 s; false is the paper's profile")


@dataclasses.dataclass(frozen=True)
class StreamParameters:
    """Streaming setpoints to the controllers."""

    start_tolerance: float = _writable(
        "largest distance of a measured joint from the trajectory's start at which it may stream",
        'rad', 0.0001, 1.0,
        source='chosen: 3 deg, so no setpoint jumps')
    feedback_rate: float = _writable(
        'rate of follow_trajectory feedback messages', 'Hz', 0.1, 1000.0,
        source='chosen')
    lookahead: int = _writable(
        'control periods ahead of the newest joint state up to which setpoints are sent',
        '', 1, 10,
        source="chosen: the loop need not wait for the planner; at most the setpoint topics' "
               'depth')


@dataclasses.dataclass(frozen=True)
class PlannerParameters:
    """The ``planner.*`` parameters."""

    joint: JointPlanning
    cartesian: CartesianPlanning
    bang_bang: BangBangPlanning
    stream: StreamParameters
    send_whole_trajectories: bool = parameter(
        'send each followed trajectory once, whole, on controllers/joint_trajectory (else stream)',
        source='chosen: true, as joint_trajectory_controller is fed: a late message costs nothing')
