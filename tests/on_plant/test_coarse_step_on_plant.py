"""A coarse step on the flexible plant ends where the joints say it does.

The walker has no tip sensing (paper section 2): insertion relies on the joint angles. After the
coarse motion of a step the links must not keep a bend the joints cannot see, and the tip must
come within the insertion tolerance of the point above the target. The plant core, the five
controller cores and the planner core run in one process (no ROS), at the control rate.
"""

import math

import numpy as np
import pytest

from plant_loop import ClosedLoop
from walker_control.core.config import load_controller_settings
from walker_control.core.modes import Mode
from walker_core.parameter_schema import load_parameter_file, section_from_flat
from walker_core.robot_parameters import default_parameter_file, load_walker_parameters
from walker_planner.core.parameters import PlannerParameters
from walker_planner.core.planning import PlanningContext, PlanRequest, plan
from walker_sim.core.config import StartConfiguration, load_sim_parameters
from walker_sim.core.plant import WalkerPlant

PARAMS = load_walker_parameters()
#: "Within a few seconds": the time after the end of the coarse motion by which the tip must
#: be, and stay, within the insertion tolerance [s]; then how long it is watched [s].
ALLOWANCE = 3.0
WATCH = 1.0


@pytest.fixture(scope='module')
def coarse_step():
    """Run a 90 deg step of gripper b about gripper a at the planner's nominal plan.

    Gripper a is screwed into n1_1; gripper b starts free at the approach height above n2_1
    (where extraction leaves it) and moves above n1_2; the controllers are in COARSE mode and
    the planner keeps streaming the final point after the plan ends.
    """
    sim = load_sim_parameters()
    settings = load_controller_settings()
    planner = section_from_flat(PlannerParameters, load_parameter_file(default_parameter_file()),
                                'planner.')
    height = PARAMS.gripper.approach_height
    base_node, from_node, to_node = 'n1_1', 'n2_1', 'n1_2'
    with WalkerPlant(PARAMS, sim) as plant:
        state = plant.reset(StartConfiguration('a', base_node, from_node, False, height))
        loop = ClosedLoop(plant, settings)
        at_rest = loop.tip_and_fk(state)
        base_inverse = np.linalg.inv(state.poses['a'].matrix())
        lift = np.array([0.0, 0.0, height])

        def in_base(node):
            return (base_inverse @ np.r_[plant.truss.position(node) + lift, 1.0])[:3]

        request = PlanRequest('bang_bang_node', 'a', tuple(in_base(from_node)),
                              tuple(in_base(to_node)), start_joints=tuple(state.position))
        coarse = plan(request, PlanningContext.from_parameters(PARAMS, planner))
        loop.command(Mode.COARSE)
        loop.follow(coarse.samples.position, coarse.samples.velocity,
                    coarse.samples.acceleration)
        end = loop.state.time
        loop.hold_setpoint(coarse.samples.position[-1], ALLOWANCE + WATCH)
        time, _, tip, fk_tip = loop.record.arrays()
    return {'plan': coarse, 'end': end, 'time': time, 'tip': tip, 'fk_tip': fk_tip,
            'target': plant.truss.position(to_node) + lift, 'at_rest': at_rest}


def test_the_loop_sees_the_tip_where_the_plant_puts_it_at_rest(coarse_step):
    """Straight links at rest: the forward kinematics of the joints is the true tip."""
    tip, fk_tip = coarse_step['at_rest']
    assert np.linalg.norm(tip - fk_tip) < 1e-6


def test_the_step_is_the_nominal_quarter_turn(coarse_step):
    first, last = coarse_step['plan'].samples.position[[0, -1]]
    assert abs(last[0] - first[0]) == pytest.approx(math.pi / 2, abs=1e-3)
    assert coarse_step['plan'].duration > coarse_step['plan'].time_optimal_bound


def test_the_true_tip_comes_within_the_insertion_tolerance_of_the_point_above_the_target(
        coarse_step):
    time, tip = coarse_step['time'], coarse_step['tip']
    watched = time >= coarse_step['end'] + ALLOWANCE
    error = np.linalg.norm(tip[watched] - coarse_step['target'], axis=1)
    assert watched.sum() > 0
    assert error.max() < PARAMS.gripper.insertion_position_tolerance, (
        f'the tip is {1e3 * error.max():.2f} mm from the point above the target '
        f'{ALLOWANCE:g} s after the coarse motion')


def test_the_links_keep_no_bend_that_the_joints_cannot_see(coarse_step):
    """The gap between the true tip and the forward kinematics of the measured joints."""
    time = coarse_step['time']
    gap = np.linalg.norm(coarse_step['tip'] - coarse_step['fk_tip'], axis=1)
    watched = time >= coarse_step['end'] + ALLOWANCE
    assert gap[watched].max() < PARAMS.gripper.insertion_position_tolerance
    # and it keeps shrinking: the bend rings out instead of being locked in by friction
    first_second = (time >= coarse_step['end']) & (time < coarse_step['end'] + 1.0)
    assert gap[watched].max() < 0.5 * gap[first_second].max()
