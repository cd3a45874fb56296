"""Route planning over the truss: steps, sweeps, shortest walks, refusals."""

import math

import pytest

from walker_core.truss import Truss, UnknownNodeError
from walker_supervisor.core.route import (
    PlannedStep, Stance, UnreachableTargetError, plan_route, possible_steps, step_sweep)

TRUSS = Truss(spacing=0.9, columns=5, rows=4)
START = Stance('a', 'n1_1', 'n2_1')


def test_sweeps_are_quarter_and_half_turns():
    assert step_sweep(TRUSS, 'n1_1', 'n2_1', 'n1_2') == pytest.approx(math.pi / 2)
    assert step_sweep(TRUSS, 'n1_1', 'n2_1', 'n1_0') == pytest.approx(-math.pi / 2)
    assert step_sweep(TRUSS, 'n1_1', 'n2_1', 'n0_1') == pytest.approx(math.pi)


def test_possible_steps_go_to_the_other_neighbours_of_the_base():
    steps = possible_steps(TRUSS, START)
    assert sorted(s.to_node for s in steps) == ['n0_1', 'n0_1', 'n1_0', 'n1_2']  # 2 half turns
    assert all(s.moving_gripper == 'b' and s.from_node == 'n2_1' for s in steps)
    after = steps[0].stance_after()
    assert after.base_gripper == 'b' and after.other_node == 'n1_1'


def test_route_alternates_grippers_and_each_step_is_valid():
    route = plan_route(TRUSS, START, 'n4_3')
    assert route, 'a route is expected'
    stance = START
    for step in route:
        assert step.base_gripper == stance.base_gripper
        assert step.base_node == stance.base_node and step.from_node == stance.other_node
        assert step.to_node in TRUSS.neighbors(step.base_node)
        stance = step.stance_after()
    assert stance.base_node == 'n4_3'


def test_route_is_shortest():
    # Compared with a breadth-first enumeration of every stance reachable in k steps.
    for target in ['n0_1', 'n1_2', 'n3_1', 'n4_3', 'n0_0']:
        route = plan_route(TRUSS, START, target, step_cost=lambda s: 1.0)
        assert len(route) == _brute_force_steps(START, target)


def _brute_force_steps(stance, target, limit=8):
    frontier = [stance]
    for depth in range(limit + 1):
        if any(target in (s.base_node, s.other_node) for s in frontier):
            return depth
        frontier = [step.stance_after() for s in frontier for step in possible_steps(TRUSS, s)]
    raise AssertionError('not reached')


def test_target_already_occupied_needs_no_step():
    assert plan_route(TRUSS, START, 'n2_1') == []
    assert plan_route(TRUSS, START, 'n1_1') == []


@pytest.mark.parametrize('target', ['n9_9', 'x', ''])
def test_unknown_targets_are_refused(target):
    with pytest.raises(UnknownNodeError):
        plan_route(TRUSS, START, target)


def test_unreachable_target_is_refused_with_a_reason():
    # On a line of three nodes, a walker pivoting on the end node has nowhere to swing to.
    line = Truss(spacing=0.9, columns=3, rows=1)
    with pytest.raises(UnreachableTargetError, match='no sequence of steps'):
        plan_route(line, Stance('a', 'n0_0', 'n1_0'), 'n2_0')
    assert len(plan_route(line, Stance('a', 'n1_0', 'n0_0'), 'n2_0')) == 1


def test_stance_must_be_on_neighbouring_nodes():
    with pytest.raises(UnknownNodeError, match='not neighbouring'):
        plan_route(TRUSS, Stance('a', 'n0_0', 'n2_0'), 'n4_3')
    with pytest.raises(ValueError):
        Stance('a', 'n0_0', 'n0_0')
    with pytest.raises(ValueError):
        step_sweep(TRUSS, 'n1_1', 'n3_1', 'n0_1')


def test_half_turn_flag():
    assert PlannedStep('a', 'n1_1', 'n2_1', 'n0_1', math.pi).is_half_turn
    assert not PlannedStep('a', 'n1_1', 'n2_1', 'n1_2', math.pi / 2).is_half_turn


YAW_LIMITS = (-3.5, 3.5)


def test_half_turns_offer_both_directions_within_the_yaw_limits():
    both = [s.sweep for s in possible_steps(TRUSS, START, (0.0, 0.0), YAW_LIMITS)
            if s.to_node == 'n0_1']
    assert sorted(both) == pytest.approx([-math.pi, math.pi])
    wound = [s.sweep for s in possible_steps(TRUSS, START, (math.pi, math.pi), YAW_LIMITS)]
    assert all(sweep < 0 for sweep in wound), 'from +pi only clockwise sweeps stay in limits'


def test_routes_never_wind_the_yaw_joints_past_their_limits():
    for target in TRUSS.node_names:
        for yaws in ((0.0, 0.0), (math.pi, math.pi), (-math.pi / 2, -math.pi / 2)):
            try:
                route = plan_route(TRUSS, START, target, yaws=yaws, yaw_limits=YAW_LIMITS)
            except UnreachableTargetError:
                continue
            total = yaws[0]
            for step in route:
                total += step.sweep
                assert YAW_LIMITS[0] <= total <= YAW_LIMITS[1]


def test_a_wound_walker_is_refused_a_target_it_cannot_turn_to():
    # On a 2 x 2 truss the only way round is turning the same way: the winding stops it.
    square = Truss(spacing=0.9, columns=2, rows=2)
    start = Stance('a', 'n0_0', 'n1_0')
    with pytest.raises(UnreachableTargetError, match='yaw joints'):
        plan_route(square, start, 'n1_1', yaws=(3.0, 3.0), yaw_limits=YAW_LIMITS)
    assert plan_route(square, start, 'n1_1', yaws=(0.0, 0.0), yaw_limits=YAW_LIMITS)
