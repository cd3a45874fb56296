"""A whole walk in the lock-step loop: the library call behind ``run_all.py --headless``.

:func:`walk` builds the robot side (:class:`~walker_headless.loop.RobotLoop`) and the
supervisor's walk runner in its shell (:class:`~walker_headless.shell.WalkShell`) from the
walker's configuration, gives the runner a ``walk_to`` goal and runs them period by period
until the goal has ended::

    state t_k out (recorded, to the planner's stream) -> the controllers answer ->
    the supervisor hears and decides at t_k -> the plant steps to t_(k+1)

Deterministic: the same configuration and target give the same walk, bit for bit, on any machine
load (nothing in it reads a wall clock but the optional time limit). One process, one core,
no DDS: a campaign runs many at once.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable

from walker_config.core.configuration import WalkerConfiguration
from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_core.urdf import description_urdf
from walker_core.walk_summary import Runner, WalkSummary
from walker_supervisor.core.commands import Feedback
from walker_supervisor.core.survey_file import SurveyKeeper

from walker_headless.loop import RobotLoop
from walker_headless.shell import WalkShell

__all__ = ['walk', 'DIAGNOSTICS_PERIOD']

#: [s] of simulated time between two of the plant's ``/diagnostics`` statuses
DIAGNOSTICS_PERIOD = 1.0
#: Periods between two looks at the wall clock (the time limit, the progress)
_WALL_CHECK_PERIODS = 250


def walk(configuration: WalkerConfiguration, target: str, recording=None,
         progress: Callable[[Feedback, float], None] | None = None,
         say: Callable[[str, str], None] | None = None,
         wall_timeout: float = math.inf, goal: str = 'walk_to', survey: dict | None = None,
         whole_trajectories: bool | None = None) -> WalkSummary:
    """Walk from the plant's start (``sim.start``) to ``target``, headless; return how it went.

    The summary (:class:`~walker_core.walk_summary.WalkSummary`, ``runner`` ``'headless'``)
    holds the runner's own fields too: the step reports and phase messages, the simulated time
    and periods, the loop's CPU time and the truss map at the end (``survey``). Its ``rows``
    and ``loop`` are left for the session to make (:mod:`walker_bringup.headless_session`).

    Parameters
    ----------
    configuration : WalkerConfiguration
        The walker's configuration (:func:`~walker_config.core.configuration.load_configuration`).
    target : str
        The truss node to walk to.
    recording : WalkRecording, optional
        The bag to record into (not closed here).
    progress : callable, optional
        ``progress(feedback, time)``: the goal's feedback (at most every ``FEEDBACK_PERIOD``
        of simulated time) and the simulated time [s].
    say : callable, optional
        ``say(level, text)`` for what the supervisor would log.
    wall_timeout : float
        Longest wall time [s] the walk may take; it ends unreached after it.
    goal : str
        ``'walk_to'`` (any node) or ``'step'`` (one step to a neighbouring node).
    survey : dict, optional
        A truss survey to start from (a survey file's content); raises
        :class:`~walker_supervisor.core.truss_map.SurveyFileError` if it does not fit. Without
        it the walk starts from ``supervisor.truss_survey_file`` where that file exists; the
        walk's survey is written to that file at the end, as the graph's supervisor does.
    whole_trajectories : bool, optional
        The controllers hold whole trajectories instead of following a setpoint stream
        (:class:`~walker_headless.loop.RobotLoop`); by default as the graph's planner does
        (``planner.send_whole_trajectories``).

    Raises
    ------
    ParameterError
        If the plant refuses its settings.
    """
    started = time.monotonic()
    loop = RobotLoop(configuration, recording, whole_trajectories)
    try:
        if recording is not None:
            recording.robot_description(0, description_urdf(configuration.walker))
        shell = WalkShell(loop, say, progress)
        # supervisor.truss_survey_file, as the graph's supervisor keeps it; ``survey`` over it
        keeper = SurveyKeeper(shell.runner.mapped.map,
                              configuration.supervisor.truss_survey_file)
        if survey is not None:
            shell.runner.mapped.map.load(survey)
        shell.send_goal(goal, target)
        cpu_started = _cpu_time(loop)
        diagnostics_ns = round(DIAGNOSTICS_PERIOD * 1e9)
        next_diagnostics = 0
        periods = 0
        message = None
        while True:
            loop.sense()
            loop.control()
            shell.decide()
            if recording is not None and loop.stamp >= next_diagnostics \
                    and not shell.refusal:
                next_diagnostics += diagnostics_ns
                _plant_diagnostics(recording, loop)
            if shell.done:
                break
            loop.step()
            periods += 1
            if periods % _WALL_CHECK_PERIODS == 0 and time.monotonic() - started > wall_timeout:
                message = f'the walk did not end within {wall_timeout:g} s of wall time'
                break
        failure = keeper.write_if_changed()
        if failure is not None and say is not None:
            say('warning', failure)
        return dataclasses.replace(
            _result(target, shell, loop, started, message),
            cpu_time=_cpu_time(loop) - cpu_started, timed_out=message is not None,
            survey=shell.runner.mapped.map.to_dict())
    finally:
        loop.close()


def _cpu_time(loop: RobotLoop) -> float:
    """[s] CPU time of this process and of the wrist cameras' renders, in their own process."""
    return time.process_time() + loop.plant.render_cpu_time


def _result(target: str, shell: WalkShell, loop: RobotLoop, started: float,
            message: str | None) -> WalkSummary:
    ended = shell.ended
    reached = ended is not None and ended.success and message is None
    if message is None:
        message = shell.refusal or ('' if reached else ended.message)
    return WalkSummary(
        target=target, reached=reached, message=message,
        path=tuple(ended.path) if ended is not None else (),
        steps_taken=ended.steps_taken if ended is not None else 0,
        duration=ended.duration if ended is not None else 0.0,
        wall_time=time.monotonic() - started, runner=Runner.HEADLESS,
        reports=tuple(shell.reports), phases=tuple(shell.phases), looks=tuple(shell.looks),
        sim_time=loop.time,
        periods=loop.stamp // loop.period_ns, grip_states=loop.grip_states,
        grip_losses=loop.grip_losses)


def _plant_diagnostics(recording, loop: RobotLoop) -> None:
    """Record the plant's status as its node publishes it (lock-stepped: nothing missed)."""
    values = {f'missed {joint}': 0 for joint in PHYSICAL_JOINT_NAMES}
    values.update({'refused commands': loop.counts['refused'],
                   'saturated commands': loop.counts['saturated'],
                   'expired commands': 0, 'overruns commands': 0, 'lock-step timeouts': 0,
                   'not waited for': ''})
    recording.diagnostics(loop.stamp, f'{recording.namespace}/plant: plant', 'walker_sim', 0,
                          f'sim_time, t={loop.plant.time:.3f} s, 0 missed command periods',
                          values)
