"""The per-step table of a walk: one row per step report, as text and as JSON.

run_all.py prints it at the end of a walk (through :mod:`walker_bringup.summary`) and the walk
report prints and embeds it; both build it from ``walker_msgs/StepReport`` messages, live or
decoded from a bag.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

__all__ = ['PHASES', 'StepRow', 'rows_from_reports', 'table_cells', 'format_table',
           'format_markdown', 'write_json']

PHASES = ('extraction', 'coarse', 'fine', 'insertion')


@dataclasses.dataclass(frozen=True)
class StepRow:
    """Figures of one step (SI units: s, m, rad)."""

    index: int
    gripper: str
    from_node: str
    to_node: str
    sweep: float
    success: bool
    phase_durations: dict[str, float]
    duration: float
    bound: float
    insertion_error: float
    insertion_error_estimated: float
    residual_vibration: float
    attempts: int
    message: str
    search_probes: int = 0  # probes of a search on a jam
    hole_offset: float = math.nan  # [m] of the probe that screwed in from the map's estimate

    @property
    def bound_ratio(self) -> float:
        """Step time over the step's time-optimal lower bound (NaN when it is unknown)."""
        return self.duration / self.bound if self.bound > 0 else math.nan


def rows_from_reports(reports) -> list[StepRow]:
    """Rows from ``walker_msgs/StepReport`` messages (or objects with the same fields)."""
    rows = []
    for r in reports:
        rows.append(StepRow(
            index=int(r.step_index), gripper=r.moving_gripper, from_node=r.from_node,
            to_node=r.to_node, sweep=float(r.sweep), success=bool(r.success),
            phase_durations=dict(zip(r.phase_names, (float(v) for v in r.phase_durations),
                                     strict=False)),
            duration=float(r.duration), bound=float(r.time_optimal_bound),
            insertion_error=float(r.insertion_error),
            insertion_error_estimated=float(r.insertion_error_estimated),
            residual_vibration=float(r.residual_vibration),
            attempts=int(r.insertion_attempts), message=r.message,
            search_probes=int(getattr(r, 'search_probes', 0)),
            hole_offset=float(getattr(r, 'hole_offset', math.nan))))
    return rows


def _number(value: float, scale: float = 1.0, digits: int = 2) -> str:
    return '-' if not math.isfinite(value) else f'{value * scale:.{digits}f}'


def table_cells(rows: list[StepRow]) -> tuple[list[str], list[list[str]]]:
    """Return the header and the body cells of the per-step table, a totals line last.

    Times are in s, errors and vibration in mm, the sweep in degrees.
    """
    header = (['step', 'gripper', 'from -> to', 'sweep'] + [p[:6] for p in PHASES]
              + ['total s', 'bound s', 'ratio', 'ins. err mm', 'vib. mm', 'tries', 'ok'])
    body = []
    for row in rows:
        body.append([
            str(row.index + 1), row.gripper, f'{row.from_node} -> {row.to_node}',
            f'{math.degrees(row.sweep):+.0f}',
            *(_number(row.phase_durations.get(p, math.nan)) for p in PHASES),
            _number(row.duration), _number(row.bound), _number(row.bound_ratio),
            _number(row.insertion_error, 1e3), _number(row.residual_vibration, 1e3),
            str(row.attempts), 'yes' if row.success else 'NO'])
    if rows:
        total = sum(r.duration for r in rows)
        bound = sum(r.bound for r in rows)
        body.append(['all', '', '', '', '', '', '', '', _number(total),
                     _number(bound) if bound > 0 else '-',
                     _number(total / bound) if bound > 0 else '-', '', '', '', ''])
    return header, body


def format_table(rows: list[StepRow]) -> str:
    """Format the per-step table as aligned text, with a totals line."""
    header, body = table_cells(rows)
    widths = [max(len(h), *(len(line[i]) for line in body)) if body else len(h)
              for i, h in enumerate(header)]
    lines = ['  '.join(h.rjust(w) for h, w in zip(header, widths, strict=True))]
    lines.append('  '.join('-' * w for w in widths))
    lines += ['  '.join(c.rjust(w) for c, w in zip(line, widths, strict=True)) for line in body]
    failures = [f'step {r.index + 1}: {r.message}' for r in rows if not r.success]
    return '\n'.join(lines + failures)


def format_markdown(rows: list[StepRow]) -> str:
    """Format the per-step table as a Markdown table, with a totals line."""
    header, body = table_cells(rows)
    lines = ['| ' + ' | '.join(header) + ' |', '|' + '---|' * len(header)]
    lines += ['| ' + ' | '.join(cell.replace('|', '\\|') for cell in line) + ' |'
              for line in body]
    return '\n'.join(lines)


def write_json(rows: list[StepRow], path: Path, extra: dict | None = None) -> None:
    """Save the rows (and any extra figures) as JSON."""
    def clean(value):
        return None if isinstance(value, float) and not math.isfinite(value) else value

    data = {'steps': [{k: clean(v) for k, v in {**dataclasses.asdict(r),
                                                  'bound_ratio': r.bound_ratio}.items()}
                      for r in rows]}
    data.update(extra or {})
    Path(path).write_text(json.dumps(data, indent=1))
