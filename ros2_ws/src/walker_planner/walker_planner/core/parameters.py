"""The planner's parameters: the ``planner.*`` group of the one parameter file.

They live in ``walker_core/config/walker.yaml`` (section ``/**``) beside the robot's, each value
with its source; this frozen section checks them (``ParameterError`` naming the parameter) and
the planner node declares them with :func:`walker_runtime.node_parameters.declare_section`. All may
change at run time (``ros2 param set``); an invalid update is refused and changes nothing.
"""

from __future__ import annotations

import dataclasses

from walker_core.parameter_schema import ParameterError, parameter

__all__ = ['JointPlanning', 'CartesianPlanning', 'BangBangPlanning', 'StreamParameters',
           'PlannerParameters', 'PREFIX']

#: Dotted prefix of the section in the parameter file.
PREFIX = 'planner.'


def _writable(description, unit='', minimum=None, maximum=None):
    return parameter(description, unit, minimum, maximum, read_only=False)


@dataclasses.dataclass(frozen=True)
class JointPlanning:
    """Defaults and bounds of the joint-space types."""

    velocity_fraction: float = _writable(
        "default joint speed limit of joint-space types, as a fraction of each drive's "
        'velocity_limit', '', 0.01, 1.0)
    max_acceleration: float = _writable(
        'default joint acceleration of joint-space types (when a request gives 0)', 'rad/s^2',
        0.001, 100.0)
    acceleration_limit: float = _writable(
        'largest joint acceleration a request may ask for', 'rad/s^2', 0.001, 100.0)

    def __post_init__(self) -> None:
        if self.max_acceleration > self.acceleration_limit:
            raise ParameterError(
                f'planner.joint.max_acceleration ({self.max_acceleration} rad/s^2) must not '
                f'exceed planner.joint.acceleration_limit ({self.acceleration_limit} rad/s^2)')


@dataclasses.dataclass(frozen=True)
class CartesianPlanning:
    """Defaults and bounds of the Cartesian types (tip speeds along the path)."""

    max_velocity: float = _writable(
        'default tip speed of the Cartesian parabolic types (when a request gives 0)', 'm/s',
        0.0001, 10.0)
    max_acceleration: float = _writable(
        'default tip acceleration of the Cartesian parabolic types (when a request gives 0)',
        'm/s^2', 0.0001, 100.0)
    acceleration_limit: float = _writable(
        'largest tip acceleration a request may ask for', 'm/s^2', 0.0001, 100.0)
    fine_speed: float = _writable(
        'speed of the constant-velocity line of fine motion (when a request gives 0)', 'm/s',
        0.0001, 1.0)
    insertion_speed: float = _writable(
        'peak speed of the minimum-jerk insertion and extraction lines (when a request gives '
        '0)', 'm/s',
        0.0001, 1.0)

    def __post_init__(self) -> None:
        if self.max_acceleration > self.acceleration_limit:
            raise ParameterError(
                f'planner.cartesian.max_acceleration ({self.max_acceleration} m/s^2) must not '
                f'exceed planner.cartesian.acceleration_limit ({self.acceleration_limit} m/s^2)')


@dataclasses.dataclass(frozen=True)
class BangBangPlanning:
    """The bang-bang node-to-node planner (paper section 5)."""

    torque_fraction: float = _writable(
        'fraction of the available torque (limit minus Coulomb friction) that nominal '
        'bang-bang plans use as tau_ref', '', 0.01, 1.0)
    velocity_fraction: float = _writable(
        "fraction of each drive's velocity_limit that nominal bang-bang plans may reach", '',
        0.01, 1.0)
    min_radius: float = _writable(
        'smallest distance of the tip from the base yaw axis at the midpoint (r_min = '
        '2 l2 rho_min)', 'm', 0.01, 10.0)
    coast: bool = _writable(
        'when the J1/J5 rate limit, not the torque, sets a fastest plan (a pure rotation), '
        'accelerate at tau_ref over whole periods of the joint-1 mode and coast at the rate cap '
        "(bang-coast-bang) instead of the paper's bang-bang triangle")


@dataclasses.dataclass(frozen=True)
class StreamParameters:
    """Streaming setpoints to the controllers."""

    start_tolerance: float = _writable(
        "largest distance of a measured joint from the trajectory's start at which a stream "
        'may begin', 'rad', 0.0001, 1.0)
    feedback_rate: float = _writable(
        'rate of follow_trajectory feedback messages', 'Hz', 0.1, 1000.0)
    lookahead: int = _writable(
        'control periods ahead of the newest joint state up to which the stream has sent its '
        'setpoints (each stamped with the time it applies): 1 sends each one period before '
        'it applies; more lets the controllers answer the next states without waiting for '
        "the planner's process (sim time) and rides out its late wake-ups (real time); a "
        'cancel stops the motion where the setpoints already sent end; at most the '
        "setpoint topics' depth (10), since a stream's start sends this many at once", '', 1,
        10)


@dataclasses.dataclass(frozen=True)
class PlannerParameters:
    """The ``planner.*`` parameters."""

    joint: JointPlanning
    cartesian: CartesianPlanning
    bang_bang: BangBangPlanning
    stream: StreamParameters
