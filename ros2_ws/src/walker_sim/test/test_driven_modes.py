"""The modes joint 1's coarse motion excites: held, and driven under its coarse loop.

What a shaper designer needs to be true of the map: the held case is the springs' 18 rad/s,
the driven case is the loop on the flexible plant (between the held and the free joint),
frequencies are positive and damped, and everything is continuous in the configuration.
"""

import math

import numpy as np
import pytest
from scipy import signal

from walker_control.core.config import load_controller_settings
from walker_control.core.lowpass import design_lowpass_sos
from walker_control.core.modes import Mode
from walker_sim.core.driven_modes import (
    DRIVEN_JOINT, JointLoop, Plane, dominant_mode, driven_modes, held_modes, stance_at,
    stance_model)
from walker_sim.core.config import StartConfiguration
from walker_sim.core.flexibility import default_stance
from walker_sim.core.identification import (
    MAX_DAMPING, RIG_SOLVER_ITERATIONS, RIG_SOLVER_RESIDUAL, fit_modes)
from walker_sim.core.plant import WalkerPlant


@pytest.fixture(scope='module')
def settings():
    return load_controller_settings()


@pytest.fixture(scope='module')
def coarse_loop(settings):
    """Joint 1's coarse loop as shipped: wc, zc, Ka and its in-loop low-pass."""
    design = settings.loop_design(1, Mode.COARSE)
    sos = design_lowpass_sos(design.filter_order, design.filter_corner, settings.sample_time,
                             design.filter_kind)
    return {DRIVEN_JOINT: JointLoop(design.bandwidth, design.damping,
                                    design.acceleration_feedback,
                                    np.asarray(sos).reshape(-1, 6))}


@pytest.fixture(scope='module')
def default(params):
    return stance_model(params, default_stance(params))


@pytest.fixture(scope='module')
def approach(params):
    """Gripper b one spacing away at the approach height, where every coarse motion ends."""
    return stance_model(params, stance_at(params, 0.0, params.truss.spacing,
                                          params.gripper.approach_height))


def test_the_held_arm_has_joint_one_mode_of_the_paper(params, tuning, default):
    mode = dominant_mode(held_modes(default, tuning, params.robot.flexibility.damping_ratio))
    assert mode.frequency == pytest.approx(params.robot.flexibility.joint1_mode, rel=0.01)
    assert mode.damping == pytest.approx(params.robot.flexibility.damping_ratio, rel=0.01)


@pytest.mark.parametrize('factor', [0.85, 1.15])
def test_the_held_mode_follows_the_plants_mode_dispersion(params, tuning, default, factor):
    """The campaigns scale the plant's mode by f: the held mode is f times the nominal."""
    zeta = params.robot.flexibility.damping_ratio
    nominal = dominant_mode(held_modes(default, tuning, zeta))
    dispersed = dominant_mode(held_modes(default, tuning, zeta, {Plane.OUT_OF_PLANE: factor}))
    assert dispersed.frequency == pytest.approx(factor * nominal.frequency, rel=1e-6)
    assert dispersed.damping == pytest.approx(nominal.damping, rel=1e-6)


def test_a_soft_loop_leaves_joint_one_at_its_free_joint_resonance(tuning, default, settings):
    """As the gains vanish the driven mode is the collocated resonance the springs predict."""
    loop = {DRIVEN_JOINT: JointLoop(bandwidth=0.01, damping=1.0)}
    modes = driven_modes(default, tuning, loop, settings.sample_time, visible=0.0)
    lowest = min(m.frequency for m in modes if m.plane == Plane.OUT_OF_PLANE)
    assert lowest == pytest.approx(tuning.free_joint[DRIVEN_JOINT], rel=0.01)


def _strike_under_the_coarse_loop(plant, loop, inertia, sample_time, steps):
    """Joint 1 under its coarse loop, struck by a torque doublet; its velocity [rad/s]."""
    held = np.ones(5, dtype=bool)
    held[0] = False
    plant.hold_joints(held)
    plant.enable_friction(held)  # joint 1 slides: no stiction, as in the motion
    start = plant.state().position[0]
    state = np.zeros((len(loop.filter_sos), 2))
    theta = omega = previous = 0.0
    velocity = []
    for k in range(steps):
        command = (-inertia * loop.bandwidth ** 2 * theta
                   - 2.0 * loop.damping * loop.bandwidth * inertia * omega
                   - loop.acceleration_feedback * inertia * (omega - previous) / sample_time)
        filtered, state = signal.sosfilt(loop.filter_sos, [command], zi=state)
        torque = np.zeros(5)
        torque[0] = filtered[0] + (1.0 if k < 10 else -1.0 if k < 20 else 0.0)
        previous = omega
        measured = plant.step(torque, sample_time)
        theta, omega = measured.position[0] - start, measured.velocity[0]
        velocity.append(omega)
    return np.array(velocity[20:])


def test_the_driven_modes_are_those_the_simulated_plant_rings_at(params, sim, tuning, settings,
                                                                  coarse_loop):
    """Strike joint 1 on the plant under its coarse loop, fit its ring: the linearisation's."""
    plant = WalkerPlant(params, sim)
    try:
        plant.set_solver(RIG_SOLVER_ITERATIONS, RIG_SOLVER_RESIDUAL)
        plant.enable_contact(False)
        base = sim.start.base_node
        plant.reset(StartConfiguration(base_gripper='a', base_node=base,
                                       other_node=plant.truss.neighbors(base)[0],
                                       other_attached=False, other_height=0.0))
        stance = stance_model(params, plant.state().position)
        loop = coarse_loop[DRIVEN_JOINT]
        velocity = _strike_under_the_coarse_loop(plant, loop, stance.inertia[0],
                                                 settings.sample_time, steps=2000)
    finally:
        plant.close()
    time = np.arange(1, len(velocity) + 1) * settings.sample_time
    fitted = fit_modes(time, velocity)
    predicted = [m for m in driven_modes(stance, tuning, coarse_loop, settings.sample_time,
                                         visible=0.0) if m.plane == Plane.OUT_OF_PLANE]
    assert len(fitted) == len(predicted)
    for found, mode in zip(fitted, predicted, strict=True):
        assert found.frequency == pytest.approx(mode.frequency, rel=0.02)
        assert found.damping == pytest.approx(mode.damping, abs=0.02)


def test_the_driven_modes_are_positive_damped_and_out_of_the_arm_plane(tuning, approach,
                                                                       coarse_loop, settings):
    modes = driven_modes(approach, tuning, coarse_loop, settings.sample_time)
    assert modes
    for mode in modes:
        assert mode.frequency > 0.0 and mode.weight > 0.0
        assert 0.0 < mode.damping <= MAX_DAMPING
        assert mode.plane == Plane.OUT_OF_PLANE  # joint 1 turns the arm plane
    assert [m.frequency for m in modes] == sorted(m.frequency for m in modes)


def test_the_coarse_loop_moves_joint_ones_mode_away_from_the_held_one(params, tuning, approach,
                                                                      coarse_loop, settings):
    """Sliding under its soft coarse loop, joint 1 does not see the held arm's mode."""
    held = dominant_mode(held_modes(approach, tuning, params.robot.flexibility.damping_ratio))
    driven = driven_modes(approach, tuning, coarse_loop, settings.sample_time)
    assert min(m.frequency for m in driven) > 1.5 * held.frequency


@pytest.mark.parametrize('sweep', [math.pi / 2, math.pi])
def test_the_modes_do_not_depend_on_joint_one_angle(params, tuning, approach, coarse_loop,
                                                    settings, sweep):
    """Zero g and gripper a fixed: turning the whole arm about the base yaw changes nothing."""
    turned = stance_model(params, stance_at(params, sweep, params.truss.spacing,
                                            params.gripper.approach_height))
    for found, reference in (
            (driven_modes(turned, tuning, coarse_loop, settings.sample_time),
             driven_modes(approach, tuning, coarse_loop, settings.sample_time)),
            (held_modes(turned, tuning, 0.05), held_modes(approach, tuning, 0.05))):
        assert [m.frequency for m in found] == pytest.approx([m.frequency for m in reference],
                                                              rel=1e-6)


@pytest.mark.parametrize('reach', [0.5, 0.7, 0.85, 0.95, 1.1])
def test_the_map_is_continuous_in_the_reach(params, tuning, coarse_loop, settings, reach):
    """A millimetre of reach moves every mode of joint 1's plane by a small fraction."""
    height = params.gripper.approach_height
    branches = []
    for r in (reach, reach + 0.001):
        stance = stance_model(params, stance_at(params, 0.0, r, height))
        driven = driven_modes(stance, tuning, coarse_loop, settings.sample_time, visible=0.0)
        held = held_modes(stance, tuning, 0.05, visible=0.0)
        branches.append([m.frequency for m in (*held, *driven)
                         if m.plane == Plane.OUT_OF_PLANE])
    assert len(branches[0]) == len(branches[1])
    assert branches[1] == pytest.approx(branches[0], rel=0.01)


def test_bad_input_is_refused_with_a_clear_error(params, tuning, approach, settings):
    with pytest.raises(ValueError, match='bandwidth'):
        JointLoop(bandwidth=-1.0, damping=1.0)
    with pytest.raises(ValueError, match='filter_sos'):
        JointLoop(bandwidth=1.0, damping=1.0, filter_sos=np.ones((1, 5)))
    with pytest.raises(ValueError, match=DRIVEN_JOINT):
        driven_modes(approach, tuning, {'b_yaw_joint': JointLoop(1.0, 1.0)},
                     settings.sample_time)
    with pytest.raises(ValueError, match='sample_time'):
        driven_modes(approach, tuning, {DRIVEN_JOINT: JointLoop(1.0, 1.0)}, 0.0)
    with pytest.raises(ValueError, match='mode_scale'):
        held_modes(approach, tuning, 0.05, {Plane.OUT_OF_PLANE: 0.0})
    with pytest.raises(ValueError):
        stance_at(params, 0.0, 5.0)  # out of reach


def test_an_unstable_loop_is_refused(params, tuning, settings):
    """Acceleration feedback without its filter destabilises joint 1: no modes are made up."""
    stance = stance_model(params, stance_at(params, 0.3, 0.5, params.gripper.approach_height))
    loop = {DRIVEN_JOINT: JointLoop(0.6, 1.0, acceleration_feedback=0.25)}
    with pytest.raises(ValueError, match='unstable'):
        driven_modes(stance, tuning, loop, settings.sample_time)
