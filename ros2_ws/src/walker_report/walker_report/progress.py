"""A progress line for long work: rewritten in place on a terminal, sparse in a log.

No dependency (tqdm or rich would do more, but one line per stage is all the report needs):
on a terminal the line shows a bar and is redrawn at most ten times a second; when the output
is a file or a pipe (CI logs, run_all.py's output captured) a stage is printed when it starts,
at every quarter of its work and when it ends, so logs stay short.
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

__all__ = ['ProgressLine']

_BAR = 24
_REDRAW_PERIOD = 0.1  # [s]


class ProgressLine:
    """Report ``(stage, done, total)`` updates on one line; silent when ``quiet``.

    Parameters
    ----------
    quiet : bool
        Print nothing.
    stream : text stream, optional
        Where to print (default: standard output).
    prefix : str
        Put before every line, e.g. ``[walk_report]``.
    """

    def __init__(self, quiet: bool = False, stream: TextIO | None = None,
                 prefix: str = '') -> None:
        self.quiet = quiet
        self.stream = stream or sys.stdout
        self.tty = bool(getattr(self.stream, 'isatty', lambda: False)())
        self.prefix = f'{prefix} ' if prefix else ''
        self._stage = None
        self._quarter = -1
        self._drawn_at = 0.0
        self._open = False

    def __call__(self, stage: str, done: int, total: int) -> None:
        """Show that ``done`` of ``total`` units of ``stage`` are done."""
        if self.quiet:
            return
        total = max(int(total), 1)
        done = min(max(int(done), 0), total)
        new_stage = stage != self._stage
        if new_stage:
            self._stage, self._quarter = stage, -1
        if self.tty:
            now = time.monotonic()
            if not new_stage and done < total and now - self._drawn_at < _REDRAW_PERIOD:
                return
            self._drawn_at = now
            filled = _BAR * done // total
            self.stream.write(f'\r\033[K{self.prefix}{stage} [{"#" * filled}'
                              f'{"." * (_BAR - filled)}] {done}/{total}')
            self._open = True
            if done == total:
                self.stream.write('\n')
                self._open = False
            self.stream.flush()
            return
        quarter = 4 * done // total
        if quarter != self._quarter:
            self._quarter = quarter
            self.stream.write(f'{self.prefix}{stage}: {done}/{total}\n')
            self.stream.flush()

    def close(self) -> None:
        """End an unfinished line on a terminal."""
        if self._open and not self.quiet:
            self.stream.write('\n')
            self.stream.flush()
            self._open = False
