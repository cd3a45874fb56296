"""LOOKING: the wrist camera aligns the gripper over the hole before the descent.

The sequencer runs in ``sequencer_world``'s ideal world; its camera is a pinhole at the nominal
mount that sees the true hole exactly (:func:`_sighting`): the hole as a look at an assumed
height places it, on the line of sight from the camera's centre to the true hole.
"""

import dataclasses
import math

import numpy as np
import pytest

from sequencer_world import KIN, PARAMS, SUPERVISOR, TRUSS, World
from walker_core.camera import CameraModel
from walker_supervisor.core.commands import LookRequest, Notice, TrajectoryRequest
from walker_supervisor.core.looking import LOOK_WAIT
from walker_supervisor.core.route import possible_steps
from walker_supervisor.core.sequencer import StepSequencer
from walker_supervisor.core.sighting import Sighting, combine, frame_weights, locate

MOUNT = CameraModel.from_parameters(PARAMS.gripper.camera).mount
LATENCY = 0.03  # [s] a frame is ready this long after it was asked for
INTERVAL = math.pi / PARAMS.robot.flexibility.joint1_mode  # [s] between a look's frames


def _sighting(theta, hole, assumed_height, sigma=2e-5):
    """Return the look of a perfect camera at ``hole`` [m] (base frame), at an assumed height."""
    pose = KIN.forward_transform(theta)
    centre = (pose @ np.append(MOUNT[:3, 3], 1.0))[:3]
    sight = np.asarray(hole, dtype=float) - centre
    seen = centre + sight * (assumed_height - centre[2]) / sight[2]
    offset = np.linalg.solve(pose, np.append(seen, 1.0))[:2]
    return Sighting(seen, sight[:2] / sight[2], offset, sigma, '', 'a perfect look')


class LookingWorld(World):
    """The ideal world with a camera on the grippers and the hole ``hole_shift`` off its estimate.

    ``frames``: 'seen' (the camera sees the true hole), 'unseen' (it never does), 'none' (no
    frame ever comes). ``height_std`` [m] is the map's height uncertainty the looks start from.
    """

    def __init__(self, hole_shift=(0.0, 0.0, 0.0), frames='seen', height_std=0.002,
                 parameters=SUPERVISOR, camera=True, **options):
        super().__init__(**options)
        self.sequencer = StepSequencer(parameters, KIN, self.stance.base_gripper, camera=camera,
                                       frame_interval=INTERVAL)
        self.parameters = parameters
        self.hole_shift = np.asarray(hole_shift, dtype=float)
        self.frames, self.height_std = frames, height_std
        self.frames_due = []  # (time, request) of frames asked for
        self.looks = []  # (time, tip [m], request) of every look asked for

    def run_step(self, step, max_time=60.0):
        self.hole = None
        return super().run_step(step, max_time)

    def execute(self, commands):
        super().execute([c for c in commands if not isinstance(c, LookRequest)])
        for command in commands:
            if isinstance(command, LookRequest):
                self.log.append(command)
                self.looks.append((self.now, KIN.forward(self.theta)[:3], command))
                if self.frames != 'none':
                    self.frames_due.append((self.now + LATENCY, command))

    def advance(self):
        if self.hole is None:
            self.hole = self.targets.point_to + self.hole_shift
        for due in [f for f in self.frames_due if f[0] <= self.now + 1e-9]:
            self.frames_due.remove(due)
            if self.frames == 'unseen':
                seen = Sighting(None, None, None, math.inf, 'out of view', 'no dark disc')
            else:
                seen = _sighting(self.theta, self.hole, float(self.sequencer.targets.point_to[2]))
            self.execute(self.sequencer.frame_seen(seen, float(self.targets.point_to[2]),
                                                   self.height_std, self.now))
        super().advance()

    @property
    def looks_taken(self):
        """Looks asked for: each asks for ``look_frames`` frames."""
        frames = self.parameters.look_frames
        assert len(self.looks) % frames == 0
        return len(self.looks) // frames

    def requests(self, purpose):
        return [c for c in self.log if isinstance(c, TrajectoryRequest) and c.purpose == purpose]

    def notices(self, level):
        return [c.message for c in self.log if isinstance(c, Notice) and c.level == level]


def _step(world):
    return possible_steps(TRUSS, world.stance)[0]


def test_a_hole_off_its_estimate_and_height_is_located_and_the_descent_goes_down_its_axis():
    world = LookingWorld(hole_shift=(0.002, -0.001, 0.0015))  # 2.4 mm off, 1.5 mm high
    outcome = world.run_step(_step(world))
    assert outcome.success, outcome.message
    lifts = world.requests('look_lift')
    assert len(lifts) == 1, 'one look from higher measures the height'
    assert lifts[0].goal_point[2] > lifts[0].start_point[2]
    np.testing.assert_allclose(lifts[0].goal_point[:2], lifts[0].start_point[:2], atol=1e-9)
    assert world.looks_taken >= 2
    descent = world.requests('insertion')[-1]
    np.testing.assert_allclose(descent.goal_point, world.hole, atol=5e-5)
    located = world.sequencer.targets.point_to
    np.testing.assert_allclose(located, world.hole, atol=5e-5)


def test_a_looks_frames_are_half_a_period_of_the_link_mode_apart():
    world = LookingWorld(hole_shift=(0.002, 0.0, 0.0))
    world.run_step(_step(world))
    times = np.array([t for t, _, _ in world.looks]).reshape(-1, SUPERVISOR.look_frames)
    np.testing.assert_allclose(np.diff(times, axis=1), INTERVAL, atol=0.011)  # a tick


def _descent_time(world):
    return next(t for t, r in world.requested if r.purpose == 'insertion')


def test_the_first_look_costs_no_wait_and_every_other_waits_for_the_arm_at_rest():
    blind = LookingWorld(hole_shift=(0.002, 0.0, 0.0), camera=False)
    blind.run_step(_step(blind))
    world = LookingWorld(hole_shift=(0.002, 0.0, 0.0))
    world.run_step(_step(world))
    firsts = [time for time, _, _ in world.looks[::SUPERVISOR.look_frames]]
    assert len(firsts) >= 2
    # the first where the blind walker would start its descent, the arm not at rest yet
    assert firsts[0] <= _descent_time(blind) + 1e-9
    for time in firsts[1:]:
        still_since = max(t for t, stage in world.stages if t < time and stage != 'settling'
                          and stage != 'looking')
        assert time - still_since >= SUPERVISOR.look_settle_time - 1e-9


def test_a_look_on_arrival_that_finds_the_hole_elsewhere_is_set_aside_for_one_at_rest():
    world = LookingWorld(hole_shift=(0.002, 0.0, 0.0))
    outcome = world.run_step(_step(world))
    assert outcome.success, outcome.message
    assert any('look on arrival is set aside' in m for m in world.notices('info'))
    # the looks the hole was located from are those at rest (a lift's look among them)
    assert len(world.sequencer._run.looks.sightings) == world.looks_taken - 1


@pytest.mark.parametrize('height_std', [1e-5, 0.002])
def test_a_hole_where_the_map_has_it_is_confirmed_by_one_look(height_std):
    """Surveyed or not, a hole where the map has it is confirmed by one look.

    A hole lower and off along the line of sight looks the same to one look, and the descent
    feels the height.
    """
    world = LookingWorld(height_std=height_std)
    outcome = world.run_step(_step(world))
    assert outcome.success, outcome.message
    assert world.looks_taken == 1
    assert not world.requests('look_lift') and not world.requests('fine')
    assert _descent_time(world) - world.looks[0][0] \
        == pytest.approx((SUPERVISOR.look_frames - 1) * INTERVAL + LATENCY, abs=0.025)


def test_a_hole_not_seen_goes_on_blind_at_the_estimate():
    world = LookingWorld(frames='unseen')
    outcome = world.run_step(_step(world))
    assert outcome.success, outcome.message
    assert world.looks_taken == 2, 'not seen on arrival, looked at again at rest'
    assert any('not seen on arrival' in m for m in world.notices('info'))
    assert any('not seen (out of view' in m for m in world.notices('warning'))
    np.testing.assert_allclose(world.requests('insertion')[-1].goal_point,
                               world.targets.point_to, atol=1e-12)


def test_a_camera_that_sends_no_frame_is_waited_for_a_bounded_time_then_the_step_goes_on():
    world = LookingWorld(frames='none')
    outcome = world.run_step(_step(world))
    assert outcome.success, outcome.message
    assert world.looks_taken == 1
    assert any('no frame from the camera' in m for m in world.notices('warning'))
    descent = next(t for t, r in world.requested if r.purpose == 'insertion')
    assert descent - world.looks[-1][0] == pytest.approx(LOOK_WAIT, abs=0.05)


@pytest.mark.parametrize('camera, looks', [(False, 4), (True, 0)])
def test_the_blind_robot_never_looks(camera, looks):
    """Without a camera, or with ``max_looks`` 0, the step is the paper's blind one."""
    parameters = dataclasses.replace(SUPERVISOR, max_looks=looks)
    world = LookingWorld(hole_shift=(0.0005, 0.0, 0.0), parameters=parameters, camera=camera)
    outcome = world.run_step(_step(world))
    assert outcome.success, outcome.message
    assert not world.looks


def test_a_frame_nobody_asked_for_is_refused_and_changes_nothing():
    world = LookingWorld()
    with pytest.raises(Exception, match='no look is under way'):
        world.sequencer.frame_seen(_sighting(world.theta, np.zeros(3), 0.0), 0.0, 0.001, 0.0)


# ---------------------------------------------------------------------- locate
def _looks_at(hole, centres, assumed_height, sigma=1e-6):
    looks = []
    for centre in centres:
        sight = hole - centre
        seen = centre + sight * (assumed_height - centre[2]) / sight[2]
        looks.append(Sighting(seen, sight[:2] / sight[2], np.zeros(2), sigma, '', ''))
    return looks


def test_one_look_places_the_hole_on_its_line_of_sight_at_the_height_known_before():
    hole = np.array([0.01, 0.5, 0.0])
    looks = _looks_at(hole, [np.array([0.055, 0.5, 0.035])], assumed_height=0.0)
    position, covariance = locate(looks, height=0.0, height_std=0.002)
    np.testing.assert_allclose(position, hole, atol=1e-9)
    assert covariance[2, 2] == pytest.approx(0.002 ** 2, rel=1e-6), 'one look: no height'


def test_two_lines_of_sight_measure_a_height_the_map_had_wrong():
    hole = np.array([0.01, 0.5, 0.003])  # 3 mm above where the map has it
    centres = [np.array([0.055, 0.5, 0.035]), np.array([0.055, 0.5, 0.050])]
    looks = _looks_at(hole, centres, assumed_height=0.0)
    one, _ = locate(looks[:1], height=0.0, height_std=0.002)
    assert np.linalg.norm(one[:2] - hole[:2]) > 0.002, 'one look is fooled by the height'
    both, covariance = locate(looks, height=0.0, height_std=0.002)
    np.testing.assert_allclose(both, hole, atol=1e-5)
    assert math.sqrt(covariance[2, 2]) < 2e-4


# ---------------------------------------------------------------------- a look's frames
@pytest.mark.parametrize('detuning, left', [(1.0, 1e-12), (0.85, 0.055), (1.15, 0.055)])
def test_a_looks_frames_cancel_the_links_ringing_within_15_percent_of_its_mode(detuning,
                                                                                left):
    """Three frames half a period apart, weighted 1:2:1: the ringing's residue is cos^2."""
    omega = detuning * PARAMS.robot.flexibility.joint1_mode
    hole, amplitude = np.array([0.01, 0.5, 0.0]), 5e-4
    worst = 0.0
    for phase in np.linspace(0.0, 2 * math.pi, 24):
        frames = []
        for k in range(3):
            swing = amplitude * math.sin(omega * k * INTERVAL + phase)
            seen = hole + np.array([0.0, swing, 0.0])
            frames.append(Sighting(seen, np.zeros(2), seen[:2], 1e-5, '', ''))
        worst = max(worst, abs(combine(frames).hole[1] - hole[1]))
    assert worst <= left * amplitude + 1e-12
    assert worst >= 0.9 * left * amplitude - 1e-12, "the residue is the theory's, not less"


def test_the_frames_that_saw_the_hole_are_weighted_and_a_look_that_saw_nothing_is_not_seen():
    assert frame_weights(3).tolist() == [0.25, 0.5, 0.25]
    assert frame_weights(1).tolist() == [1.0]
    seen = Sighting(np.ones(3), np.zeros(2), np.ones(2), 1e-5, '', 'seen')
    unseen = Sighting(None, None, None, math.inf, 'occluded', 'a bar')
    np.testing.assert_allclose(combine([unseen, seen, seen]).hole, np.ones(3))
    assert combine([unseen, unseen]).reason == 'occluded'
    with pytest.raises(ValueError, match='at least one frame'):
        frame_weights(0)
