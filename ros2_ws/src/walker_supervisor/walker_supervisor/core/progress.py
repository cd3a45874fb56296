"""How far the current phase of a step has come (``StepPhase.phase_progress``)."""

from __future__ import annotations

import math

from walker_supervisor.core.phases import Phase
from walker_supervisor.core.step_run import StepRun

__all__ = ['PhaseProgress']


class PhaseProgress:
    """The fraction of the current phase done, in [0, 1], never decreasing within a phase.

    EXTRACTION, COARSE and INSERTION go by time: the time in the phase over its planned
    duration, the sum of its timed parts (EXTRACTION: the unscrewing, ``screw_time``, and the
    lift; COARSE: the coarse motion; INSERTION: the descent, ``mouth_settle_time`` and the
    screw-in), each motion as planned once it streams and, until then, as the last one of its
    kind was (0 before the first). FINE goes by the tip error: 0 at ``coarse_to_fine_region``,
    1 at ``insertion_alignment``. The value stays at 1 when a phase runs over its plan (a
    correction line, a retried screw-in); 0 in IDLE and SAFE_HOLD.
    """

    def __init__(self) -> None:
        self._value = 0.0  # of the phase entered at _key
        self._key: tuple | None = None

    def of(self, run: StepRun, now: float) -> float:
        """Return the progress of ``run``'s phase at ``now`` [s]."""
        if not run.busy or run.targets is None:
            return 0.0
        key = (run.phase, run.phase_started)
        if key != self._key:
            self._key, self._value = key, 0.0
        parameters = run.parameters
        if run.phase == Phase.FINE:
            value = (parameters.coarse_to_fine_region - run.tip_error()) \
                / (parameters.coarse_to_fine_region - parameters.insertion_alignment)
        else:
            motions = run.motions.planned
            planned = {
                Phase.EXTRACTION: run.screw_time + motions.get('extraction', 0.0),
                Phase.COARSE: motions.get('coarse', 0.0),
                Phase.INSERTION: motions.get('insertion', 0.0) + parameters.mouth_settle_time
                + run.screw_time}[run.phase]
            value = (now - run.phase_started) / planned if planned > 0.0 else 0.0
        if math.isfinite(value):
            self._value = max(self._value, min(1.0, value))
        return self._value
