"""The bang-bang node-to-node coarse motion in physical units: limits, time scale, trajectory.

The dimensionless profile (:mod:`walker_planner.core.bang_bang`) fixes the shape of the motion;
eq (23), ``phi = omega t`` with ``omega^2 = tau3 / (m l^2)``, fixes its speed. The radial torque
is then ``tau3 = omega^2 m l^2`` and the circular one ``tau1 = tau tau3``. Every limit caps
``omega``: the torques (``tau3`` and ``tau1`` each at most their reference ``tau_ref``), and the
joint rates (J1 and J5 turn at ``omega Theta'``, J2 and J4 at ``omega th2'``, J3 at twice that).
Of the family of profiles with ``rho(phi2)`` between ``rho_min`` and ``rho(0)``, the planner takes
the one with the shortest duration ``2 phi2 / omega``: pulling the tip in lowers the inertia
about the yaw axis but costs radial motion and raises the peak yaw rate.

Mapping to the robot (our choices, documented in docs/planner.md)
-------------------------------------------------------------
* ``Theta`` is the base yaw J1; ``r`` is the horizontal distance of the tip from the base yaw
  axis, ``l = l2``.
* The tip moves in the horizontal plane at the height of its start, normally the approach height
  above the truss; the planar model neglects that height (30 mm tilts the J2-J4 chord by about
  2 deg), the joint mapping (:mod:`walker_planner.core.cartesian`) does not.
* The mass at the tip is ``m = m4 + m5``: the tip gripper with its yaw drive and the tip wrist
  with half a link, as the paper lumps "the gripper and two joints" at the tip.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy.optimize import minimize_scalar

from walker_planner.core.bang_bang import (
    RADIAL_MOTION_FLOOR, PlanarProfile, ProfileSummary, summarize_profile)
from walker_planner.core.errors import LimitError
from walker_planner.core.trajectory import CARTESIAN, Samples, Trajectory

__all__ = ['PlanarModel', 'NodeToNodeSolution', 'NodeToNodeTrajectory', 'solve_node_to_node',
           'SWEEP_TYPE_NAME', 'polar_samples']

SWEEP_TYPE_NAME = 'bang_bang_node'
_GRID_POINTS = 48


@dataclasses.dataclass(frozen=True)
class PlanarModel:
    """The planar model of section 5 with its limits.

    Attributes
    ----------
    link_length : float
        ``l = l2`` [m].
    tip_mass : float
        ``m`` [kg], the mass concentrated at the tip.
    circular_torque, radial_torque : float
        Largest ``|tau1|`` (J1) and ``|tau3|`` (J3) the plan may use [N*m].
    yaw_rate, pitch_rate, vertex_rate : float
        Largest joint rates of J1/J5, J2/J4 and J3 [rad/s]; ``inf`` for none.
    """

    link_length: float
    tip_mass: float
    circular_torque: float
    radial_torque: float
    yaw_rate: float = math.inf
    pitch_rate: float = math.inf
    vertex_rate: float = math.inf

    def __post_init__(self) -> None:
        for name in ('link_length', 'tip_mass', 'circular_torque', 'radial_torque',
                     'yaw_rate', 'pitch_rate', 'vertex_rate'):
            value = getattr(self, name)
            if not (value > 0.0 and not math.isnan(value)):
                raise LimitError(f'planar model {name} must be positive, got {value!r}')

    @classmethod
    def from_parameters(cls, params, torque_fraction: float = 1.0,
                        velocity_fraction: float | None = None) -> 'PlanarModel':
        """Build from :class:`walker_core.robot_parameters.WalkerParameters`.

        Parameters
        ----------
        params : WalkerParameters
            The robot.
        torque_fraction : float
            Fraction of the available torque (limit minus Coulomb friction) the plan uses: 1
            for the physical bound, ``planner.bang_bang.torque_fraction`` for nominal plans.
        velocity_fraction : float, optional
            Fraction of each drive's velocity limit; ``None`` leaves the rates unlimited
            (the time-optimal bound is under the torque limits only).
        """
        drive = params.robot.drive
        _, m4, m5 = params.robot.mass.lumped

        def available(kind):
            d = getattr(drive, kind)
            return torque_fraction * (d.torque_limit - d.friction_torque)

        def rate(kind):
            if velocity_fraction is None:
                return math.inf
            return velocity_fraction * getattr(drive, kind).velocity_limit

        return cls(link_length=params.robot.geometry.l2, tip_mass=m4 + m5,
                   circular_torque=available('yaw'), radial_torque=available('vertex'),
                   yaw_rate=rate('yaw'), pitch_rate=rate('pitch'), vertex_rate=rate('vertex'))

    @property
    def inertia_scale(self) -> float:
        """``m l^2`` [kg*m^2], the inertia of eq (23)."""
        return self.tip_mass * self.link_length ** 2

    def rho(self, radius: float) -> float:
        """``rho = r / 2l`` of a radius [m]."""
        return radius / (2.0 * self.link_length)

    def time_scale(self, summary: ProfileSummary) -> tuple[float, str]:
        """Largest ``omega = dphi/dt`` [1/s] the limits allow, and the name of the binding one."""
        caps = {'the circular torque tau1 (J1)':
                math.sqrt(self.circular_torque / (summary.tau * self.inertia_scale)),
                'the J1/J5 rate limit': self.yaw_rate / summary.circular_rate}
        if summary.pitch_rate > 0.0:
            caps['the radial torque tau3 (J3)'] = math.sqrt(self.radial_torque
                                                            / self.inertia_scale)
            caps['the J2/J4 rate limit'] = self.pitch_rate / summary.pitch_rate
            caps['the J3 rate limit'] = self.vertex_rate / (2.0 * summary.pitch_rate)
        binding = min(caps, key=caps.get)
        return caps[binding], binding


@dataclasses.dataclass(frozen=True)
class NodeToNodeSolution:
    """A solved node-to-node motion: the profile and its time scale.

    Attributes
    ----------
    model : PlanarModel
        The model and limits it was solved for.
    profile : PlanarProfile
        The dimensionless solution (``tau``, ``phi1``, ``phi2``).
    omega : float
        ``dphi/dt`` [1/s], eq (23).
    binding_limit : str
        Which limit sets ``omega`` (or ``'the requested duration'``).
    """

    model: PlanarModel
    profile: PlanarProfile
    omega: float
    binding_limit: str

    @property
    def duration(self) -> float:
        """Duration ``2 phi2 / omega`` [s]."""
        return self.profile.phi_end / self.omega

    @property
    def radial_torque(self) -> float:
        """``|tau3| = omega^2 m l^2`` [N*m] (0 for a pure rotation)."""
        if self.profile.pure_rotation:
            return 0.0
        return self.omega ** 2 * self.model.inertia_scale

    @property
    def circular_torque(self) -> float:
        """``|tau1|`` [N*m]: ``tau tau3``, or ``omega^2 m l^2`` for a pure rotation."""
        return self.profile.tau * self.omega ** 2 * self.model.inertia_scale

    @property
    def switch_times(self) -> tuple[float, float, float]:
        """Times [s] of the radial switch, the midpoint and the mirrored radial switch."""
        p = self.profile
        return p.phi1 / self.omega, p.phi2 / self.omega, (p.phi_end - p.phi1) / self.omega

    def torques(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Planned circular torque ``S1 tau1`` and radial force torque ``S3 tau3`` [N*m] at t.

        The radial torque is positive when it pushes the tip outwards (eq (17)); the J3 joint
        torque is its negative, since a positive J3 closes the V.
        """
        phi = np.asarray(t, dtype=float) * self.omega
        return (self.profile.circular_sign(phi) * self.circular_torque,
                self.profile.radial_sign(phi) * self.radial_torque)


def _duration(model: PlanarModel, rho_start: float, rho_mid: float, half_sweep: float) -> float:
    summary = summarize_profile(rho_start, rho_mid, half_sweep)
    omega, _ = model.time_scale(summary)
    return 2.0 * summary.phi2 / omega


def solve_node_to_node(model: PlanarModel, rho_start: float, half_sweep: float,
                       rho_min: float, duration: float | None = None) -> NodeToNodeSolution:
    """Choose the midpoint radius and time scale of the fastest node-to-node motion.

    Parameters
    ----------
    model : PlanarModel
        Tip mass, link length, torque and rate limits.
    rho_start : float
        ``rho(0) = rho(2 phi2)``, in (0, 1).
    half_sweep : float
        ``Theta(phi2)`` [rad], half the sweep, in (0, pi/2].
    rho_min : float
        Smallest allowed ``rho(phi2)``, in (0, rho_start].
    duration : float, optional
        Stretch the motion to this duration [s] (lower torques); it must not be shorter than
        the fastest one.

    Returns
    -------
    NodeToNodeSolution

    Raises
    ------
    NoSolutionError
        ``rho_min`` above the start radius, a start outside the reach, a sweep outside
        (0, 180] deg.
    LimitError
        A requested duration shorter than the limits allow.

    Notes
    -----
    ``T(rho_mid)`` is evaluated on a grid of 48 midpoints and refined by bounded Brent
    minimisation around the best one; the pure rotation ``rho_mid = rho_start`` is a candidate.
    """
    summarize_profile(rho_start, rho_min, half_sweep)  # validates the data, names the problem
    upper = rho_start - RADIAL_MOTION_FLOOR
    best_rho, best_time = rho_start, _duration(model, rho_start, rho_start, half_sweep)
    if rho_min < upper:
        grid = np.linspace(rho_min, upper, _GRID_POINTS)
        times = [_duration(model, rho_start, rho, half_sweep) for rho in grid]
        index = int(np.argmin(times))
        if times[index] < best_time:
            low, high = grid[max(index - 1, 0)], grid[min(index + 1, len(grid) - 1)]
            refined = minimize_scalar(lambda rho: _duration(model, rho_start, rho, half_sweep),
                                      bounds=(low, high), method='bounded',
                                      options={'xatol': 1e-7})
            best_rho, best_time = grid[index], times[index]
            if refined.fun < best_time:
                best_rho, best_time = float(refined.x), float(refined.fun)
    profile = PlanarProfile.solve(rho_start, best_rho, half_sweep)
    omega, binding = model.time_scale(profile.summary)
    if duration is not None:
        shortest = profile.phi_end / omega
        if not (math.isfinite(duration) and duration >= shortest * (1.0 - 1e-12)):
            raise LimitError(f'duration {duration:.4g} s is shorter than the fastest node-to-node '
                             f'motion within the limits, {shortest:.4g} s (set by {binding})')
        omega, binding = profile.phi_end / duration, 'the requested duration'
    return NodeToNodeSolution(model, profile, omega, binding)


@dataclasses.dataclass(frozen=True)
class NodeToNodeTrajectory(Trajectory):
    """The tip's bang-bang node-to-node motion as a Cartesian trajectory (type ``bang_bang_node``).

    Parameters
    ----------
    solution : NodeToNodeSolution
        Profile and time scale.
    theta_start : float
        ``Theta`` at the start [rad]: the base yaw J1 that points the arm at the start node.
    direction : int
        +1 for a counter-clockwise sweep (seen from above), -1 for clockwise.
    height : float
        Height ``Z`` of the tip above the base contact point during the motion [m].

    Notes
    -----
    The tip is at ``(X, Y) = r (-sin Theta, cos Theta)`` (eq (1) with J1 = Theta); its velocity
    and acceleration follow from the polar kinematics ``a = (r'' - r Theta'^2) e_r + (r Theta''
    + 2 r' Theta') e_Theta`` that eqs (19) and (20) are built on.
    """

    type_name = SWEEP_TYPE_NAME
    space = CARTESIAN

    solution: NodeToNodeSolution
    theta_start: float
    direction: int
    height: float

    @property
    def duration(self) -> float:
        """Duration [s]."""
        return self.solution.duration

    def polar(self, t: np.ndarray) -> tuple[np.ndarray, ...]:
        """``r, r', r'', Theta, Theta', Theta''`` in physical units (m, s, rad) at times t."""
        omega = self.solution.omega
        two_l = 2.0 * self.solution.model.link_length
        p = self.solution.profile.sample(np.asarray(t, dtype=float) * omega)
        d = float(self.direction)
        return (two_l * p.rho, two_l * omega * p.rho_d, two_l * omega ** 2 * p.rho_dd,
                self.theta_start + d * p.theta, d * omega * p.theta_d,
                d * omega ** 2 * p.theta_dd)

    def _sample(self, t: np.ndarray) -> Samples:
        return polar_samples(*self.polar(t), self.height)


def polar_samples(r: np.ndarray, r_d: np.ndarray, r_dd: np.ndarray, theta: np.ndarray,
                  theta_d: np.ndarray, theta_dd: np.ndarray, height: float) -> Samples:
    """Tip position, velocity and acceleration from polar coordinates about the base yaw axis.

    ``(X, Y) = r (-sin Theta, cos Theta)`` (eq (1) with J1 = Theta) at height ``Z``, and the
    polar kinematics ``a = (r'' - r Theta'^2) e_r + (r Theta'' + 2 r' Theta') e_Theta`` that
    eqs (19) and (20) are built on. Arrays of one shape ``(N,)``: m, rad and s.
    """
    radial = np.column_stack([-np.sin(theta), np.cos(theta), np.zeros_like(theta)])
    circular = np.column_stack([-np.cos(theta), -np.sin(theta), np.zeros_like(theta)])
    position = r[:, None] * radial
    position[:, 2] = height
    velocity = r_d[:, None] * radial + (r * theta_d)[:, None] * circular
    acceleration = ((r_dd - r * theta_d ** 2)[:, None] * radial
                    + (r * theta_dd + 2.0 * r_d * theta_d)[:, None] * circular)
    return Samples(position, velocity, acceleration)
