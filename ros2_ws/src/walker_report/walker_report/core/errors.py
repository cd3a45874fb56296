"""Errors of walker_report: bad input is refused with a message naming what was wrong.

Every error is a :class:`ValueError` subclass and is raised before any output file is written.
"""

from __future__ import annotations

__all__ = ['ReportError', 'BagCutShortError']


class ReportError(ValueError):
    """The report cannot be made: the bag, an option or the output directory is unusable."""


class BagCutShortError(ReportError):
    """The bag's MCAP file has no footer (its recorder was killed): recover it first."""
