"""How well the control loop kept its period during a walk, from the plant's own diagnostics.

The plant publishes on ``/diagnostics`` (1 Hz, steady clock) a status named
``<plant node>: plant`` whose message reads ``<clock mode>, t=<plant time> s, ...`` and whose
values count, since it started, the periods each joint's effort came late (``missed
<joint>``), the control periods it stepped late to catch up with the wall clock (``overruns
commands``), the lock-step timeouts (sim time) and, on the wall clock, the longest interval
between two of its ticks. :func:`loop_health` reads that status and :meth:`LoopHealth.summary`
says in one line what a user of ``run_all.py`` needs to know: whether the loop kept real time.

:func:`sources_not_heard` reads the supervisor's status the same way (``<supervisor node>:
walker``, a value per watched source): the sources it has not heard from yet, which make it
refuse a walk; ``run_all.py`` counts the graph ready only once there are none.

Plain Python: the graph client hands over the status's message and values as strings.
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Mapping

__all__ = ['LoopHealth', 'loop_health', 'sources_not_heard', 'PLANT_STATUS_SUFFIX',
           'SUPERVISOR_STATUS_SUFFIX']

#: The plant's status is named after its node: ``/walker/plant: plant``.
PLANT_STATUS_SUFFIX = ': plant'
#: The supervisor's: ``/walker/supervisor: walker``.
SUPERVISOR_STATUS_SUFFIX = ': walker'
_NOT_HEARD = 'not heard from yet'


def sources_not_heard(values: Mapping[str, str]) -> list[str]:
    """Return the sources the supervisor's status says it has not heard from yet, in order.

    Each watched source is a value ``<source>: <LEVEL>: <message>`` (``controller
    a_yaw_joint``: ``ERROR: not heard from yet``).
    """
    return [name for name, value in values.items() if value.endswith(_NOT_HEARD)]

_MESSAGE = re.compile(r'^(?P<mode>\w+), t=(?P<time>[-+0-9.eE]+) s')


@dataclasses.dataclass(frozen=True)
class LoopHealth:
    """The control loop's record in one walk (counts since the plant started).

    Attributes
    ----------
    clock_mode : str
        ``'real_time'`` or ``'sim_time'``.
    plant_time : float
        The plant's time [s] when the status was published.
    late_periods : int
        Control periods the plant stepped late, catching up with the wall clock (real time).
    late_efforts : dict of str to int
        Per joint, the periods its controller's effort came after the plant's next tick.
    lockstep_timeouts : int
        Times the plant stopped waiting for efforts (sim time).
    longest_tick_interval : float or None
        Longest wall time [s] between two of the plant's ticks (real time; None in sim time).
    decision_timeouts : int or None
        Times the plant stopped waiting for the supervisor's decisions (sim time with
        ``sim.wait_for_decisions``; None when it does not wait for them).
    """

    clock_mode: str
    plant_time: float
    late_periods: int
    late_efforts: dict[str, int]
    lockstep_timeouts: int
    longest_tick_interval: float | None
    decision_timeouts: int | None = None

    def summary(self, control_rate: float) -> str:
        """Say in one line, for the end of a walk, whether the loop kept its period.

        Parameters
        ----------
        control_rate : float
            ``timing.control_rate`` [Hz].
        """
        periods = max(1, round(self.plant_time * control_rate))
        joint, late = max(self.late_efforts.items(), key=lambda item: item[1],
                          default=('', 0))
        if self.clock_mode == 'sim_time':
            with_decisions = '' if self.decision_timeouts is None \
                else " with the supervisor's decisions"
            if not self.lockstep_timeouts and not self.decision_timeouts:
                return (f'loop: lock-stepped in sim time{with_decisions}, {periods} periods, '
                        'no timeout')
            return (f'loop: lock-stepped in sim time{with_decisions}, {periods} periods; the '
                    f'plant stopped waiting for late efforts {self.lockstep_timeouts} times'
                    + (f' and for the supervisor {self.decision_timeouts} times'
                       if self.decision_timeouts else ''))
        text = (f'loop: {periods} periods of {1e3 / control_rate:g} ms in real time; the plant '
                f'stepped {self.late_periods} late ({100.0 * self.late_periods / periods:.1f} %)')
        if self.longest_tick_interval is not None:
            text += f', standing still {self.longest_tick_interval * 1e3:.0f} ms at worst'
        if late:
            text += (f'; efforts came late in {late} periods ({100.0 * late / periods:.1f} %, '
                     f'{joint})')
        if self.late_periods or late:
            text += ('. A loop that cannot keep its period tracks worse than in sim time '
                     '(docs/performance.md, Known limits)')
        return text

    def as_dict(self) -> dict:
        """Return the record as JSON-ready values (for the walk's summary file)."""
        return dataclasses.asdict(self)


def loop_health(message: str, values: Mapping[str, str]) -> LoopHealth | None:
    """Read the plant's diagnostic status; None when it is not one (or not readable).

    Parameters
    ----------
    message : str
        The status's message, ``<clock mode>, t=<seconds> s, ...``.
    values : mapping of str to str
        The status's key-value pairs.
    """
    match = _MESSAGE.match(message)
    if match is None:
        return None
    try:
        late_efforts = {key[len('missed '):]: int(value) for key, value in values.items()
                        if key.startswith('missed ')}
        longest = values.get('longest tick interval [ms]')
        decisions = values.get('supervisor gate timeouts')
        return LoopHealth(
            clock_mode=match['mode'], plant_time=float(match['time']),
            late_periods=int(values.get('overruns commands', 0)), late_efforts=late_efforts,
            lockstep_timeouts=int(values.get('lock-step timeouts', 0)),
            longest_tick_interval=None if longest is None else float(longest) * 1e-3,
            decision_timeouts=None if decisions is None else int(decisions))
    except ValueError:
        return None
