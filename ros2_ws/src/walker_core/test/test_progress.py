"""The progress line of walk-to and step: in place on a terminal, sparse in a log, or quiet."""

import io

from walker_core.progress import ProgressLine, step_progress, walk_progress


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


class _Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def test_the_lines_say_the_step_the_phase_and_the_tip_error_in_mm():
    assert walk_progress(1, 3, 2, 'n1_2', 'n2_2', 0.0123, 42.4) == \
        'step 2/3 n1_2 -> n2_2: coarse, tip error 12.3 mm (42 s)'
    assert step_progress('n1_2', 4, 0.0005, 3.0) == \
        'step to n1_2: insertion, tip error 0.5 mm (3 s)'


def test_between_steps_the_line_counts_the_steps_done_instead_of_a_step_past_the_last():
    # after the last step the feedback has no step under way: index = count, no nodes
    assert walk_progress(5, 5, 0, '', '', 0.0, 23.2) == '5 of 5 steps done: idle (23 s)'


def test_quiet_prints_nothing():
    stream = _Terminal()
    line = ProgressLine(quiet=True, stream=stream)
    line.update('step 1/3', key=1)
    line.end()
    assert stream.getvalue() == ''


def test_a_terminal_line_is_rewritten_in_place_and_ended_once():
    stream = _Terminal()
    line = ProgressLine(stream=stream)
    line.update('a', key=1)
    line.update('a', key=1)  # unchanged: not written again
    line.update('b', key=1)
    line.end()
    assert stream.getvalue() == '\r\033[Ka\r\033[Kb\n'


def test_a_log_gets_a_line_per_new_phase_and_otherwise_one_per_period():
    stream, clock = io.StringIO(), _Clock()
    line = ProgressLine(stream=stream, log_period=5.0, clock=clock)
    line.update('coarse 10 mm', key='coarse')
    clock.now = 1.0
    line.update('coarse 8 mm', key='coarse')  # same phase, within the period: skipped
    line.update('fine 1 mm', key='fine')  # new phase: written
    clock.now = 7.0
    line.update('fine 0.5 mm', key='fine')  # the period is over: written
    line.end()
    assert stream.getvalue().splitlines() == ['coarse 10 mm', 'fine 1 mm', 'fine 0.5 mm']


def test_a_said_line_ends_the_status_line_and_an_error_is_shown_even_when_quiet():
    terminal = _Terminal()
    line = ProgressLine(stream=terminal)
    line.update('step 1/3: coarse')
    line.say('[walker] graph ready')
    assert terminal.getvalue() == '\r\033[Kstep 1/3: coarse\n[walker] graph ready\n'
    quiet = io.StringIO()
    line = ProgressLine(quiet=True, stream=quiet)
    line.say('[walker] graph ready')
    line.error('[walker] error: the plant died')
    assert quiet.getvalue() == '[walker] error: the plant died\n'
