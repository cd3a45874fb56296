"""The walk session's headless backend: the cores in one lock-step loop, no ROS, no DDS.

What the graph does, without it: the same progress line, per-step table and ``summary.json``,
a rosbag2 bag of the same topics (``<out>/bag``) and the walk report made from it
(``<out>/report``), from the same cores in this process (:func:`walker_headless.runner.walk`).
Each walk starts from the plant's start (``sim.start``): the loop is built for the walk and
closed after it. ``summary.json``'s ``wall_time`` is the loop's wall time and ``runner``
``"headless"``; everything else in it is the same, bit for bit, for the same parameter file
and target.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from walker_bag.core.errors import BagError
from walker_core.joint_roles import PHYSICAL_JOINT_NAMES
from walker_core.parameter_schema import ParameterError
from walker_core.progress import ProgressLine, walk_progress
from walker_headless.recording import WalkRecording
from walker_core.walk_summary import Runner, WalkSummary
from walker_headless.runner import walk
from walker_report.core.steps import format_table, rows_from_reports, write_json
from walker_report.walk_report import report_after_walk
from walker_supervisor.core.survey_file import SURVEY_FILE_NAME, write_survey
from walker_supervisor.core.truss_map import SurveyFileError

from walker_bringup.session_options import SessionError, SessionOptions
from walker_bringup.truss_survey import checked_survey, survey_map

__all__ = ['HeadlessBackend', 'loop_record']


def loop_record(result: WalkSummary) -> dict:
    """Return the ``loop`` entry of ``summary.json``: lock-stepped by calls, never late."""
    return {'clock_mode': 'sim_time', 'plant_time': result.sim_time, 'late_periods': 0,
            'late_efforts': dict.fromkeys(PHYSICAL_JOINT_NAMES, 0), 'lockstep_timeouts': 0,
            'longest_tick_interval': None, 'decision_timeouts': None}


class HeadlessBackend:
    """Walks in the lock-step loop (:class:`~walker_bringup.session.WalkSession`'s backend)."""

    runner = Runner.HEADLESS

    def __init__(self, configuration, options: SessionOptions, out: Path,
                 progress: ProgressLine) -> None:
        self.configuration = configuration
        self.options = options
        self.out = out
        self.progress = progress
        self.report_failed = False
        self.survey = None
        self.exit_codes: dict[str, int | None] = {}  # no node processes

    def start(self) -> None:
        """Make the output directory; refuse to overwrite a bag or a survey that does not fit.

        Both refusals are :class:`SessionError` (code 2), before anything is written.
        """
        if self.options.truss_survey is not None:
            self.survey = checked_survey(self.configuration, self.options.truss_survey)
        bag = self.out / 'bag'
        if self.options.record and bag.exists():
            raise SessionError(f'{bag} already exists and a recording never overwrites a bag: '
                               'choose another --out, or --no-record')
        self.out.mkdir(parents=True, exist_ok=True)
        self.progress.say(f'[walker] output in {self.out}')

    def walk(self, target: str, goal: str = 'walk_to') -> WalkSummary:
        """Walk to ``target`` (``goal`` ``'step'``: one step), print, write, report."""
        options = self.options
        self.progress.say(f'[walker] headless: plant, five controllers, planner and supervisor '
                          f'in one lock-step loop, no DDS; walking to {target}')
        try:
            recording = WalkRecording(self.out / 'bag', options.namespace) \
                if options.record else None
        except BagError as error:
            raise SessionError(str(error)) from None

        def on_feedback(feedback, time: float) -> None:
            text = walk_progress(feedback.step_index, feedback.step_count, int(feedback.phase),
                                 feedback.from_node, feedback.to_node,
                                 feedback.tip_position_error, time)
            self.progress.update(f'[walker] {text}',
                                 key=(feedback.step_index, int(feedback.phase)))

        try:
            result = walk(self.configuration, target, recording, on_feedback,
                          wall_timeout=options.walk_timeout, goal=goal, survey=self.survey)
        except (ParameterError, SurveyFileError) as error:
            self.progress.end()
            raise SessionError(str(error)) from None
        finally:
            if recording is not None:
                recording.close()
        self.progress.end()
        summary = self._summarise(result)
        if result.survey is not None:
            write_survey(self.out / SURVEY_FILE_NAME,
                         survey_map(self.configuration, result.survey))
        if options.record and options.report:
            self.report_failed = not report_after_walk(
                self.out / 'bag', self.out / 'report', self.configuration.path, options.quiet)
        return summary

    def _summarise(self, result: WalkSummary) -> WalkSummary:
        """Print the per-step table and the outcome, write ``summary.json``; return it whole.

        The runner's summary, with the per-step table, the loop's record and the namespace.
        """
        rows = rows_from_reports(result.reports)
        result = dataclasses.replace(result, rows=tuple(rows), loop=loop_record(result),
                                     namespace=self.options.namespace)
        print(format_table(rows) if rows else '[walker] no step was taken')
        rate = self.configuration.walker.timing.control_rate

        def speed(seconds: float) -> float:
            return result.sim_time / seconds if seconds > 0 else float('nan')

        print(f'[walker] loop: headless, lock-stepped by calls, {result.periods} periods of '
              f'{1e3 / rate:g} ms; {result.sim_time:.1f} s simulated in {result.wall_time:.1f} '
              f's of wall time ({speed(result.wall_time):.1f} x real time), the loop '
              f'{result.cpu_time:.1f} s of CPU ({speed(result.cpu_time):.1f} x real time on '
              'one core)')
        fields = result.json_fields('target', 'reached', 'message', 'path', 'timed_out',
                                    'wall_time', 'loop', 'looks')
        fields['grip_monitor'] = {'states': result.grip_states,
                                  'no_gripper_attached': result.grip_losses}
        write_json(rows, self.out / 'summary.json', {**fields, 'runner': result.runner})
        if result.reached:
            print(f'[walker] reached {result.target} in {result.steps_taken} steps, '
                  f'{result.duration:.1f} s of walking; summary in {self.out / "summary.json"}')
        else:
            print(f'[walker] the walk to {result.target} did not reach it: {result.message}')
        return result

    def command(self, which: str) -> str:
        """``hold`` or ``resume``: the headless loop has no walker between walks to tell."""
        raise SessionError(f'{which}: a headless walk runs to its end within walk(); there is no '
                           'walker to tell between walks')

    def stop(self, make_report: bool = True) -> int:
        """Nothing runs between walks; return 6 if a walk report could not be made, else 0.

        The report of each walk is made as it ends (``make_report`` is the graph's).
        """
        return 6 if self.report_failed else 0
