"""The campaign's progress line: runs done, success so far, the pace and what is left."""

from __future__ import annotations

import math

__all__ = ['progress_text', 'duration_text']


def duration_text(seconds: float) -> str:
    """Return a duration for people: ``45 s``, ``12 min``, ``3 h 05 min``."""
    if not math.isfinite(seconds):
        return '?'
    seconds = max(0.0, seconds)
    if seconds < 90:
        return f'{seconds:.0f} s'
    if seconds < 5400:
        return f'{seconds / 60:.0f} min'
    hours, minutes = divmod(round(seconds / 60), 60)
    return f'{hours} h {minutes:02d} min'


def progress_text(done: int, total: int, reached: int, walks: int, finished_now: int,
                  elapsed: float) -> str:
    """One progress line.

    Parameters
    ----------
    done, total : int
        Runs with a result (resumed ones included), and runs in the campaign.
    reached, walks : int
        Runs that reached their target, among the walks carried out so far.
    finished_now : int
        Runs finished since this process started (the pace is theirs).
    elapsed : float
        Seconds since this process started.
    """
    rate = f'{reached}/{walks} reached ({100 * reached / walks:.1f} %)' if walks else \
        'none walked yet'
    left = total - done
    if finished_now and elapsed > 0 and left:
        pace = finished_now / elapsed
        eta = f', {3600 * pace:.0f} walks/h, ETA {duration_text(left / pace)}'
    else:
        eta = ''
    return f'{done}/{total} runs, {rate}{eta}'
