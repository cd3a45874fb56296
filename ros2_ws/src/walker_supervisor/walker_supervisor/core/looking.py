"""LOOKING, in FINE above the hole: the wrist camera aligns the gripper before the descent.

Where the blind walker would descend (:func:`~walker_supervisor.core.approach.fine_settling`),
a gripper that carries a camera looks first (``max_looks`` > 0): the approach's first look at
once (:func:`on_arrival`), any other once the joints have been still for ``look_settle_time``.
A look asks for ``look_frames`` frames
(:class:`~walker_supervisor.core.commands.LookRequest`), ``frame_interval`` apart, and waits in
``Stage.LOOKING`` for them, at most :data:`LOOK_WAIT` after the last. The joints do not see the
links ring (the joint-1 link's mode, 18 rad/s, damped 2.5-7.5 %, swings the tip half a
millimetre for seconds after the joints are still); frames half its period apart, binomially
weighted, cancel it in their mean (:func:`~walker_supervisor.core.sighting.combine`). What the
look shows (:class:`~walker_supervisor.core.sighting.Sighting`, each frame placed by the walk
runner through the joints at its instant) decides:

* the hole located within ``look_alignment`` of where the step aims: confirmed, and the step
  goes on as the blind one would (descend once the tip is over the hole: the descent closes
  the last of the tip's error, and the insertion checks it against the axis at the mouth). A
  look from the approach height alone cannot tell a hole in place from one lower and off
  along its line of sight; the descent feels the height;
* a look taken on arrival that does not confirm the hole (or did not see it) is set aside:
  before the arm is at rest the links put the gripper a few tenths of a millimetre off where
  its joints say, too much to measure the height with; the step looks again at rest;
* a hole located to more than :data:`LOOK_SPREAD` of ``look_alignment`` (one look cannot tell
  the node's height: the camera looks 52 degrees off the gripper's axis, so a millimetre of
  height moves the hole 1.3 mm along its line of sight): the step's targets move onto the hole
  seen with the point above it :data:`LOOK_HEIGHT` times the approach height over the mouth, and
  the gripper lifts straight up there and looks again, along a steeper line of sight (from
  lower, its own body hides the hole); the looks together measure the height
  (:func:`~walker_supervisor.core.sighting.locate`);
* located well, and farther than ``look_alignment`` from where the step aims: the targets move
  onto the hole, and a fine line takes the tip there before the descent (without another
  look); not located well after ``max_looks`` looks: the same, to the hole last located;
* not seen (out of view, occluded, ambiguous) or no frame in time: the descent goes on blind,
  and a jam searches as it would without a camera.

Each hole seen becomes the centre of the step's search (``run.estimate``): a jam after a look
searches around what the camera saw, from the search's first probe. A height felt on the
node's face that differs from the one the last look assumed by more than ``look_alignment``
makes the next approach look again: the camera measures the hole's place along its line of
sight at the assumed height, so a height error moves it.
"""

from __future__ import annotations

import math

import numpy as np

from walker_core.kinematics import KinematicsError
from walker_supervisor.core import transitions
from walker_supervisor.core.commands import LookRequest, Notice
from walker_supervisor.core.hole_search import HoleSearch
from walker_supervisor.core.phases import Stage
from walker_supervisor.core.sighting import Sighting, combine, frame_weights, locate
from walker_supervisor.core.step_geometry import (
    probe_targets, raised_approach, shifted_targets)
from walker_supervisor.core.step_run import Looks, StepRun

__all__ = ['Looks', 'LOOK_WAIT', 'LOOK_SPREAD', 'LOOK_HEIGHT', 'wanted', 'on_arrival', 'look',
           'waiting', 'seen', 'height_felt']

#: [s] A frame not back this long after it was asked for: the descent goes on blind.
LOOK_WAIT = 2.0
#: A hole located to more than this fraction of ``look_alignment`` (its worst horizontal
#: standard deviation) is looked at again from higher, along a steeper line of sight.
LOOK_SPREAD = 0.5
#: The higher look's height over the hole, as a multiple of the approach height (lower, the
#: gripper's own body hides the hole from its camera).
LOOK_HEIGHT = 1.5


def wanted(run: StepRun) -> bool:
    """Return True if the step looks before its next descent."""
    return run.camera and run.looks.due and run.looks.taken < run.parameters.max_looks


def on_arrival(run: StepRun) -> bool:
    """Return True if the approach's first look may be taken before the arm is at rest."""
    return run.looks.taken == 0


def look(run: StepRun, now: float, arriving: bool = False) -> list:
    """Ask for the first frame of a look through the moving gripper's camera; wait in LOOKING.

    ``arriving``: taken on arrival, the arm not at rest yet (:func:`seen` keeps it only if it
    confirms the hole where the step aims).
    """
    looks = run.looks
    looks.taken += 1
    looks.arriving = arriving
    looks.asked_at = now
    looks.height_shift = run.height_shift
    looks.frames, looks.asked = [], 1
    run.stage = Stage.LOOKING
    return [LookRequest(run.step.moving_gripper, now)]


def waiting(run: StepRun, now: float) -> list:
    """Ask for the look's next frame when due; without its frames in time, go on blind.

    The frames are ``frame_interval`` apart; a look whose frames have not all come
    :data:`LOOK_WAIT` after the last was asked for is given up.
    """
    looks = run.looks
    if looks.asked_at is None:
        return []
    count = run.parameters.look_frames
    if looks.asked < count:
        if now < looks.asked_at + looks.asked * run.frame_interval - 1e-9:
            return []
        looks.asked += 1
        return [LookRequest(run.step.moving_gripper, now)]
    if now - (looks.asked_at + (count - 1) * run.frame_interval) > LOOK_WAIT:
        looks.asked_at, looks.due = None, False
        run.stage = Stage.SETTLING
        return [Notice(f'no frame from the camera of gripper {run.step.moving_gripper} within '
                       f'{LOOK_WAIT:g} s; the descent goes on blind', 'warning')]
    return []


def seen(run: StepRun, now: float, sighting: Sighting, height: float, height_std: float
         ) -> list:
    """Take a frame; the look's last: descend, move onto the hole and look again, or go blind.

    ``height`` [m] (base frame) and ``height_std`` [m] are the node's mouth height as the map
    knew it before any look (:func:`~walker_supervisor.core.sighting.locate`).
    """
    looks = run.looks
    looks.frames.append(sighting)
    if len(looks.frames) < run.parameters.look_frames:
        return []  # the look's next frame is asked for when due
    sighting = looks.last = combine(looks.frames)
    looks.done = list(frame_weights(len(looks.frames)))
    looks.asked_at = None
    run.stage = Stage.SETTLING
    gripper = run.step.moving_gripper
    arriving, looks.arriving = looks.arriving, False
    if not sighting.found:
        if arriving:
            return [Notice(f'camera of gripper {gripper}: hole of {run.step.to_node} not seen '
                           f'on arrival ({sighting.reason}); it looks again at rest', 'info')]
        looks.due = False
        return [Notice(f'camera of gripper {gripper}: hole of {run.step.to_node} not seen '
                       f'({sighting.reason}: {sighting.detail}); the descent goes on blind',
                       'warning')]
    position, covariance = locate(looks.sightings + [sighting], height, height_std)
    moved = float(np.hypot(*(position[:2] - run.targets.point_to[:2])))
    spread = math.sqrt(max(float(np.linalg.eigvalsh(covariance[:2, :2]).max()), 0.0))
    higher = spread > LOOK_SPREAD * run.parameters.look_alignment and not looks.raised
    notice = Notice(f'camera of gripper {gripper}: hole of {run.step.to_node} '
                    f'{sighting.distance * 1e3:.2f} mm from the axis; located to +-'
                    f'{spread * 1e3:.2f} mm, {moved * 1e3:.2f} mm from where the step aimed, '
                    f'its mouth {(position[2] - run.targets.point_to[2]) * 1e3:+.2f} mm; '
                    f'look {looks.taken}', 'info')
    precise = spread <= LOOK_SPREAD * run.parameters.look_alignment
    if moved <= run.parameters.look_alignment and (precise or not looks.raised):
        # confirmed: the hole is where the step aims, to what this look can tell (one look
        # from the approach height cannot tell the height: a hole lower by as much as it is
        # off along the line of sight looks the same; the descent feels the height, and a
        # jam looks again with it)
        looks.sightings.append(sighting)
        looks.located, looks.due = (position, covariance), False
        return [notice]
    if arriving:  # the ringing links put the gripper off its joints' place: look at rest
        return [notice, Notice(f'camera of gripper {gripper}: the look on arrival is set '
                               'aside; it looks again at rest', 'info')]
    looks.sightings.append(sighting)
    looks.located = (position, covariance)
    if not _centre_on(run, position, higher):
        looks.due = False
        return [notice, Notice('the hole seen is out of reach; the descent goes on blind',
                               'warning')]
    if higher:  # straight up where the gripper is, to see the hole along a steeper line
        return [notice] + _lift(run, now)
    if precise or looks.taken >= run.parameters.max_looks:
        looks.due = False  # located well enough: a fine line there, then the descent
    return [notice] + transitions.enter_fine(run, now, correction=True)


def _lift(run: StepRun, now: float) -> list:
    """Lift the gripper straight up to the raised point's height, for the next look."""
    up = run.straight_up(run.targets.point_above_to)
    if up is None:
        run.looks.due = False
        return [Notice('no straight lift for a look from higher; the step goes on to the hole '
                       'seen', 'warning')] + transitions.enter_fine(run, now, correction=True)
    run.stage = Stage.MOVING
    run.settled_since = None
    run.deadline = now + run.parameters.phase_timeout
    return [run.trajectory('look_lift', run.theta, up[0], run.tip(), up[1])]


def height_felt(run: StepRun) -> None:
    """Take a height felt on the face: look again if it moved from the one the looks assumed.

    The looks so far stay: with the height felt, they locate the hole along their lines of
    sight.
    """
    looks = run.looks
    if looks.taken and abs(run.height_shift - looks.height_shift) \
            > run.parameters.look_alignment:
        looks.due, looks.taken, looks.raised = True, 0, False


def _centre_on(run: StepRun, position: np.ndarray, higher: bool) -> bool:
    """Move the step's estimate and targets onto the hole located; False when out of reach.

    ``position`` [m] is the hole's mouth in the base frame; with ``higher`` the point above the
    hole goes up to :data:`LOOK_HEIGHT` times the approach height, where the next look sees the
    hole along another line of sight (and the descent starts). The search starts again around
    the hole, from its first probe.
    """
    estimate = run.estimate if run.estimate is not None else run.targets
    shift = np.zeros(3)
    shift[:2] = position[:2] - estimate.point_to[:2]
    height_shift = float(position[2] - estimate.point_to[2])
    above = float(run.targets.point_above_to[2] - run.targets.point_to[2])
    try:
        centred = shifted_targets(run.kinematics, estimate, shift)
        targets = probe_targets(run.kinematics, centred, np.zeros(2), height_shift)
        if higher or run.looks.raised:
            targets = raised_approach(run.kinematics, targets,
                                      (LOOK_HEIGHT if higher else 1.0) * above)
    except KinematicsError:
        return False
    run.estimate, run.targets, run.height_shift = centred, targets, height_shift
    run.looks.raised = run.looks.raised or higher
    run.looks.height_shift = height_shift
    if run.search is not None:
        run.search = HoleSearch(run.search.pattern)
    run.search_over = ''
    return True
