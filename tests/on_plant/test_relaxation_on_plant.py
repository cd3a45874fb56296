"""The relaxation dither on the flexible plant: the bend a screw-in locks in, and its release.

Gripper b is screwed in 1 mm off its hole's axis: the hole draws it onto the axis, joint 1 stays
where its stiction holds it, and the links bend. The joint angles then put the tip (forward
kinematics from the base's true pose) about a millimetre from where it is. The HOLD command that
ends a step (base gripper b) runs the relaxation dither first: the joints slide out of the bend.
Without it (``control.relaxation.duration`` 0) the bend stays.
"""

import numpy as np
import pytest

from plant_loop import ClosedLoop
from walker_control.core.config import load_controller_settings
from walker_control.core.modes import Mode
from walker_core.parameter_schema import replace_in_section
from walker_core.robot_parameters import load_walker_parameters
from walker_sim.core.config import StartConfiguration, load_sim_parameters
from walker_sim.core.plant import WalkerPlant

PARAMS = load_walker_parameters()
SIM = load_sim_parameters()
SETTINGS = load_controller_settings()
OFFSET = 0.0016  # [rad] of joint 1: the tip settles about 1 mm off the axis (friction)


def bend_after_seating(settings):
    """Return the tip's gap [m] (joints' kinematics to true) before and after the step's end."""
    start = StartConfiguration('a', SIM.start.base_node, SIM.start.other_node, False, 0.0)
    with WalkerPlant(PARAMS, SIM) as plant:
        loop = ClosedLoop(plant, settings)
        target = plant.reset(start).position.copy()
        target[0] += OFFSET
        loop.command(Mode.FINE)
        loop.hold_setpoint(target, 6.0)  # joint 1 settles within its 0.5 mrad
        tip, _ = loop.tip_and_fk(loop.state)
        node = plant.truss.position(SIM.start.other_node)
        offset = float(np.linalg.norm(tip[:2] - node[:2]))
        assert plant.screw_in('b').success
        loop.hold_setpoint(target, PARAMS.gripper.screw_time + 0.3)  # fine mode, as in a step
        tip, fk = loop.tip_and_fk(loop.state)
        seated = float(np.linalg.norm(fk[:2] - tip[:2]))
        for controller in loop.controllers:  # the step's end: HOLD with the new base
            controller.command(Mode.HOLD, 'b')
        loop.hold_setpoint(target, settings.control.relaxation.duration + 0.3)
        assert not any(controller.relaxing for controller in loop.controllers)
        tip, fk = loop.tip_and_fk(loop.state)
        return offset, seated, float(np.linalg.norm(fk[:2] - tip[:2]))


@pytest.mark.parametrize('relax', [True, False], ids=['relaxed', 'not_relaxed'])
def test_the_dither_releases_the_bend_a_seat_locks_in(relax):
    settings = SETTINGS if relax else replace_in_section(
        SETTINGS, {'control.relaxation.duration': 0.0})
    offset, seated, after = bend_after_seating(settings)
    assert 0.7e-3 < offset < 1.6e-3, 'the tip was not aimed off the axis as the test needs'
    assert seated > 0.5e-3, 'screwed in off the axis, the links bend and the joints stay'
    if relax:
        assert after < 0.2e-3, f'relaxed, the joints are still {after * 1e3:.2f} mm off'
    else:
        assert after > 0.5e-3, 'without the relaxation the bend stays'
