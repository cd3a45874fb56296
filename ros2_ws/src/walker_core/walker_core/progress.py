"""The progress line of a walk: ``run_all.py`` (graph or headless), ``walkerctl``, campaigns.

One place for every tool that shows a walk's or a step's progress (it needs nothing but the
``walker_msgs`` feedback's fields, so the operator's tool and the bring-up share it). On a
terminal the line is rewritten in place; in a log (no terminal) a line is written only when
the step or phase changes, or every ``log_period`` seconds, so a long walk does not flood it.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Sequence
from typing import TextIO

__all__ = ['ProgressLine', 'walk_progress', 'step_progress', 'PHASE_NAMES', 'name_of']

#: Names of the ``walker_msgs/StepPhase`` constants, by value.
PHASE_NAMES = ('IDLE', 'EXTRACTION', 'COARSE', 'FINE', 'INSERTION', 'SAFE_HOLD')


def name_of(value: int, names: Sequence[str]) -> str:
    """Name of a message constant, or ``'unknown (<value>)'``."""
    return names[value] if 0 <= value < len(names) else f'unknown ({value})'


def walk_progress(step_index: int, step_count: int, phase: int, from_node: str, to_node: str,
                  tip_error: float, elapsed: float) -> str:
    """One line of ``walk_to`` feedback (``walker_msgs/action/WalkTo`` fields, SI units).

    During a step: the step, its nodes, the phase and the tip error. Between steps (no step
    under way, ``from_node`` empty, as after the last one): how many steps are done, and the
    phase.
    """
    phase_name = name_of(phase, PHASE_NAMES).lower()
    if not from_node:
        return f'{step_index} of {step_count} steps done: {phase_name} ({elapsed:.0f} s)'
    return (f'step {step_index + 1}/{step_count} {from_node} -> {to_node or "?"}: '
            f'{phase_name}, tip error {tip_error * 1e3:.1f} mm ({elapsed:.0f} s)')


def step_progress(target: str, phase: int, tip_error: float, elapsed: float) -> str:
    """One line of ``step`` feedback (``walker_msgs/action/Step`` fields, SI units)."""
    return (f'step to {target}: {name_of(phase, PHASE_NAMES).lower()}, tip error '
            f'{tip_error * 1e3:.1f} mm ({elapsed:.0f} s)')


class ProgressLine:
    """A status line for long work.

    Parameters
    ----------
    quiet : bool
        Print nothing.
    stream : file, optional
        Where to print (standard error by default, so standard output keeps the result).
    log_period : float
        Without a terminal, the longest time [s] between two lines for the same key.
    clock : callable
        Monotonic time [s] (for tests).
    """

    def __init__(self, quiet: bool = False, stream: TextIO | None = None,
                 log_period: float = 5.0, clock: Callable[[], float] = time.monotonic) -> None:
        self.quiet = quiet
        self.stream = stream if stream is not None else sys.stderr
        self.tty = bool(getattr(self.stream, 'isatty', lambda: False)())
        self.log_period = log_period
        self.clock = clock
        self._last = ''
        self._key: object = None
        self._printed = -float('inf')

    def update(self, text: str, key: object = None) -> None:
        """Show ``text``; ``key`` identifies what it is about (a new key is always shown)."""
        if self.quiet or text == self._last:
            return
        if self.tty:
            self._last = text
            print(f'\r\033[K{text}', end='', file=self.stream, flush=True)
            return
        now = self.clock()
        if key != self._key or now - self._printed >= self.log_period:
            self._key, self._printed, self._last = key, now, text
            print(text, file=self.stream, flush=True)

    def say(self, text: str) -> None:
        """Print a line of progress on a line of its own (not when quiet)."""
        self._line(text, always=False)

    def error(self, text: str) -> None:
        """Print a line that says what went wrong, on a line of its own: also when quiet."""
        self._line(text, always=True)

    def _line(self, text: str, always: bool) -> None:
        if self.tty and self._last:
            print(file=self.stream, flush=True)
        self._last = ''
        if always or not self.quiet:
            print(text, file=self.stream, flush=True)

    def end(self) -> None:
        """Finish the line (on a terminal) so that what follows starts on a new one."""
        if self.tty and self._last and not self.quiet:
            print(file=self.stream, flush=True)
        self._last = ''
