"""COARSE and FINE: from above the old node to above the hole (paper sections 2 and 5).

Coarse motion (controllers in COARSE mode: low gains, acceleration feedback) ends when the tip
error, from the forward kinematics of the measured joints, enters ``coarse_to_fine_region``: the
controllers then switch to FINE mode (higher gains, integral action) while the coarse trajectory
runs on to its end, the point above the hole; the descent is planned then, so that it streams
the moment FINE ends. A coarse motion that comes to rest outside the region goes on in FINE,
with a fine line. Fine motion ends, once the trajectory has ended, as soon as the tip is within
``descent_region`` (the insertion tolerance) of the point above the hole and still closing on
it, joint 1 coming in behind its filter (not swinging through it), or within
``insertion_alignment`` with every joint slower than ``settle_velocity``: the descent need not
wait for the tip to come to rest, since the insertion settles at the mouth and checks the tip
again, across the hole's axis, before anything screws in. A tip that settles (``settle_time``)
anywhere else gets a constant-velocity fine line (paper section 5) from where it settled, up to
:data:`~walker_supervisor.core.transitions.MAX_FINE_LINES` times before insertion is tried
anyway (the screw-in itself is the final check). The entries into FINE and INSERTION are
:mod:`~walker_supervisor.core.transitions`'.
"""

from __future__ import annotations

import numpy as np

from walker_supervisor.core import looking, transitions
from walker_supervisor.core.phases import Stage
from walker_supervisor.core.step_run import StepRun

__all__ = ['coarse_tick', 'fine_settling']


def coarse_tick(run: StepRun, now: float, velocities: np.ndarray) -> list:
    """Hand over to FINE inside the region, or once at rest outside it."""
    if run.tip_error() < run.parameters.coarse_to_fine_region:
        return transitions.enter_fine(run, now, correction=False)
    if run.stage == Stage.ARRIVING and run.settled(now, velocities, run.parameters.settle_time):
        # the coarse motion ended and the arm came to rest outside the region (friction,
        # overshoot): fine motion, with its higher gains and a fine line, takes it there
        return transitions.enter_fine(run, now, correction=True)
    return []


def fine_settling(run: StepRun, now: float, velocities: np.ndarray) -> list:
    """FINE, the motion over: descend once over the hole, or a fine line once at rest.

    Where it would descend, a gripper with a camera looks first (:mod:`.looking`).
    """
    if run.stage == Stage.LOOKING:
        return looking.waiting(run, now)
    descend = _may_descend(run, velocities)
    if looking.wanted(run):
        # the first look is taken where the blind walker would descend: it confirms a hole
        # where the map has it at no more cost than its frames; any other waits for the arm
        # at rest, the links' ringing decayed (the joints say where the gripper would be
        # rigid, the camera sees it where the flexible links put it)
        at_rest = run.settled(now, velocities, run.parameters.look_settle_time)
        if at_rest or (descend and looking.on_arrival(run)):
            return looking.look(run, now, arriving=not at_rest)
        return []
    if descend:
        # the descent need not wait for the tip to come to rest: the insertion settles at the
        # mouth and checks the tip against the axis again before it screws in
        return transitions.enter_insertion(run, now)
    if not run.settled(now, velocities, run.parameters.settle_time):
        return []
    if run.tip_error() <= run.parameters.insertion_alignment \
            or run.tries.fine_lines >= transitions.MAX_FINE_LINES:
        return transitions.enter_insertion(run, now)
    return transitions.enter_fine(run, now, correction=True)  # settled, not aligned: a line


def _may_descend(run: StepRun, velocities: np.ndarray) -> bool:
    """Return True if the tip is over the hole closely enough to start the descent.

    Either it is within ``descent_region`` of the point above the hole and closing on it
    slowly enough not to get there within ``descent_arrival_time`` (joint 1 coming in behind
    its filter: it arrives on the axis during the descent, 0.3 s; a tip swinging through the
    point is not closing so), or within ``insertion_alignment`` with every joint slower than
    ``settle_velocity`` (at rest there, or nearly).

    The tip's velocity is the measured joint velocities through the Jacobian of eq (1), not
    the change of its error between two ticks: a real-time supervisor's ticks come late and
    then bunched up, and 2 ms apart a tip swinging through at half a metre a second looked as
    if it were closing slowly (one went down 33 mm beside the hole).
    """
    error, parameters = run.tip_error_now, run.parameters
    if error <= parameters.descent_region and _closing_slowly(run, velocities, error):
        return True
    return error <= parameters.insertion_alignment \
        and bool(np.all(np.abs(velocities) < parameters.settle_velocity))


def _closing_slowly(run: StepRun, velocities: np.ndarray, error: float) -> bool:
    """Return True if the tip closes on the point above the hole, and slowly.

    Slowly: slower than ``error / descent_arrival_time`` [m/s]; ``error`` [m] is the tip's
    distance from the point, ``velocities`` [rad/s] the joints' in role order.
    """
    tip = run.tip()
    tip_velocity = run.kinematics.jacobian(run.theta)[:3] @ np.asarray(velocities, float)
    towards = float(np.dot(tip_velocity, run.targets.point_above_to - tip))
    speed = float(np.linalg.norm(tip_velocity))
    return towards > 0.0 and speed * run.parameters.descent_arrival_time < error
