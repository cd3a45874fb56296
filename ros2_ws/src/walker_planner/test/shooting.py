"""Feasible node-to-node moves built by multi-segment shooting, independently of the planner.

The tests' own construction, sharing no code with :mod:`walker_planner.core.direct_method`: the
tip in polar coordinates ``(r, Theta)`` obeys eqs (17)-(20) as printed (the centrifugal term
kept), ``r'' = r Theta'^2 + F_r / m`` with ``F_r = S3 tau3 / (l cos th2)`` and
``Theta'' = tau1 / (m r^2) - 2 r' Theta' / r``; the torques are constant on each of
``segments`` equal segments; single shooting (fixed-step Runge-Kutta, complex-step
derivatives) with ``scipy.optimize`` SLSQP shortens the move from a slow start that holds the
radius; ``solve_ivp`` re-integrates the result, and only a move that re-integrates within
the limits is returned.
"""

import math

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import minimize

_SUBSTEPS = 8
_MARGIN = 1e-4  # keep inside the radius limits between the Runge-Kutta points


def _rates(state, tau1, f3, mass, link):
    r, r_d, _, theta_d = state
    cos_th2 = np.sqrt(1.0 - (r / (2.0 * link)) ** 2)
    return np.array([r_d, r * theta_d ** 2 + f3 / (link * cos_th2) / mass, theta_d,
                     tau1 / (mass * r * r) - 2.0 * r_d * theta_d / r])


def _shoot(z, r0, segments, torque, mass, link):
    """States at every Runge-Kutta point, for a batch of decision vectors (columns of z)."""
    tau1, f3, duration = z[:segments] * torque[0], z[segments:2 * segments] * torque[1], z[-1]
    h = duration / (segments * _SUBSTEPS)
    state = np.zeros((4, z.shape[1]), dtype=z.dtype)
    state[0] = r0
    points = [state]
    for k in range(segments):
        for _ in range(_SUBSTEPS):
            k1 = _rates(state, tau1[k], f3[k], mass, link)
            k2 = _rates(state + 0.5 * h * k1, tau1[k], f3[k], mass, link)
            k3 = _rates(state + 0.5 * h * k2, tau1[k], f3[k], mass, link)
            k4 = _rates(state + h * k3, tau1[k], f3[k], mass, link)
            state = state + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
            points.append(state)
    return np.stack(points, axis=1)


def reintegrate_polar(r0, duration, torques, mass, link, samples=24):
    """``solve_ivp`` (DOP853) of the piecewise-constant torques: end state and sampled path."""
    edges = np.linspace(0.0, duration, len(torques) + 1)
    state, path = np.array([r0, 0.0, 0.0, 0.0]), []
    for start, stop, (tau1, f3) in zip(edges[:-1], edges[1:], torques, strict=True):
        solution = solve_ivp(lambda _, y, a, b: _rates(y, a, b, mass, link), (start, stop),
                             state, method='DOP853', rtol=1e-11, atol=1e-13, args=(tau1, f3),
                             dense_output=True)
        path.append(solution.sol(np.linspace(start, stop, samples)).T)
        state = solution.y[:, -1]
    return state, np.concatenate(path)


def shoot_move(r0, sweep, r_min, mass, link, torque, segments=30, start_duration=3.0):
    """Build a feasible move from rest at ``r0`` to rest ``sweep`` further round, short.

    Returns
    -------
    (float, ndarray)
        Duration [s] and torques ``(tau1, S3 tau3)`` per segment [N*m]; the move has been
        re-integrated and stays within ``|tau| <= torque``, ``r_min <= r <= r0``.
    """
    n = 2 * segments + 1
    t = (np.arange(segments) + 0.5) / segments
    theta_d = sweep * 6.0 * (t - t * t) / start_duration
    hold = -mass * r0 * theta_d ** 2 * link * math.sqrt(1.0 - (r0 / (2.0 * link)) ** 2)
    push = mass * r0 * r0 * sweep * 6.0 * (1.0 - 2.0 * t) / start_duration ** 2
    z0 = np.concatenate([push / torque[0], hold / torque[1], [start_duration]])
    memo = {}

    def evaluate(z):
        key = z.tobytes()
        if key not in memo:
            batch = np.tile(z.astype(complex)[:, None], (1, n + 1))
            batch[np.arange(n), np.arange(n) + 1] += 1e-30j
            states = _shoot(batch, r0, segments, torque, mass, link)
            memo.clear()
            memo[key] = (states[:, :, 0].real, states[:, :, 1:].imag / 1e-30)
        return memo[key]

    target = np.array([r0, 0.0, sweep, 0.0])
    low = r_min * (1.0 + _MARGIN)
    high = np.full(segments * _SUBSTEPS - 1, r0 * (1.0 - _MARGIN))
    high[:_SUBSTEPS], high[-_SUBSTEPS:] = r0, r0  # not tightened where the move is at rest
    constraints = [
        {'type': 'eq', 'fun': lambda z: evaluate(z)[0][:, -1] - target,
         'jac': lambda z: evaluate(z)[1][:, -1, :]},
        {'type': 'ineq', 'fun': lambda z: np.concatenate(
            [evaluate(z)[0][0, 1:-1] - low, high - evaluate(z)[0][0, 1:-1]]),
         'jac': lambda z: np.concatenate([evaluate(z)[1][0, 1:-1], -evaluate(z)[1][0, 1:-1]])},
    ]
    result = minimize(lambda z: z[-1], z0, jac=lambda z: np.eye(n)[-1], method='SLSQP',
                      bounds=[(-1.0, 1.0)] * (2 * segments) + [(0.1, 20.0)],
                      constraints=constraints, options={'maxiter': 400, 'ftol': 1e-12})
    duration = float(result.x[-1])
    torques = np.column_stack([result.x[:segments] * torque[0],
                               result.x[segments:2 * segments] * torque[1]])
    end, path = reintegrate_polar(r0, duration, torques, mass, link)
    miss = np.abs(end - target)
    if not (result.success and np.all(miss < 1e-5) and path[:, 0].min() >= r_min
            and path[:, 0].max() <= r0 * (1.0 + 1e-9)):
        raise AssertionError(f'the shooting did not give a feasible move: {result.message}, '
                             f'end miss {miss}, radius {path[:, 0].min()}..{path[:, 0].max()}')
    return duration, torques
