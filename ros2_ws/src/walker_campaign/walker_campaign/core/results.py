"""The campaign's results file: JSON Lines, one row per line, appended as runs finish.

The first line is the campaign's header (``kind: campaign``: its name, the spec's digest, the
dispersions and sweeps, so the file describes itself); then, per finished run, its step rows
and its run row, written in one append and flushed to disk (``fsync``) before the next, so a
crash loses at most the run being written, which a resume runs again. A run counts as finished
when its run row is in the file; rows of a run without one (a torn last write) are ignored and
cut off when the file is opened to resume.

Every line is a flat JSON object with the same keys for rows of a kind (a table:
``pandas.read_json(path, lines=True)`` reads it). Floats are written by ``repr``: they read
back bit for bit.
"""

from __future__ import annotations

import dataclasses
import fcntl
import json
import os
from pathlib import Path
from typing import Any

from walker_campaign.core.errors import ResultsError
from walker_campaign.core.rows import RUN, STEP
from walker_campaign.core.spec import CampaignSpec

__all__ = ['HEADER', 'Results', 'ResultsWriter', 'campaign_header', 'read_results']

HEADER = 'campaign'


def campaign_header(spec: CampaignSpec) -> dict[str, Any]:
    """Return the header row of a campaign's results file."""
    return {'kind': HEADER, 'name': spec.name, 'digest': spec.digest, 'seed': spec.seed,
            'runs': spec.runs, 'points': spec.point_count, 'total_runs': spec.total_runs,
            'target': spec.target, 'params_file': str(spec.params_file),
            'dispersions': [{'name': d.name, 'columns': list(d.columns), 'apply': d.apply,
                             'describe': d.describe()} for d in spec.dispersions],
            'sweeps': [{'key': s.target.key, 'unit': s.target.spec.unit,
                        'values': [list(v) if isinstance(v, tuple) else v for v in s.values]}
                       for s in spec.sweeps]}


@dataclasses.dataclass
class Results:
    """What a results file holds: the newest header, and the finished runs' rows."""

    header: dict[str, Any]
    runs: dict[int, dict[str, Any]]
    steps: dict[int, list[dict[str, Any]]]

    @property
    def run_rows(self) -> list[dict[str, Any]]:
        """Run rows by index."""
        return [self.runs[i] for i in sorted(self.runs)]

    @property
    def step_rows(self) -> list[dict[str, Any]]:
        """Step rows of the finished runs, by run index then step."""
        return [row for i in sorted(self.runs) for row in self.steps.get(i, [])]


def _parse(path: Path) -> tuple[Results, int]:
    """Read a results file; return its content and the byte length of its whole lines."""
    header: dict[str, Any] | None = None
    runs: dict[int, dict[str, Any]] = {}
    steps: dict[int, list[dict[str, Any]]] = {}
    pending: dict[int, list[dict[str, Any]]] = {}
    good = 0
    with open(path, 'rb') as handle:
        for number, line in enumerate(handle, start=1):
            if not line.endswith(b'\n'):
                break  # a torn last write
            try:
                row = json.loads(line)
            except json.JSONDecodeError:
                raise ResultsError(f'{path}, line {number}: not a JSON row') from None
            good += len(line)
            kind = row.get('kind') if isinstance(row, dict) else None
            if kind == HEADER:
                header = row
            elif kind == STEP:
                pending.setdefault(row['index'], []).append(row)
            elif kind == RUN:
                runs[row['index']] = row
                steps[row['index']] = pending.pop(row['index'], [])
            else:
                raise ResultsError(f'{path}, line {number}: unknown row kind {kind!r}')
    if header is None:
        raise ResultsError(f'{path} has no campaign header: not a campaign results file')
    return Results(header, runs, steps), good


def read_results(path: str | Path) -> Results:
    """Read a campaign's results file (finished runs only).

    Raises
    ------
    ResultsError
        The file is missing, has no header, or a line that is not a row.
    """
    path = Path(path)
    if not path.is_file():
        raise ResultsError(f'no results file {path}')
    return _parse(path)[0]


class ResultsWriter:
    """The one writer of a campaign's results file (an exclusive lock while it is open).

    Opening an existing file resumes it: its header must carry the spec's digest (the same
    seed, route, nominal file, dispersions and sweeps; ``runs`` may differ), the torn end of an
    interrupted write is cut off, and :attr:`finished` lists the runs not to do again.

    Raises
    ------
    ResultsError
        The file belongs to another campaign, or another process is writing it.
    """

    def __init__(self, path: str | Path, spec: CampaignSpec) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._file = open(self.path, 'ab')
        try:
            fcntl.flock(self._file, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            self._file.close()
            raise ResultsError(f'{self.path} is being written by another campaign process'
                               ) from None
        try:
            self.finished = self._resume(spec)
        except Exception:
            self.close()
            raise

    def _resume(self, spec: CampaignSpec) -> set[int]:
        header = campaign_header(spec)
        if self.path.stat().st_size == 0:
            self.append([header])
            return set()
        results, good = _parse(self.path)
        if results.header['digest'] != spec.digest:
            raise ResultsError(
                f'{self.path} holds campaign {results.header["name"]!r} with other parameters '
                f'(digest {results.header["digest"]}, the spec gives {spec.digest}): give this '
                'campaign another results file')
        if good < self.path.stat().st_size:
            self._file.truncate(good)
        if results.header != header:
            self.append([header])  # more (or fewer) runs: the newest header describes the file
        return set(results.runs)

    def append(self, rows: list[dict[str, Any]]) -> None:
        """Append rows in one write and flush them to disk."""
        self._file.write(''.join(json.dumps(row, allow_nan=False) + '\n'
                                 for row in rows).encode())
        self._file.flush()
        os.fsync(self._file.fileno())

    def close(self) -> None:
        """Release the file."""
        if not self._file.closed:
            self._file.close()

    def __enter__(self) -> 'ResultsWriter':
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()
