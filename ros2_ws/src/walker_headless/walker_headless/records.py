"""What the supervisor publishes about a walk, as plain records with the fields of its messages.

:class:`StepReportRecord` has the fields of ``walker_msgs/StepReport`` and
:class:`PhaseRecord` those of ``walker_msgs/StepPhase`` (less the header: ``stamp`` [ns]), as
the supervisor node fills them from the walk runner's records
(:func:`walker_supervisor.core.reports.report_fields`, :func:`~walker_supervisor.core.
reports.phase_fields`), so that what reads the messages
(:func:`walker_report.core.steps.rows_from_reports`, the bag's encoder) reads these alike.
"""

from __future__ import annotations

import dataclasses

__all__ = ['StepReportRecord', 'PhaseRecord']


@dataclasses.dataclass(frozen=True)
class StepReportRecord:
    """One ended step's figures (``walker_msgs/StepReport``; SI units)."""

    stamp: int
    step_index: int
    step_count: int
    base_gripper: str
    moving_gripper: str
    base_node: str
    from_node: str
    to_node: str
    sweep: float
    success: bool
    message: str
    phase_names: list
    phase_durations: list
    duration: float
    time_optimal_bound: float
    bound_ratio: float
    insertion_error: float
    insertion_error_estimated: float
    residual_vibration: float
    insertion_attempts: int
    search_probes: int = 0
    hole_offset: float = float('nan')


@dataclasses.dataclass(frozen=True)
class PhaseRecord:
    """The step's phase as published (``walker_msgs/StepPhase``)."""

    stamp: int
    phase: int
    base_gripper: str
    step_index: int
    step_count: int
    from_node: str
    to_node: str
    base_node: str
    base_heading: float
    phase_progress: float
    reason: str
