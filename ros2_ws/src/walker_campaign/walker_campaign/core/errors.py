"""The campaign's errors: each message names what was wrong."""

from __future__ import annotations

__all__ = ['SpecError', 'ResultsError']


class SpecError(ValueError):
    """A campaign spec that cannot run.

    The message names the field (``dispersions.x.normal``) and the rule. Nothing has been run
    or written.
    """


class ResultsError(ValueError):
    """A results file that does not belong to the spec, or cannot be read."""
