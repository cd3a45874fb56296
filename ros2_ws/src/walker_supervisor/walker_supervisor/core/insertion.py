"""INSERTION: down the hole's axis to the node's face, settle, screw in (paper section 2).

Insertion descends along the hole axis to contact: it is commanded ``insertion_overtravel``
past the nominal mouth (:func:`~walker_supervisor.core.transitions.descent_goal`), so that a
node lower than the parameter file says is still reached, and the node's face stops it where
the node really is (a node higher than nominal is not passed through); :mod:`.descent_contact`
feels the face from the joints (:func:`feel_the_face`), and the screw-in is made where the
descent came to rest on it (a descent whose tip leaves the axis by more than
``descent_axis_tolerance`` is stopped and the gripper lifted straight back to the approach
height, to come over the hole again: an insertion attempt, as a jam is; stopped before it went
``descent_region`` down, there is nothing to lift and a fine line brings it over the hole). The
descent moves the joints, which stop in their friction again, so once they have been still for
``mouth_settle_time`` (the vertical descent hardly moves joint 1; after a line at the mouth,
which does, for ``settle_time``) the tip is checked again, now across the hole's axis: more than
``insertion_alignment`` off it, a fine line at the mouth takes it there (up to
:data:`~walker_supervisor.core.transitions.MAX_FINE_LINES` times; more than
``descent_axis_tolerance`` off, the gripper is lifted back instead), and only then is the
gripper screwed in. A jammed screw-in is retried up to ``max_insertion_attempts`` times (each
lift goes straight up from where the gripper jammed), then the step is aborted to SAFE_HOLD;
with a search (:mod:`~walker_supervisor.core.hole_search`), each jam moves the targets to the
next probe instead (descending at the height a jam on the node's face felt), and the step holds
once the last probe has jammed, its reason naming where the joints put the tip at the last jam
from the map's estimate (the search's bound: a resume does not try the same probes again). A
step ends when the gripper reports attached, with the controllers commanded to HOLD under the
new base (which starts their relaxation).
"""

from __future__ import annotations

import math

import numpy as np

from walker_core.gripper_state import GripperState
from walker_core.kinematics import KinematicsError
from walker_supervisor.core import transitions
from walker_supervisor.core.commands import (
    CancelTrajectory, GripperRequest, Notice, SetControlMode)
from walker_supervisor.core.descent_contact import DescentContact
from walker_supervisor.core.phases import Phase, Stage, StepOutcome
from walker_supervisor.core.step_geometry import probe_targets
from walker_supervisor.core.step_run import StepRun

__all__ = ['MAX_MOUTH_LINES', 'MOUTH_LINE_PROGRESS', 'MAX_DEEPER_DESCENTS', 'feel_the_face',
           'at_mouth', 'left_the_axis', 'jammed', 'follow_screwing']

#: Fine lines at the mouth tried before the gripper is screwed in anyway (as above the hole).
MAX_MOUTH_LINES = 3
#: A line at the mouth that left the tip farther from the hole's axis than this fraction of
#: where it started is the last: the tip rests on the node's face or in the mouth's chamfer, held
#: there by friction, and the next line would not move it either (measured on a truss placed to
#: 2 mm: three lines took the tip from 0.52 to 0.50 mm, 0.4 s each).
MOUTH_LINE_PROGRESS = 0.75
#: Times a step's descents go ``insertion_overtravel`` deeper after one met no face and jammed
#: (:func:`_deeper_after_no_face`): a node lower than that under its estimate is beyond what
#: the map allows, and the search goes on at that depth.
MAX_DEEPER_DESCENTS = 3
#: [m] A line at the mouth after the descent felt the face ends this far below where it was
#: felt: it keeps the gripper on the face (and drops it into the chamfer when it gets there)
#: without pressing it so hard that the joints push it sideways.
MOUTH_PRESS = 3e-4


def feel_the_face(run: StepRun, now: float) -> list:
    """Watch a streaming descent for the node's face (:mod:`.descent_contact`).

    Contact is where the gripper will be screwed in. Once it is felt, the rest of the descent
    (down to ``insertion_overtravel`` past the nominal mouth) is cancelled and replaced by a
    short line to :data:`MOUTH_PRESS` below the contact, on the hole's axis: the descent's
    last setpoints would press the gripper into the face a millimetre or two deep, and the
    joints pressing that hard push the tip sideways by as much as the insertion tolerance.
    When that line ends and the joints are still, the tip is judged at the mouth. A descent
    whose stream ends before the tip meets the face is judged at rest instead
    (:func:`at_mouth`), and pressed lightly the same way.
    """
    contact = run.tries.contact
    if contact is None or not contact.update(now, float(run.tip()[2])):
        return []
    contact.judged = True
    if run.parameters.insertion_overtravel <= 0.0:
        return [Notice(_felt(contact), 'info')]  # the descent ends at the mouth: no deeper
    return [Notice(_felt(contact), 'info'), *_press_lightly(run)]


def _press_lightly(run: StepRun) -> list:
    """Replace the descent's press on the face by a light one, on the hole's axis."""
    joints, point = _on_the_face(run, run.tries.contact)
    stop = [CancelTrajectory()] if run.motions.running else []
    run.motions.running = False
    return [*stop, run.trajectory('insertion', run.theta, joints, run.tip(), point)]


def _on_the_face(run: StepRun, contact: DescentContact,
                 press: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Return the joints [rad] and point [m] on the hole's axis :data:`MOUTH_PRESS` below contact.

    The press (``press``) is a line along the hole's axis, which the planner accepts only from
    within the insertion tolerance of it: a tip that met the face farther than
    ``descent_region`` (at most that tolerance) from the axis, as a descent swinging 2-3 mm off
    it does, is pressed straight down where it is, and the lines at the mouth (not a press:
    a fine line, which goes anywhere) bring it over the hole. The point at the nominal mouth
    (and its joints) if the face was not felt or that point is out of reach.
    """
    t = run.targets
    if not contact.felt:
        return t.at_to, t.point_to
    point = np.array([t.point_to[0], t.point_to[1], contact.height - MOUTH_PRESS])
    tip = run.tip()
    if press and np.linalg.norm(tip[:2] - point[:2]) > run.parameters.descent_region:
        point[:2] = tip[:2]
    try:
        joints = run.kinematics.inverse([*point, 0.0, t.at_to[4]], reference=t.at_to)
    except KinematicsError:
        return t.at_to, t.point_to
    return np.asarray(joints, dtype=float), point


def _felt(contact: DescentContact) -> str:
    offset = contact.face_offset * 1e3
    where = 'at' if abs(offset) < 0.05 else ('below' if offset < 0.0 else 'above')
    return (f"the descent met the node's face {abs(offset):.2f} mm {where} the nominal mouth"
            if where != 'at' else "the descent met the node's face at the nominal mouth")


def settle_wait(run: StepRun) -> float:
    """How long [s] the joints must be still at the mouth before the tip is judged.

    ``mouth_settle_time`` after the descent, which moves joint 1 hardly at all; after a line at
    the mouth, which moves joint 1 (it comes in behind its filter slowly enough to look still
    for a moment), ``settle_time``.
    """
    if run.tries.mouth_lines == 0:
        return run.parameters.mouth_settle_time
    return run.parameters.settle_time


def at_mouth(run: StepRun, now: float, velocities: np.ndarray, grippers: dict[str, str]) -> list:
    """Settled at the mouth: check the tip across the axis, then align it or screw in.

    A descent whose stream ended before the tip met the face is judged first, at rest: stopped
    short of its end, the tip rests on the face behind setpoints as deep as the overtravel, and
    that press is lightened (:func:`feel_the_face`) before the tip is judged across the axis.
    """
    if not run.settled(now, velocities, settle_wait(run)):
        return []
    parameters = run.parameters
    unfollowed = _descent_not_followed(run)
    if unfollowed:
        return run.abort(unfollowed, now)
    notices = _judge_contact(run)
    if run.mouth_offset() > parameters.descent_axis_tolerance:
        return notices + left_the_axis(run, now)  # too far to slide at the mouth's height
    if notices and run.tries.contact.felt:  # just felt at rest
        run.stage = Stage.DESCENDING
        return notices + _press_lightly(run)
    return notices + _judged_at_mouth(run, now, grippers)


def _judged_at_mouth(run: StepRun, now: float, grippers: dict[str, str]) -> list:
    """Align the tip at rest at the mouth over the hole's axis, or screw it in.

    A line is tried while the tip is more than ``insertion_alignment`` off the axis, at most
    :data:`MAX_MOUTH_LINES` times, and not again after one that did not bring the tip nearer
    (:data:`MOUTH_LINE_PROGRESS`).
    """
    parameters = run.parameters
    offset, tries = run.mouth_offset(), run.tries
    if offset > parameters.insertion_alignment and tries.mouth_lines < MAX_MOUTH_LINES \
            and offset < MOUTH_LINE_PROGRESS * tries.mouth_offset_lined:
        return _align(run)
    run.stage = Stage.SCREWING
    run.tries.insertion_error = run.mouth_offset()  # the same moment as the plant's
    run.deadline = math.inf
    run.gripper.deadline = now + run.gripper.allowance
    run.gripper.answers_due += 1
    # a retry starts from 'jammed': that report is the last attempt's, not this one's
    run.gripper.state_before_screwing = grippers.get(run.step.moving_gripper, '')
    return [GripperRequest(run.step.moving_gripper, 'screw_in')]


def _descent_not_followed(run: StepRun) -> str:
    """Why a descent that ended with the tip still in the upper half of its way was not one.

    '' if it was one. A node sits within millimetres of its nominal height, far below half
    the approach height (the lowest a joint-space way back lets the tip go, too).

    Its trajectory never reached the joints (a controller or planner restarted a moment
    before): taken for contact, it would put the node's face where the tip stopped and every
    probe after it at that height. The step holds instead, the map unchanged; resume comes
    over the hole and descends again.
    """
    contact = run.tries.contact
    if contact is None or contact.felt or contact.judged \
            or run.parameters.insertion_overtravel <= 0.0:
        return ''
    height = float(run.tip()[2])
    if height <= contact.mouth + 0.5 * (run.targets.point_above_to[2] - contact.mouth):
        return ''
    contact.judged = True
    return (f'the descent ended with the tip {(height - contact.mouth) * 1e3:.1f} mm above the '
            f'nominal mouth, in the upper half of its way down: the joints did not follow it '
            f'(its trajectory lost?); nothing is learned of the node')


def _judge_contact(run: StepRun) -> list:
    """At rest after the descent: say whether it met the face (once per descent)."""
    contact = run.tries.contact
    if contact is None or run.parameters.insertion_overtravel <= 0.0 or contact.judged:
        return []
    contact.judged = True
    if contact.felt:
        return []  # said when it was felt
    if contact.at_rest(float(run.tip()[2])):
        return [Notice(_felt(contact), 'info')]
    return [Notice(f'the descent met no face down to '
                   f'{run.parameters.insertion_overtravel * 1e3:.1f} mm below the nominal mouth: '
                   f'the node may sit lower')]


def _align(run: StepRun) -> list:
    """Run a fine line at the mouth, from where the tip settled onto the hole's axis.

    At the height where the descent felt the face, :data:`MOUTH_PRESS` lower (at the nominal
    mouth if it felt none), on the axis however far the tip rests from it (within
    ``descent_axis_tolerance``): a line that stayed where the tip is would align nothing.
    """
    run.tries.mouth_lines += 1
    run.tries.mouth_offset_lined = run.mouth_offset()
    run.stage = Stage.ALIGNING
    contact = run.tries.contact
    if contact is None:
        joints, point = run.targets.at_to, run.targets.point_to
    else:
        joints, point = _on_the_face(run, contact, press=False)
    return [run.trajectory('fine', run.theta, joints, run.tip(), point)]


def left_the_axis(run: StepRun, now: float) -> list:
    """Stop a descent whose tip has left the hole's axis; lift it straight back up.

    Lowered farther, the gripper would meet the node's face beside the hole. Like a jam it
    counts as an insertion attempt: the gripper rises from where it is to the approach height,
    FINE brings it over the hole again, and a new descent starts.
    """
    offset = run.mouth_offset()
    run.tries.insertions += 1
    reason = (f"the descent left the hole's axis ({offset * 1e3:.1f} mm off, tolerance "
              f'{run.parameters.descent_axis_tolerance * 1e3:.1f} mm)')
    if run.tries.insertions >= _attempt_limit(run):
        return run.abort(f'{reason}; {run.tries.insertions} insertion attempts', now)
    below = _below_the_approach(run)
    up = run.straight_up(run.targets.point_above_to) if below else None
    if below and up is None:
        return run.abort(f'{reason}, and no straight lift from here', now)
    stop = [CancelTrajectory()] if run.motions.running else []
    run.motions.running = False
    if not below:
        # stopped before it went down (the stream had only begun): nothing to lift out of,
        # a fine line from where the tip is brings it over the hole
        run.tries.fine_lines = 0
        return stop + [Notice(f'{reason} before it went down: brought over the hole again')] \
            + transitions.enter_fine(run, now, correction=True)
    run.stage = Stage.RETRY_LIFT
    return stop + [Notice(f'{reason}: lifted back to come over the hole again'),
                   run.trajectory('retry_lift', run.theta, up[0], run.tip(), up[1])]


def _below_the_approach(run: StepRun) -> bool:
    """Return True if the tip is more than ``descent_region`` [m] below the approach height.

    Only then is there a straight lift to make: the planner's extraction line must rise.
    """
    height = run.targets.point_above_to[2] - run.tip()[2]
    return height > run.parameters.descent_region


def _attempt_limit(run: StepRun) -> int:
    """Return the attempts allowed so far: ``max_insertion_attempts``, one more per probe."""
    moved = run.search.probes_moved if run.search is not None else 0
    return run.parameters.max_insertion_attempts + moved


def jammed(run: StepRun, message: str, now: float) -> list:
    """Take a jammed screw-in: lift straight back up to try again, or stop after the last.

    With a search, the targets move to the next probe first; after the last probe, the step
    holds (the base gripper attached, the moving one free above the truss).
    """
    run.tries.insertions += 1
    if run.tries.contact is not None and run.tries.contact.felt:
        run.felt_faces.append(run.theta.copy())  # resting on the face: the node's height
    notices = []
    if run.search is not None:
        notices += _deeper_after_no_face(run)
        offset = _offset_from_estimate(run)
        probe = _next_probe(run)
        if isinstance(probe, str):
            run.search_over = (f'the hole of {run.step.to_node} was not found: {probe}; the '
                               f'last jam with the tip {offset} from the estimate (measured '
                               f'by the joints)')
            return run.abort(f'insertion jammed {run.tries.insertions} times: {message}; '
                             f'{run.search_over}', now)
        notices.append(probe)
    elif run.tries.insertions >= run.parameters.max_insertion_attempts:
        return run.abort(f'insertion jammed {run.tries.insertions} times: {message}', now)
    run.stage = Stage.RETRY_LIFT
    up = run.straight_up(run.targets.point_above_to)
    if up is None:
        return run.abort(f'insertion jammed: {message}; and no straight lift out of the hole '
                         f'from here', now)
    return notices + [run.trajectory('retry_lift', run.theta, up[0], run.tip(), up[1])]


def _deeper_after_no_face(run: StepRun) -> list:
    """After a jam whose descent met no face, send the search's next descents deeper.

    The descent ended ``insertion_overtravel`` below the estimated mouth with nothing under
    the gripper, and the screw-in jammed there: a gripper over the hole would have come to
    rest on the mouth, one beside it on the face (both felt), so the node sits lower than its
    estimate by more than the overtravel. Screwed in at that height, every probe jams, even
    the one over the hole: the next descents end ``insertion_overtravel`` deeper (at most
    :data:`MAX_DEEPER_DESCENTS` times in a step), until one feels the face and the map gives
    the height again (:meth:`~walker_supervisor.core.sequencer.StepSequencer.move_mouth`).
    """
    contact, overtravel = run.tries.contact, run.parameters.insertion_overtravel
    if contact is None or contact.felt or not contact.judged or overtravel <= 0.0 \
            or run.height_shift - overtravel < -MAX_DEEPER_DESCENTS * overtravel - 1e-12:
        return []
    run.height_shift -= overtravel
    return [Notice(f'the descent met no face and the screw-in jammed: the node sits lower '
                   f'than its estimate; the next descents end {overtravel * 1e3:.1f} mm '
                   f'deeper', 'info')]


def _offset_from_estimate(run: StepRun) -> str:
    """Where the tip jammed, measured by the joints, from the map's estimate of the hole.

    ``(+x, +y) mm`` in the truss frame (the frame of the search's probes).
    """
    estimate = run.estimate if run.estimate is not None else run.targets
    c, s = math.cos(estimate.frame.heading), math.sin(estimate.frame.heading)
    dx, dy = (run.tip() - estimate.point_to)[:2]
    return f'({(c * dx - s * dy) * 1e3:+.1f}, {(s * dx + c * dy) * 1e3:+.1f}) mm'


def _next_probe(run: StepRun) -> Notice | str:
    """Move the targets to the search's next probe: a notice, or why the search is over."""
    search = run.search
    if run.estimate is None:
        run.estimate = run.targets
    while True:
        offset = search.next_offset()
        if offset is None:
            pattern = search.pattern
            return (f'the search tried all {len(pattern)} probes within '
                    f'{(pattern.covered + pattern.reach) * 1e3:.1f} mm of the estimate, and '
                    f'the estimate again')
        try:
            run.targets = probe_targets(run.kinematics, run.estimate, offset, run.height_shift)
        except KinematicsError:
            continue  # out of reach: the next probe
        return Notice(f'insertion jammed: probe {search.probe} of {len(search) - 1}, '
                      f'{offset[0] * 1e3:+.1f} mm x {offset[1] * 1e3:+.1f} mm y from the '
                      f'estimate', 'info')


def follow_screwing(run: StepRun, now: float, state: str) -> list:
    """Take the moving gripper's reported state while it screws in."""
    watch = run.gripper
    if state != watch.state_before_screwing:
        watch.state_before_screwing = None  # the gripper has reported on this attempt
    if state == GripperState.ATTACHED:
        return _finish(run, now)
    if state == GripperState.JAMMED and watch.state_before_screwing is None:
        return jammed(run, 'the screw-in jammed', now)
    if now > watch.deadline:
        return run.abort(f'gripper {run.step.moving_gripper} did not screw in in time (it '
                         f'reports {state or "nothing"})', now)
    return []


def _finish(run: StepRun, now: float) -> list:
    """Screwed in: the step ends, HOLD under the new base, whose controllers relax the chain.

    The hole drew the gripper onto its axis while the joints stayed in their friction: the
    links are bent, and the joint angles would misplace the base frame of the next step by the
    bend (about a millimetre at the tip). The controllers' relaxation dither, started by this
    base change, lets the joints slide out of it by ``relaxed_at``; the next step measures its
    stance again after that.
    """
    run.relaxed_at = now + run.parameters.relaxation_wait
    run.enter(Phase.IDLE, now, Stage.NONE)
    run.grippers[run.step.moving_gripper] = GripperState.ATTACHED
    run.base_gripper = run.step.moving_gripper
    search = run.search
    run.outcome = StepOutcome(True, '', dict(run.durations), now - run.step_started,
                              run.tries.insertion_error, run.tries.insertions + 1,
                              search.probes_moved if search is not None else 0,
                              float(np.linalg.norm(search.offset)) if search is not None
                              else 0.0)
    run.outcome_taken = False
    return [SetControlMode('hold', run.step.moving_gripper)]
