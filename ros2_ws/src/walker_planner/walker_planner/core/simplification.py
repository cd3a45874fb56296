"""How much the simplifications of paper section 5 cost: the plan's torques on fuller models.

The planar model (eqs (21), (22)) neglects the centrifugal term ``r Theta'^2`` of eq (19) and
puts all the moving mass at the tip. This module drives fuller planar models, open loop, with
the planned bang-bang torques and reports where the tip ends (the endpoint error the
simplifications cause), and computes the torques those models need to follow the plan exactly.

Models (generalised coordinates ``u = th2`` and ``Theta``, symmetric inverted V, tip at the
base's height, zero gravity; kinetic energy ``(A(u) Theta'^2 + B(u) u'^2) / 2``)::

    A = (m3 + 4 m) l^2 sin^2 u + I_yaw,   B = m3 l^2 + 4 m l^2 cos^2 u + I_pitch
    A Theta'' + A_u u' Theta' = S1 tau1                            (Lagrange, Theta)
    B u'' + B_u u'^2 / 2 - c A_u Theta'^2 / 2 = 2 S3 tau3          (Lagrange, u)

``m`` is the tip mass, ``m3`` the vertex mass (at the middle of the V), ``I_yaw`` the rotor
inertia turning with ``Theta`` (J1 and J5, ``n^2 I_m`` each) and ``I_pitch`` that of J2, J3, J4
(``th2' = th4' = u'``, ``th3' = -2 u'``: ``(1 + 4 + 1) n^2 I_m``); ``2 S3 tau3`` is the virtual
work of the J3 torque through ``th3 = pi - 2u`` (eq (17)). With ``m3 = I = 0`` these are exactly
eqs (19)-(20) (``c = 1``) or the paper's (21)-(22) (``c = 0``):

* ``simplified``: ``c = 0``, tip mass only: the plan itself (a check of the integration);
* ``full``: ``c = 1``, tip mass only: eqs (19)-(20), the centrifugal term restored;
* ``lumped``: ``c = 1`` with the vertex mass and the rotor inertias of the parameter file.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy.integrate import solve_ivp

from walker_planner.core.node_to_node import NodeToNodeSolution

__all__ = ['PlanarDynamics', 'EndpointError', 'simplification_errors', 'required_torques',
           'feasible_duration', 'MODELS']

MODELS = ('simplified', 'full', 'lumped')
_FOLDED, _STRETCHED = 1e-3, 0.5 * math.pi - 1e-3  # [rad] th2 where the model breaks down


@dataclasses.dataclass(frozen=True)
class PlanarDynamics:
    """A planar model of the node-to-node motion (see the module notes).

    Attributes
    ----------
    link_length : float
        ``l`` [m].
    tip_mass, vertex_mass : float
        ``m``, ``m3`` [kg].
    yaw_inertia, pitch_inertia : float
        ``I_yaw``, ``I_pitch`` [kg*m^2].
    centrifugal : bool
        Keep the centrifugal term of eq (19).
    """

    link_length: float
    tip_mass: float
    vertex_mass: float = 0.0
    yaw_inertia: float = 0.0
    pitch_inertia: float = 0.0
    centrifugal: bool = True

    @classmethod
    def named(cls, name: str, solution: NodeToNodeSolution, params=None) -> 'PlanarDynamics':
        """One of :data:`MODELS` for a solution (``lumped`` needs ``WalkerParameters``)."""
        model = solution.model
        if name == 'simplified':
            return cls(model.link_length, model.tip_mass, centrifugal=False)
        if name == 'full':
            return cls(model.link_length, model.tip_mass)
        if name == 'lumped':
            if params is None:
                raise ValueError('the lumped model needs the robot parameters')
            m3, _, _ = params.robot.mass.lumped
            drive = params.robot.drive
            rotor = drive.motor_inertia * drive.role_array('gear_ratio') ** 2
            return cls(model.link_length, model.tip_mass, m3, rotor[0] + rotor[4],
                       rotor[1] + 4.0 * rotor[2] + rotor[3])
        raise ValueError(f'unknown model {name!r}: expected one of {", ".join(MODELS)}')

    def coefficients(self, u: np.ndarray) -> tuple[np.ndarray, ...]:
        """Return ``A, dA/du, B, dB/du`` at ``u = th2``."""
        l2 = self.link_length ** 2
        s, c = np.sin(u), np.cos(u)
        swing = (self.vertex_mass + 4.0 * self.tip_mass) * l2
        a = swing * s * s + self.yaw_inertia
        b = self.vertex_mass * l2 + 4.0 * self.tip_mass * l2 * c * c + self.pitch_inertia
        return a, 2.0 * swing * s * c, b, -8.0 * self.tip_mass * l2 * s * c

    def accelerations(self, state: np.ndarray, circular: float, radial: float
                      ) -> tuple[float, float]:
        """``u''`` and ``Theta''`` for state ``(u, u', Theta, Theta')`` and torques [N*m]."""
        u, u_d, _, theta_d = state
        a, a_u, b, b_u = self.coefficients(u)
        centrifugal = 0.5 * a_u * theta_d ** 2 if self.centrifugal else 0.0
        u_dd = (2.0 * radial - 0.5 * b_u * u_d ** 2 + centrifugal) / b
        return u_dd, (circular - a_u * u_d * theta_d) / a


@dataclasses.dataclass(frozen=True)
class EndpointError:
    """Where the tip ends when a model is driven open loop with the planned torques.

    Attributes
    ----------
    model : str
        Which model.
    position : float
        Distance of the tip from the planned end [m] (at ``end_time``).
    radius, angle : float
        Radius [m] and sweep angle [rad] errors, end minus plan.
    speed : float
        Tip speed left at the end [m/s] (the plan ends at rest).
    end_time : float
        Time the integration reached [s]: the duration, or earlier if the V stretched out or
        folded (``stopped`` is then True).
    stopped : bool
        The model left the workspace before the end (the error is then at ``end_time``).
    """

    model: str
    position: float
    radius: float
    angle: float
    speed: float
    end_time: float
    stopped: bool


def _integrate(dynamics: PlanarDynamics, solution: NodeToNodeSolution, rtol: float):
    rho0 = solution.profile.rho_start
    state = np.array([math.asin(rho0), 0.0, 0.0, 0.0])
    switches = sorted({0.0, *solution.switch_times, solution.duration})

    def leaves(_, y, *__):
        return min(y[0] - _FOLDED, _STRETCHED - y[0])

    leaves.terminal = True
    time = 0.0
    for lower, upper in zip(switches[:-1], switches[1:], strict=True):
        middle = 0.5 * (lower + upper)
        s1, s3 = solution.torques(np.array([middle]))
        torques = (float(s1[0]), float(s3[0]))

        def rates(_, y, tau1, tau3):
            u_dd, theta_dd = dynamics.accelerations(y, tau1, tau3)
            return [y[1], u_dd, y[3], theta_dd]

        result = solve_ivp(rates, (lower, upper), state, method='DOP853', rtol=rtol,
                           atol=rtol * 1e-3, args=torques, events=leaves)
        state, time = result.y[:, -1], result.t[-1]
        if result.status == 1:
            return state, time, True
    return state, time, False


def simplification_errors(solution: NodeToNodeSolution, params=None, models=MODELS,
                          rtol: float = 1e-10) -> list[EndpointError]:
    """Endpoint errors of the planned torques on each model (see the module notes).

    Parameters
    ----------
    solution : NodeToNodeSolution
        The planned bang-bang motion (its torques and the paper's model).
    params : WalkerParameters, optional
        Needed for the ``lumped`` model.
    models : sequence of str
        Which of :data:`MODELS` to run.
    rtol : float
        Relative tolerance of ``solve_ivp`` (DOP853).

    Returns
    -------
    list of EndpointError
    """
    link = solution.model.link_length
    omega = solution.omega
    errors = []
    for name in models:
        dynamics = PlanarDynamics.named(name, solution, params)
        state, time, stopped = _integrate(dynamics, solution, rtol)
        u, u_d, theta, theta_d = state
        planned = solution.profile.sample(np.array([time * omega]))
        radius, planned_radius = 2.0 * link * math.sin(u), 2.0 * link * float(planned.rho[0])
        planned_theta = float(planned.theta[0])
        tip = radius * np.array([-math.sin(theta), math.cos(theta)])
        planned_tip = planned_radius * np.array([-math.sin(planned_theta),
                                                 math.cos(planned_theta)])
        speed = math.hypot(2.0 * link * math.cos(u) * u_d, radius * theta_d)
        errors.append(EndpointError(name, float(np.linalg.norm(tip - planned_tip)),
                                    radius - planned_radius, theta - planned_theta, speed,
                                    time, stopped))
    return errors


def required_torques(solution: NodeToNodeSolution, dynamics: PlanarDynamics,
                     times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Torques a model needs to follow the planned motion exactly (inverse dynamics).

    Returns
    -------
    tuple of ndarray
        Circular torque ``tau1`` (J1) and radial torque ``S3 tau3`` (positive outwards; the J3
        joint torque is its negative) [N*m] at ``times``.
    """
    omega = solution.omega
    p = solution.profile.sample(np.asarray(times, dtype=float) * omega)
    u = np.arcsin(p.rho)
    cos_u = np.cos(u)
    # rho = sin u: rho' = cos(u) u', rho'' = cos(u) u'' - sin(u) u'^2 (phi-derivatives)
    u_d = p.rho_d / cos_u
    u_dd = (p.rho_dd + p.rho * u_d ** 2) / cos_u
    u_d, u_dd = omega * u_d, omega ** 2 * u_dd
    theta_d, theta_dd = omega * p.theta_d, omega ** 2 * p.theta_dd
    a, a_u, b, b_u = dynamics.coefficients(u)
    circular = a * theta_dd + a_u * u_d * theta_d
    centrifugal = 0.5 * a_u * theta_d ** 2 if dynamics.centrifugal else 0.0
    radial = 0.5 * (b * u_dd + 0.5 * b_u * u_d ** 2 - centrifugal)
    return circular, radial


def feasible_duration(solution: NodeToNodeSolution, dynamics: PlanarDynamics,
                      circular_limit: float, radial_limit: float, points: int = 2001) -> float:
    """Shortest duration [s] at which a model can follow the planned path within torque limits.

    Every term of the inverse dynamics is quadratic in the time scale, so following the same
    path ``k`` times slower needs ``1/k^2`` of the torques: the duration is stretched by
    ``sqrt`` of the largest ratio of required to available torque (never shortened).

    Parameters
    ----------
    solution : NodeToNodeSolution
        The planned motion.
    dynamics : PlanarDynamics
        The model that has to follow it.
    circular_limit, radial_limit : float
        Available ``|tau1|`` and ``|tau3|`` [N*m].
    points : int
        Samples of the path where the torques are evaluated.
    """
    times = np.linspace(0.0, solution.duration, points)
    circular, radial = required_torques(solution, dynamics, times)
    ratio = max(float(np.max(np.abs(circular))) / circular_limit,
                float(np.max(np.abs(radial))) / radial_limit, 1.0)
    return solution.duration * math.sqrt(ratio)
