"""The bang-coast-bang sweep: limits, endpoints, the whole-period acceleration, the choice."""

import dataclasses
import math

import numpy as np
import pytest

from walker_planner.core.coasting import CoastingSweep, coasting_sweep
from walker_planner.core.node_to_node import PlanarModel
from walker_planner.core.planning import PlanRequest, PlanningContext, plan

H = 0.03
ABOVE = (0.0, 0.9, H)
MODE = 18.0  # [rad/s] robot.flexibility.joint1_mode of the default file


@pytest.fixture(scope='module')
def model(robot, planner_parameters):
    planning = planner_parameters.bang_bang
    return PlanarModel.from_parameters(robot, planning.torque_fraction,
                                       planning.velocity_fraction)


def _dense(trajectory, n=20001):
    t = np.linspace(0.0, trajectory.duration, n)
    return t, trajectory.polar(t)


@pytest.mark.parametrize('sweep', [math.pi / 2, math.pi, 0.3, 0.05])
@pytest.mark.parametrize('mode', [0.0, MODE])
def test_the_sweep_ends_at_rest_on_the_goal_within_the_rate_cap_and_tau_ref(model, sweep, mode):
    trajectory = coasting_sweep(model, 0.9, H, 0.4, -1, sweep, mode)
    t, (r, r_d, r_dd, theta, theta_d, theta_dd) = _dense(trajectory)
    assert theta[0] == pytest.approx(0.4) and theta[-1] == pytest.approx(0.4 - sweep, abs=1e-12)
    assert theta_d[0] == 0.0 and theta_d[-1] == pytest.approx(0.0, abs=1e-12)
    assert np.all(r == 0.9) and not r_d.any() and not r_dd.any()
    assert np.abs(theta_d).max() <= model.yaw_rate * (1 + 1e-12)
    torque = model.tip_mass * 0.9 ** 2 * np.abs(theta_dd)
    assert torque.max() <= model.circular_torque * (1 + 1e-12)
    # the samples are consistent: the rate integrates the acceleration, the angle the rate
    dt = t[1] - t[0]
    np.testing.assert_allclose(np.cumsum(theta_dd[:-1]) * dt, theta_d[1:], atol=5e-3)
    np.testing.assert_allclose(theta[0] + np.cumsum(theta_d[:-1]) * dt, theta[1:], atol=5e-3)


def test_at_tau_ref_it_is_the_time_optimal_rest_to_rest_move(model):
    """Without the mode's rounding: S / v + v / a, a = tau_ref / (m r^2), when it coasts."""
    sweep = math.pi / 2
    trajectory = coasting_sweep(model, 0.9, H, 0.0, 1, sweep)
    a = model.circular_torque / (model.tip_mass * 0.9 ** 2)
    v = model.yaw_rate
    assert sweep * a > v * v  # the default robot's 90 deg sweep reaches the cap
    assert trajectory.duration == pytest.approx(sweep / v + v / a)
    assert trajectory.coast_time > 0.0


@pytest.mark.parametrize('sweep', [math.pi / 2, math.pi, 0.3, 0.05])
def test_each_acceleration_lasts_whole_periods_of_the_mode(model, sweep):
    """Whole periods of an undamped mode: a constant acceleration then leaves no residual."""
    period = 2.0 * math.pi / MODE
    fastest = coasting_sweep(model, 0.9, H, 0.0, 1, sweep)
    trajectory = coasting_sweep(model, 0.9, H, 0.0, 1, sweep, MODE)
    periods = trajectory.acceleration_time / period
    assert periods == pytest.approx(round(periods), abs=1e-9) and round(periods) >= 1
    assert trajectory.acceleration_time < fastest.acceleration_time + period
    assert trajectory.duration >= fastest.duration - 1e-12
    # the residual of the mode, driven by the planned acceleration, vanishes
    t, polar = _dense(trajectory, 40001)
    accel = polar[5]
    dt = t[1] - t[0]
    after = trajectory.duration
    residual = np.sum(accel * np.exp(1j * MODE * (after - t))) * dt
    scale = np.sum(np.abs(accel)) * dt
    assert abs(residual) < 2e-3 * scale


def test_bad_geometry_is_refused(model):
    with pytest.raises(ValueError, match='radius'):
        coasting_sweep(model, 0.0, H, 0.0, 1, 1.0)
    with pytest.raises(ValueError, match='rate cap'):
        coasting_sweep(dataclasses.replace(model, yaw_rate=math.inf), 0.9, H, 0.0, 1, 1.0)
    with pytest.raises(ValueError, match='sweep'):
        CoastingSweep(0.9, H, 0.0, 1, 0.0, 1.0, 1.0)
    with pytest.raises(ValueError, match='direction'):
        CoastingSweep(0.9, H, 0.0, 0, 1.0, 1.0, 1.0)


@pytest.mark.parametrize('goal, sweep', [((-0.9, 0.0, H), math.pi / 2),
                                         ((0.0, -0.9, H), math.pi)])
def test_a_rate_bound_plan_coasts_and_is_shorter_than_the_paper_triangle(
        robot, planner_parameters, goal, sweep):
    coasting, triangle = (PlanningContext.from_parameters(robot, dataclasses.replace(
        planner_parameters, bang_bang=dataclasses.replace(planner_parameters.bang_bang,
                                                          coast=coast)))
        for coast in (True, False))
    request = PlanRequest('bang_bang_node', 'a', ABOVE, goal)
    fast, paper = plan(request, coasting), plan(request, triangle)
    assert isinstance(fast.path, CoastingSweep)
    assert paper.duration == pytest.approx(paper.solution.duration)
    assert fast.duration < paper.duration - 0.3
    assert fast.time_optimal_bound == paper.time_optimal_bound
    assert fast.duration >= fast.time_optimal_bound
    np.testing.assert_allclose(fast.samples.position[-1], paper.samples.position[-1],
                               atol=1e-9)


def test_coasting_is_shipped_and_a_timed_plan_keeps_the_paper_profile(robot,
                                                                      planner_parameters):
    assert planner_parameters.bang_bang.coast
    context = PlanningContext.from_parameters(robot, planner_parameters)
    timed = plan(PlanRequest('bang_bang_node', 'a', ABOVE, (-0.9, 0.0, H), duration=4.0),
                 context)
    assert not isinstance(timed.path, CoastingSweep)
    assert timed.duration == pytest.approx(4.0)
