"""A descent on the flexible plant, with and without the wrist in step with the arm.

The insertion line is planned vertical; the joints that carry it out must keep step with one
another for the tip to follow it. Joints 2 and 3 follow their setpoints through their command
filters (56-58 ms behind); joint 4, the moving wrist, has no command filter (paper section 3)
and leads them as shipped, swinging the gripper sideways in mid-descent by more than the
insertion tolerance (it comes back on the axis at the mouth). Passing its setpoints through the
same filter outside its loop (``control.filter.setpoint_order`` and ``setpoint_corner``, off by
default: docs/performance.md gives the trade) keeps the descent within half the
tolerance. The plant core, the five controller cores and the planner core run in one process
(no ROS), at the control rate.
"""

import dataclasses

import numpy as np
import pytest

from plant_loop import ClosedLoop
from walker_control.core.config import ControllerSettings, load_controller_settings
from walker_control.core.modes import Mode
from walker_core.parameter_schema import load_parameter_file, section_from_flat
from walker_core.robot_parameters import default_parameter_file, load_walker_parameters
from walker_planner.core.parameters import PlannerParameters
from walker_planner.core.planning import PlanningContext, PlanRequest, plan
from walker_sim.core.config import StartConfiguration, load_sim_parameters
from walker_sim.core.plant import WalkerPlant

PARAMS = load_walker_parameters()
#: How long the controllers keep the final setpoint after the descent's plan [s].
SETTLE = 0.3


def wrist_in_step(settings: ControllerSettings) -> ControllerSettings:
    """Return ``settings`` with J4's setpoints through J2's command filter."""
    control = settings.control
    filters = dataclasses.replace(
        control.filter, setpoint_order=(0, 0, 0, control.filter.order[1], 0),
        setpoint_corner=(0.0, 0.0, 0.0, control.filter.corner[1], 0.0))
    return dataclasses.replace(settings, control=dataclasses.replace(control, filter=filters))


def descend(settings: ControllerSettings) -> dict:
    """Lower gripper b from the approach height onto n2_1 (gripper a in n1_1), FINE mode.

    Returns the largest horizontal distance of the true tip from the hole's axis while it is
    above the mouth [m], and the plan.
    """
    sim = load_sim_parameters()
    planner = section_from_flat(PlannerParameters, load_parameter_file(default_parameter_file()),
                                'planner.')
    height = PARAMS.gripper.approach_height
    with WalkerPlant(PARAMS, sim) as plant:
        state = plant.reset(StartConfiguration('a', 'n1_1', 'n2_1', False, height))
        loop = ClosedLoop(plant, settings)
        base_inverse = np.linalg.inv(state.poses['a'].matrix())
        hole = plant.truss.position('n2_1')

        def in_base(point):
            return tuple((base_inverse @ np.r_[point, 1.0])[:3])

        request = PlanRequest('insertion_line', 'a', in_base(hole + [0.0, 0.0, height]),
                              in_base(hole), start_joints=tuple(state.position))
        descent = plan(request, PlanningContext.from_parameters(PARAMS, planner))
        loop.command(Mode.FINE)
        loop.follow(descent.samples.position, descent.samples.velocity,
                    descent.samples.acceleration)
        loop.hold_setpoint(descent.samples.position[-1], SETTLE)
        _, _, tip, _ = loop.record.arrays()
    above = tip[:, 2] > hole[2] + 1e-4
    off_axis = np.hypot(*(tip[above, :2] - hole[:2]).T)
    return {'off_axis': off_axis.max(), 'samples': int(above.sum()), 'plan': descent}


@pytest.fixture(scope='module')
def descents():
    settings = load_controller_settings()
    return {'shipped': descend(settings), 'in step': descend(wrist_in_step(settings))}


def test_as_shipped_the_wrist_has_no_setpoint_filter_and_joints_2_3_one_design():
    control = load_controller_settings().control.filter
    assert control.setpoint_order == (0, 0, 0, 0, 0)
    assert (control.order[1], control.corner[1]) == (control.order[2], control.corner[2])


def test_with_the_wrist_in_step_the_descent_stays_within_half_the_insertion_tolerance(
        descents):
    """The descent keeps to the axis within half the insertion tolerance.

    It swings 0.8 mm off: joint 3 moves 1.3 mrad in the descent, and its stiction holds it
    back by about 1.5 mrad at the middle (the joints' lag, 56-58 ms, is matched).
    """
    in_step = descents['in step']
    assert in_step['samples'] > in_step['plan'].duration * PARAMS.timing.control_rate / 2
    limit = PARAMS.gripper.insertion_position_tolerance / 2
    assert in_step['off_axis'] < limit, (
        f"the gripper swung {1e3 * in_step['off_axis']:.2f} mm off the hole's axis descending")


def test_as_shipped_the_wrist_leads_and_the_descent_swings_past_the_insertion_tolerance(
        descents):
    """What the setpoint filter is for (a known limit of the shipped controller)."""
    shipped = descents['shipped']['off_axis']
    assert shipped > PARAMS.gripper.insertion_position_tolerance
    assert shipped > 2 * descents['in step']['off_axis']
