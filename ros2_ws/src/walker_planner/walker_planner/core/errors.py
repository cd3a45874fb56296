"""Errors of the planner: every refusal is a ``ValueError`` whose message names what was wrong."""

from __future__ import annotations

__all__ = [
    'PlanningError', 'InvalidRequestError', 'WorkspaceError', 'LimitError', 'NoSolutionError',
]


class PlanningError(ValueError):
    """A trajectory that cannot be planned; nothing was changed."""


class InvalidRequestError(PlanningError):
    """A malformed request: unknown type, wrong lengths, NaN or infinity, bad option."""


class WorkspaceError(PlanningError):
    """A path that leaves the workspace or the joint limits; the message says where."""


class LimitError(PlanningError):
    """A request whose limits are out of range, or a trajectory that would break a limit."""


class NoSolutionError(PlanningError):
    """The bang-bang node-to-node problem has no solution for the given data."""
