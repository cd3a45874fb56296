"""The walk summary table; it lives in :mod:`walker_report.core.steps`, re-exported here.

The walk report prints the same table, and walker_bringup calls the report at the end of a
walk: the table lives in the report's core so that neither package imports the other in a
cycle (walker_bringup -> walker_report, never back).
"""

from walker_report.core.steps import (
    PHASES, StepRow, format_table, rows_from_reports, write_json)

__all__ = ['PHASES', 'StepRow', 'rows_from_reports', 'format_table', 'write_json']
